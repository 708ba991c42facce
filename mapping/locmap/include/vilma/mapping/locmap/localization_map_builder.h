// A localization map (localizer/localization_map.h) from a VI-map: the map code's side of the
// boundary, so that the localizer knows no VI-map (architecture.md section 4: localizer/ does
// not depend on mapstore/). maplab's localization summary map: the good landmarks of the
// missions that share the frame G, their observations' descriptors and observer vertices.
#pragma once

#include <vector>

#include "vilma/localizer/localization_map.h"
#include "vilma/mapping/locmap/landmark_covariance.h"
#include "vilma/mapstore/vi_map.h"

namespace vilma::mapping {

// The VI-map's ids as the localization map stores them (same 128 bits) and back.
inline localizer::MapObjectId ToMapObjectId(const mapstore::Id& id) { return {id.hi, id.lo}; }
inline mapstore::Id ToVIMapId(const localizer::MapObjectId& id) {
  mapstore::Id out;
  out.hi = id.hi;
  out.lo = id.lo;
  return out;
}

// Which missions of a VI-map share the frame G, so that their landmarks can be summarized
// together: the anchored missions (baseframe known: T_G_M is meaningful) when there is one;
// else the FIRST mission alone, whose odometry frame M then is G (T_G_M = identity). An
// unanchored mission after the first one (e.g. the daemon's new mission after a filter reset,
// docs/daemon.md) has its own unknown frame: mixing its landmarks in would place them wrongly.
std::vector<mapstore::MissionId> MissionsInCommonFrame(const mapstore::VIMap& map);

struct LocalizationMapReport {
  int missions_used = 0;
  int missions_skipped = 0;  // not in the common frame (see MissionsInCommonFrame)
  // The keypoint noise measured from the map (options.calibrate_landmark_covariances).
  KeypointNoiseEstimate keypoint_noise;
};

// From the missions of MissionsInCommonFrame(map): landmarks of quality good (unknown and bad
// are skipped), positioned with their mission's T_G_M. `report` (optional) says which were used.
// Covariances: options.calibrate_landmark_covariances (landmark_covariance.h), else the stored
// triangulation covariances rotated into G.
localizer::LocalizationMap BuildLocalizationMap(const mapstore::VIMap& map,
                                                const localizer::LocalizationMapOptions& options = {},
                                                LocalizationMapReport* report = nullptr);

// The same from the given missions (the caller vouches that they share the frame G), in their
// order: loop closure queries a mission against itself and the missions anchored with it.
localizer::LocalizationMap BuildLocalizationMapOfMissions(
    const mapstore::VIMap& map, const std::vector<mapstore::MissionId>& missions,
    const localizer::LocalizationMapOptions& options = {},
    KeypointNoiseEstimate* keypoint_noise = nullptr);

}  // namespace vilma::mapping
