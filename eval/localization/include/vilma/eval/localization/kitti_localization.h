// Real-image localization check on a KITTI odometry stereo slice (docs/localizer.md, "KITTI
// localization check"): a VI-map is built from the EVEN frames only (BRISK features in the left
// and right rectified images, stereo matches along the rows with their disparity refined to
// sub-pixel by patch alignment (stereo_geometry.h), triangulated in the left camera
// and placed in the world with the ground-truth pose; a landmark seen again in the next even
// frame is merged), then every ODD left image, which the map has never seen, is localized with
// Localizer::Localize and compared with its ground-truth pose. Used by the test
// tests/localizer/kitti_localization_test.cpp and by `vilma localize-kitti`.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <ostream>
#include <string>
#include <vector>

#include "vilma/core/camera.h"
#include "vilma/core/geometry.h"
#include "vilma/eval/localization/stereo_geometry.h"
#include "vilma/localizer/feature_options.h"
#include "vilma/localizer/keyframe_features.h"
#include "vilma/localizer/localizer.h"
#include "vilma/mapstore/vi_map.h"

namespace vilma::eval {

// The localizer's types this harness is written in.
using localizer::KeyframeFeatureOptions;
using localizer::KeyframeFeatures;
using localizer::Localizer;
using localizer::LocalizerOptions;
using localizer::LocalizationStatus;
using localizer::LocalizerStats;
using localizer::LocalizationMap;

// A KITTI odometry sequence folder: calib.txt (P0, P1: rectified 3x4 projection matrices),
// poses.txt (T_W_C0 per frame, 3x4 row-major), image_l/ and image_r/ (PNG, sorted by name).
struct KittiSequence {
  Camera camera;            // left rectified pinhole (no distortion), image size of frame 0
  double baseline_m = 0.0;  // -P1[0][3] / fx [m]
  std::vector<Transformation> T_W_C;  // ground truth of the left camera, per frame
  std::vector<std::string> left_images;
  std::vector<std::string> right_images;
  std::size_t size() const { return T_W_C.size(); }
};

// Throws InputError naming the file and what is wrong (missing files, fewer images than poses,
// malformed calibration).
KittiSequence LoadKittiSequence(const std::string& directory);

// Stereo matching of rectified images: a right keypoint is a candidate for a left keypoint on
// (almost) the same row with a disparity in [min, max]; the best candidate by Hamming distance
// must pass the threshold and Lowe's ratio test against the second best.
struct StereoMatchOptions {
  double max_row_difference_px = 1.5;  // |v_left - v_right| [px]
  double min_disparity_px = 2.0;       // far bound of the depth: fx * baseline / min [px]
  double max_disparity_px = 150.0;     // near bound [px]
  int max_hamming_distance = 80;       // of 512 bits
  double ratio = 0.8;                  // best < ratio * second best (1 = off)
  double max_depth_m = 40.0;           // triangulated points farther are dropped [m]
  std::string Validate() const;
};

struct StereoMatch {
  int left = 0;   // keypoint index in the left features
  int right = 0;  // keypoint index in the right features
  int hamming = 0;
  double disparity_px = 0.0;  // u_left - u_right (StereoPoint_C of the left keypoint)
  Eigen::Vector3d p_C = Eigen::Vector3d::Zero();  // in the left camera [m]
};

// Deterministic: left keypoints in order, ties by the lower right index.
std::vector<StereoMatch> MatchStereo(const KeyframeFeatures& left, const KeyframeFeatures& right,
                                     const Camera& camera, double baseline_m,
                                     const StereoMatchOptions& options);

struct KittiLocalizationOptions {
  KeyframeFeatureOptions features = KittiFeatureOptions();
  StereoMatchOptions stereo;
  LocalizerOptions localizer;
  // Merging a landmark of the previous even frame with a stereo point of the current one: the
  // previous landmark projected with the ground-truth pose must fall within this radius of the
  // current left keypoint, and the left descriptors must agree.
  double merge_radius_px = 6.0;
  int merge_max_hamming_distance = 70;
  // Keypoint noise of the stereo triangulation [px]: each landmark's covariance (the map's
  // p_G_covariance, used by the localizer's acceptance) is sigma^2 (sum J^T J)^-1 over its
  // used stereo views (left and right).
  double landmark_sigma_px = 1.0;
  // Sub-pixel disparity of every stereo match by 1-D patch alignment (stereo_geometry.h); a
  // match whose refinement fails keeps the keypoints' disparity (counted in the report).
  bool refine_disparity = true;
  DisparityRefinementOptions disparity;
  // true: a landmark merged over several map frames gets the maximum-likelihood point of all
  // its stereo views (TriangulateStereoTrack; views off by more than track_max_residual_px
  // left out). Off by default: measured, it accepted a wrong pose on kitti far-landmarks
  // (docs/localizer.md, "Sub-pixel stereo"); false keeps the nearest view's stereo point.
  bool triangulate_tracks = false;
  double track_max_residual_px = 2.5;
  // Success gates of a localization (the recall definition).
  double max_position_error_m = 0.3;
  double max_rotation_error_deg = 2.0;
  std::string Validate() const;

