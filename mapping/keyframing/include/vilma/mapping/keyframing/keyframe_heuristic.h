// Keyframing of a VI-map (maplab's keyframe_heuristic / kfh; docs/keyframing.md): per mission,
// walk the vertex chain and keep a vertex as a keyframe when, measured from the last keyframe,
//   - it moved at least kf_distance_threshold_m, or
//   - it turned at least kf_rotation_threshold_deg, or
//   - kf_every_nth_vertex vertices passed, or
//   - it shares fewer than kf_min_shared_landmarks_obs landmarks with it;
// the first and the last vertex are always kept. The vertices between two keyframes are merged
// into the first of them:
//   - their IMU edges become one edge from keyframe to keyframe whose samples are the
//     concatenation (each sample time once; the samples of a joint — the same interpolated
//     sample ending one edge and starting the next — appear once), so the distinct IMU samples
//     of the mission are conserved and nothing is integrated twice;
//   - landmarks stored in a removed vertex move to their earliest kept observer (position in G
//     unchanged), or are removed when no kept vertex observes them;
//   - the removed vertices' observations are dropped; landmarks left without observations are
//     removed; landmark quality is not re-evaluated (run elq after kfh);
//   - loop-closure and odometry edges of a removed vertex move to the keyframe it is merged
//     into, their measurement composed with the current relative pose (T_K_R T_R_X); pose
//     priors of removed vertices are removed.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "vilma/core/progress.h"
#include "vilma/mapstore/vi_map.h"

namespace vilma::mapping {

struct KeyframingOptions {
  double kf_distance_threshold_m = 0.75;    // keyframe when this far from the last one [m]
  double kf_rotation_threshold_deg = 20.0;  // keyframe when turned this much [deg]
  int kf_every_nth_vertex = 10;             // keyframe at least every n-th vertex
  int kf_min_shared_landmarks_obs = 20;     // keyframe when sharing fewer landmarks than this
  std::string Validate() const;
};

struct MissionKeyframingSummary {
  mapstore::MissionId mission;
  std::size_t vertices_before = 0;
  std::size_t vertices_after = 0;
  std::size_t kept_by_distance = 0;
  std::size_t kept_by_rotation = 0;
  std::size_t kept_by_every_nth = 0;
  std::size_t kept_by_shared_landmarks = 0;
  std::size_t imu_edges_merged = 0;       // edges removed by concatenation
  std::size_t imu_samples_before = 0;     // distinct sample times in the mission's IMU edges
  std::size_t imu_samples_after = 0;
  std::size_t landmarks_moved = 0;        // store vertex changed
  std::size_t landmarks_removed = 0;      // no kept observer left
  std::size_t observations_removed = 0;
  std::size_t edges_reattached = 0;       // loop-closure / odometry edges moved to a keyframe
  std::size_t edges_removed = 0;          // pose priors of removed vertices, collapsed edges
};

struct KeyframingSummary {
  std::vector<MissionKeyframingSummary> missions;
  double seconds = 0.0;
  std::size_t vertices_before() const;
  std::size_t vertices_after() const;
  std::string BriefReport() const;  // one line
  std::string FullReport() const;   // a table per mission
};

// Keyframes the given missions (empty: every mission) of `map` in place. Throws
// std::invalid_argument (map unchanged) for invalid options or a mission whose vertices are not
// one chain of IMU edges (check_map_consistency names the break). Cancelled (from
// ReportProgress) may leave the map half keyframed: the console runs kfh on a copy.
KeyframingSummary KeyframeHeuristic(const KeyframingOptions& options, mapstore::VIMap* map,
                                    const std::vector<mapstore::MissionId>& missions = {},
                                    ProgressObserver* progress = nullptr);

// The keyframe decision alone (indices into the chain that are kept), for tests and tools.
std::vector<std::size_t> SelectKeyframes(const KeyframingOptions& options,
                                         const mapstore::VIMap& map,
                                         const std::vector<mapstore::VertexId>& chain,
                                         MissionKeyframingSummary* reasons = nullptr);

// Distinct sample times over the IMU edges of a mission.
std::size_t DistinctImuSamples(const mapstore::VIMap& map, const mapstore::MissionId& mission);

}  // namespace vilma::mapping
