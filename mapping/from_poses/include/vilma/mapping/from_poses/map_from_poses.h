// A VI-map from an ASL dataset and a given trajectory (docs/map-from-poses.md): for users who
// have poses from elsewhere (motion capture, another SLAM system, a survey) and for the
// optimization benchmarks, which start from ground truth perturbed by a known amount.
//
// Unlike the online map builder, the frames need not be consecutive video: keyframes seconds
// apart (euroc_V1_01_keyframes) are matched by descriptors over wide baselines.
//   1. Vertices: one per selected frame time (every camera's image at that time), T_M_I from
//      the trajectory (interpolated, M = the trajectory's world frame), optionally perturbed by
//      a seeded random rigid motion per vertex; v_M by central differences of the trajectory;
//      biases zero (an optimizer estimates them).
//   2. Features: BRISK keyframe features per image (localizer/keyframe_features.h).
//   3. Matching: stereo pairs of one vertex (cameras of the rig) are matched by descriptor and
//      checked against the epipolar geometry of the calibrated extrinsics; pairs of vertices
//      whose cameras may see the same scene (centres within pair_max_distance_m, optical axes
//      within pair_max_angle_deg, by the given poses) by descriptor (mutual nearest neighbours,
//      Lowe's ratio) and an essential-matrix RANSAC on undistorted bearings, which does not trust
//      the (possibly perturbed) poses.
//   4. Tracks: connected components of the verified matches (union-find); a track that holds
//      two keypoints of one image is inconsistent and dropped.
//   5. Landmarks: each track with >= 2 observations triangulated with the given poses
//      (mapping/triangulation.h), stored in its first vertex, quality by the elq rules.
//   6. IMU edges between consecutive vertices from the dataset's IMU, as the map builder makes
//      them (samples interpolated at both vertex times plus the raw ones between).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "vilma/core/progress.h"
#include "vilma/core/rig.h"
#include "vilma/eval/trajectory.h"
#include "vilma/localizer/feature_options.h"
#include "vilma/mapping/map_builder_options.h"
#include "vilma/mapstore/vi_map.h"

namespace vilma::mapping {

struct MapFromPosesOptions {
  int every_nth_frame = 1;  // use every n-th frame time of cam0
  int max_frames = 0;       // at most this many vertices (0: all)
  // A frame whose time is farther than this from the trajectory's samples (outside it, or in a
  // gap) is skipped [s].
  double max_pose_gap_s = 0.1;
  // Random rigid motion applied to each vertex pose (seeded; 0: the poses as given): a
  // translation of exactly this length in a uniformly random direction [m] ...
  double perturb_translation_m = 0.0;
  // ... and a rotation of exactly this angle about a uniformly random axis [deg].
  double perturb_rotation_deg = 0.0;
  uint64_t seed = 1;  // of the perturbation and of every random choice (RANSAC)
  localizer::KeyframeFeatureOptions features = DefaultFeatures();
  int max_hamming_distance = 90;  // descriptor match at most [bits of 512]
  double ratio = 0.8;             // Lowe's ratio test (best < ratio x second best)
  double pair_max_distance_m = 4.0;    // vertex pairs: camera centres within [m]
  double pair_max_angle_deg = 70.0;    // vertex pairs: optical axes within [deg]
  int max_pairs_per_vertex = 12;       // the closest candidates (by centre distance) at most
  double stereo_epipolar_px = 2.0;     // stereo: distance to the epipolar line at most [px]
  double essential_threshold_px = 1.5; // vertex pairs: RANSAC threshold [px at the focal length]
  int min_pair_inliers = 20;           // a vertex pair's matches count only with this many
  TriangulationOptions triangulation;
  // elq rules for the new landmarks; two observers by default (a stereo pair is two).
  LandmarkQualityOptions landmark_quality = DefaultQuality();
  std::string mission_name;  // "" = the dataset folder's name

  std::string Validate() const;
  static localizer::KeyframeFeatureOptions DefaultFeatures();
  static LandmarkQualityOptions DefaultQuality();
};

struct MapFromPosesSummary {
  int frames_in_dataset = 0;
  int vertices = 0;
  int frames_skipped_no_pose = 0;
  int keypoints = 0;
  int stereo_matches = 0;
  int vertex_pairs_tried = 0;
  int vertex_pairs_verified = 0;
  int pair_matches = 0;          // verified matches between vertices
  int tracks = 0;                // with >= 2 observations
  int tracks_inconsistent = 0;   // two keypoints of one image: dropped
  int landmarks = 0;
  int landmarks_good = 0;
  int triangulation_failed = 0;
  int imu_edges = 0;
  int imu_samples = 0;
  double seconds = 0.0;
  std::string BriefReport() const;
  std::string FullReport() const;
};

// Builds a one-mission map. `T_W_I`: the poses of the IMU frame (trajectory's world W = the
// mission frame M). `rig` gives the cameras and IMU; the dataset must have the rig's cameras
// (cam0, cam1, ...) and an IMU. Throws InputError for missing data (no IMU, no frame with a
// pose) and std::invalid_argument for invalid options.
mapstore::VIMap BuildMapFromPoses(const std::string& dataset_root, const SensorRig& rig,
                                  const Trajectory& T_W_I, const MapFromPosesOptions& options,
                                  MapFromPosesSummary* summary,
                                  ProgressObserver* progress = nullptr);

// The pose of a trajectory at t_ns (slerp / linear between the neighbours); false when t_ns is
// outside it or farther than max_gap_ns from the nearest sample.
bool InterpolatePose(const Trajectory& trajectory, int64_t t_ns, int64_t max_gap_ns,
                     Transformation* T_W_B);

// The deterministic per-vertex perturbation: a translation of length translation_m and a
// rotation of angle rotation_deg, directions from (seed, index).
Transformation PerturbationForVertex(uint64_t seed, std::size_t index, double translation_m,
                                     double rotation_deg);

}  // namespace vilma::mapping