  // The feature profile for KITTI's 1226x370 outdoor images: a wider grid (16 x 4 cells) and
  // more keypoints than the 752x480 indoor default, and a 3-level pyramid with scale-adapted
  // BRISK patterns, because between a map frame and a query the car moves ~1 m towards the
  // scene, which changes the scale of near structure by 10-30 %.
  static KeyframeFeatureOptions KittiFeatureOptions();
};

struct KittiQueryResult {
  int frame = 0;
  LocalizationStatus status = LocalizationStatus::kNoKeypoints;
  int keypoints = 0;
  int raw_matches = 0;
  int matches = 0;  // after covisibility
  int inliers = 0;
  double position_error_m = -1.0;    // -1 if not localized
  double rotation_error_deg = -1.0;  // -1 if not localized
  bool success = false;              // localized within both gates
  double extract_ms = 0.0;
  double match_ms = 0.0;
  double pose_ms = 0.0;
};

struct KittiLocalizationReport {
  int map_frames = 0;
  int map_vertices_landmarks = 0;    // landmarks put in the VI-map
  int merged_observations = 0;       // landmarks re-observed in the next even frame
  int refined_disparities = 0;       // stereo matches with a sub-pixel disparity
  int unrefined_disparities = 0;     // refinement failed: the keypoints' disparity kept
  int triangulated_tracks = 0;       // landmarks with >= 2 stereo views, jointly triangulated
  int dropped_track_views = 0;       // of their views, left out as inconsistent
  int localization_landmarks = 0;
  int localization_descriptors = 0;
  double map_build_ms = 0.0;         // features + stereo + VI-map + localization map
  double projection_train_ms = 0.0;
  double index_build_ms = 0.0;
  std::vector<KittiQueryResult> queries;
  LocalizerStats stats;
  // Summary.
  double max_position_error_m = 0.0;    // the success gates the queries were judged with
  double max_rotation_error_deg = 0.0;  // (KittiLocalizationOptions)
  int successes = 0;    // localized within both gates
  double recall = 0.0;  // successes / queries
  double median_position_error_m = 0.0;    // over localized queries
  double median_rotation_error_deg = 0.0;  // over localized queries
  double p50_query_ms = 0.0;  // match + pose
  double p90_query_ms = 0.0;
  double p50_extract_ms = 0.0;

  // One line: "recall 97.3 % (36/37 within 0.3 m and 2 deg), median 0.041 m / 0.12 deg,
  // query p50 4.1 ms".
  std::string BriefReport() const;
  // What `vilma localize-kitti` prints: the map, the per-query table, recall, median errors,
  // times and the localizer's status counts.
  std::string FullReport() const;
};

// The VI-map of the even frames (one mission, T_G_M = identity, vertices T_M_I = T_W_C0 with
// I = C0, frames[0] left and frames[1] right keypoints, good landmarks with left and right
// observations). Also fills the map counters of `report` when not null.
mapstore::VIMap BuildKittiEvenFrameMap(const KittiSequence& sequence,
                                       const KittiLocalizationOptions& options,
                                       KittiLocalizationReport* report = nullptr);

// The same from the given frames (in this order; each merges with the frame before it in the
// list): the acceptance benchmark's maps of other parts of the slice (kitti_scenarios.h).
mapstore::VIMap BuildKittiFrameMap(const KittiSequence& sequence,
                                   const KittiLocalizationOptions& options,
                                   const std::vector<int>& map_frames,
                                   KittiLocalizationReport* report = nullptr);

// The whole check. Throws InputError for unreadable inputs or invalid options.
KittiLocalizationReport EvaluateKittiLocalization(const KittiSequence& sequence,
                                                  const KittiLocalizationOptions& options);

}  // namespace vilma::eval
