// Options of the map builder (docs/mapping.md): vertex rate, cameras, keyframe features,
// triangulation and landmark quality (maplab's "elq" rules). Plain structs with in-class
// defaults, checked by Validate(); read strictly from YAML (config/map_builder.yaml): unknown
// and missing keys are errors.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "vilma/core/yaml_io.h"
#include "vilma/localizer/feature_options.h"
#include "vilma/mapping/track_refinement.h"

namespace vilma::mapping {

// Landmark triangulation: linear least-squares ray intersection (midpoint of N rays), then
// Gauss-Newton on the reprojection error in pixels.
struct TriangulationOptions {
  int max_iterations = 10;           // Gauss-Newton iterations at most (0: linear only)
  double convergence_step_m = 1e-6;  // stop when the update is shorter than this [m]
  // Keypoint noise of the detector [px]: stored with unrefined keypoints (mapstore::Keypoint::
  // sigma_px), and the noise of observations that carry none, for the landmark covariance.
  double keypoint_sigma_px = 1.0;
  std::string Validate() const;
};

// Landmark quality, as maplab's vi_map_helpers "evaluate landmark quality" (elq): a landmark is
// good when all of these hold, otherwise bad (the first failing rule is counted).
struct LandmarkQualityOptions {
  int min_observers = 4;  // observations (keyframes x cameras) at least
  // Largest angle between two observation rays at the landmark at least this [deg]: the
  // parallax that makes the depth observable (maplab: elq_min_observation_angle_deg = 5).
  double min_observation_angle_deg = 5.0;
  double min_distance_m = 0.05;  // to the closest observing camera at least [m]
  double max_distance_m = 40.0;  // to the closest observing camera at most [m]
  // Root mean square reprojection error over the observations at most [px].
  double max_reprojection_error_px = 3.0;
  std::string Validate() const;
};

struct MapBuilderOptions {
  // A vertex per synchronized frame, at most this often [Hz]; 0: every frame. A frame becomes
  // a vertex when at least 0.9 / rate has passed since the previous vertex (10 % slack for
  // time stamp jitter, so that a 20 Hz camera gives exactly every other frame at 10 Hz).
  double vertex_rate_hz = 10.0;
  // Rig camera indices whose images get keyframe features; empty: every camera of the rig.
  std::vector<int> cameras;
  localizer::KeyframeFeatureOptions features;
  // Track-consistent sub-pixel keypoints: each observation of a track aligned to the track's
  // first one (track_refinement.h; docs/mapping.md "Track refinement").
  TrackRefinementOptions track_refinement;
  TriangulationOptions triangulation;
  LandmarkQualityOptions landmark_quality;
  // Compact maps (docs/mapping.md "Compact maps"), what Finish() stores:
  //   "none"    every keypoint, a landmark for every track of >= 2 observations (good or bad);
  //   "tracks"  landmarks for tracks of >= landmark_quality.min_observers observations only
  //             (shorter ones would be bad: too few observers), keypoints without a landmark
  //             dropped;
  //   "good"    (default) as "tracks", and only the good landmarks (all localization and
  //             optimization use), so only their keypoints stay: the smallest maps (8.8 MB/min
  //             mono room); loop closure then has only those keypoints as query features
  //             (fewer loops within a mission, the same optimized ATE) and `itl` no free tracks
  //             (docs/mapping.md has the figures).
  std::string compact = "good";
  // Keep the camera images of the vertices as image resources (docs/mapping.md "Images"):
  // every non-empty image AddFrame gets for a frame that becomes a vertex (all rig cameras, not
  // only `cameras`), lossless PNG, id ImageResourceId(vertex, camera). Held in memory until the
  // map is saved (~0.2-0.3 MB per 752x480 grey image); not sent in mission deltas (TakeDelta
  // clears the image ids), so missions streamed to vilma-mapstored have none.
  bool keep_images = false;
  // Long tracks are cut into landmarks of at most this many vertices (0: no limit). A track
  // that a robot standing still keeps seeing would otherwise never close, and with it neither
  // its vertices nor its observations could be released while streaming (docs/daemon.md "A
  // robot standing still"): a track segment that reaches the limit is closed as if the track
  // had ended (its landmark triangulated, evaluated and sent), and the track's next
  // observation starts a new landmark (landmark merging, `lc`/`mlm`, can join them later).
  // The same cut in both memory modes, so the streamed mission equals the whole one.
  // Nonzero: at least landmark_quality.min_observers (shorter segments make no landmark).
  int max_track_vertices = 100;
  // The same by time: a segment is closed when its last observation is at least this much
  // after its first [s] (0: no limit).
  double max_track_duration_s = 0.0;
  // True when a track segment of `observations` observations (one per vertex) from t_first_ns
  // to t_last_ns [ns] has reached a limit above.
  bool TrackSegmentFull(std::size_t observations, int64_t t_first_ns, int64_t t_last_ns) const;
  bool StoresShortTracks() const { return compact == "none"; }
  bool StoresBadLandmarks() const { return compact != "good"; }
  // Empty when valid, else "field: expectation" (field path with sections).
  std::string Validate() const;
};

// Strict readers (unknown keys are errors, an absent key keeps its value in `base`, the
// built-in defaults unless given: docs/design.md "Options files"); throw InputError naming the
// file, the key and the expectation (also for Validate() failures).
MapBuilderOptions ReadMapBuilderOptions(const YamlNode& node, const MapBuilderOptions& base = {});
MapBuilderOptions ParseMapBuilderOptions(const std::string& yaml_text,
                                         const std::string& source_name);
MapBuilderOptions LoadMapBuilderOptions(const std::string& path,
                                        const MapBuilderOptions& base = {});
// YAML text that ReadMapBuilderOptions reads back to the same options.
std::string MapBuilderOptionsToYaml(const MapBuilderOptions& options);

}  // namespace vilma::mapping
