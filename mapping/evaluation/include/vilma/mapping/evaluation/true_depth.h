// True depth maps of a simulated dataset (docs/dense.md, "Judging"): each vertex camera gets
// the depth of the simulator's world seen from the map's pose of that camera, ray-cast per
// pixel of the camera's distortion-free pinhole. For maps whose frame G is the simulator's
// world W (e.g. `vilma map-from-poses` with the dataset's ground truth): fusing them measures
// the TSDF stage alone, fusing stereo depth measures both.
#pragma once

#include <vector>

#include "vilma/core/progress.h"
#include "vilma/mapstore/vi_map.h"
#include "vilma/sim/world.h"

namespace vilma::mapping {

struct TrueDepthOptions {
  std::vector<int> cameras = {0};  // rig cameras that get depth
  double max_depth_m = 30.0;       // farther surfaces give no depth
  double depth_unit_m = 0.001;
  std::string Validate() const;
};

// Replaces the depth maps of those cameras of every vertex of `missions` (empty: all); returns
// how many were stored.
int AttachTrueDepth(mapstore::VIMap* map, const std::vector<mapstore::MissionId>& missions,
                    const sim::World& world, const TrueDepthOptions& options,
                    ProgressObserver* progress = nullptr);

}  // namespace vilma::mapping
