// `vilma localize-kitti`: the real-image localization check of issue 7 on a KITTI odometry
// stereo slice (docs/localizer.md, "KITTI localization check").
//
//   vilma localize-kitti KITTI_DIR [--config localizer.yaml] [--features FEATURES.yaml]
//                        [--indoor-features]
//
// Builds a map from the even frames (stereo-triangulated BRISK landmarks placed with the
// ground-truth poses), localizes every odd left image against it and prints a per-frame table
// with recall (within 0.3 m and 2 deg), median errors and timings.
#pragma once

#include <ostream>
#include <string>
#include <vector>

#include "vilma/console/command.h"

namespace vilma::console {

void PrintKittiHelp(std::ostream& out);

// The whole command; returns kExitOk, kExitInputError or kExitUsage.
int RunKittiCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace vilma::console
