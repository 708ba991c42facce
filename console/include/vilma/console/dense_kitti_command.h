// `vilma dense-kitti`: dense reconstruction of a KITTI odometry stereo slice with its given
// poses (docs/dense.md, "KITTI"): SGBM depth per frame (the images are rectified already),
// the neighbour-view depth filter, TSDF fusion, a PLY mesh, the depth consistency between
// neighbouring frames and timings. The same library calls as the console's dense commands,
// without a VI-map (KITTI's slices have no IMU).
//
//   vilma dense-kitti KITTI_DIR --out MESH.ply [--every N] [--voxel M] [--truncation M]
//                     [--max-depth M] [--num-disparities N] [--render PNG]
#pragma once

#include <ostream>
#include <string>
#include <vector>

#include "vilma/console/command.h"

namespace vilma::console {

// Returns kExitOk, kExitInputError or kExitUsage.
int RunDenseKittiCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace vilma::console
