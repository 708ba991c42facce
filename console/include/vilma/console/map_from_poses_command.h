// `vilma map-from-poses DATASET --poses TRAJ --out MAP_DIR`: a VI-map from an ASL dataset and a
// given trajectory (mapping/from_poses, docs/map-from-poses.md).
#pragma once

#include <ostream>
#include <string>
#include <vector>

namespace vilma::console {

int RunMapFromPosesCommand(const std::vector<std::string>& args, std::ostream& out,
                           std::ostream& err);

}  // namespace vilma::console
