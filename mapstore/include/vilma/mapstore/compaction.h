// Making a VI-map smaller without touching what localization and optimization use
// (docs/vi-map.md "Compact maps"): keypoints without a landmark carry a 64-byte descriptor each
// and are used by nothing but `itl` (landmarks from free tracks) and, as extra query features,
// loop closure. Removing them re-indexes the remaining keypoints of each frame and the landmark
// observations that point at them, so both directions of the reference stay in step.
#pragma once

#include <cstddef>
#include <vector>

#include "vilma/mapstore/vi_map.h"

namespace vilma::mapstore {

struct KeypointCompactionStats {
  std::size_t keypoints_before = 0;
  std::size_t keypoints_after = 0;
};

// Removes every keypoint without a landmark from the visual frames of `vertices` (empty: every
// vertex of the map), keeping the order of the others.
KeypointCompactionStats RemoveKeypointsWithoutLandmark(VIMap* map,
                                                       const std::vector<VertexId>& vertices = {});

}  // namespace vilma::mapstore
