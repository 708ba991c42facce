// Frame-to-frame tracking of keyframe features, as maplab's feature tracking: each previous
// keypoint's bearing is rotated by the gyroscope rotation between the keyframes and projected
// into the current image; descriptors are matched (Hamming) among the current keypoints inside
// a window around that prediction, with ratio and mutual checks; a translation-only 2-point
// RANSAC (translation_ransac.h) removes the matches that no camera translation explains.
// Matched keypoints continue their track id; the others start new tracks. See
// docs/localizer.md, "Keyframe features".
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "vilma/core/camera.h"
#include "vilma/localizer/keyframe_features.h"
#include "vilma/localizer/translation_ransac.h"

namespace vilma::localizer {

struct FeatureMatch {
  int prev_index = -1;  // keypoint index in the previous keyframe's features
  int cur_index = -1;   // keypoint index in the current keyframe's features
  int distance = 0;     // Hamming distance [bits]
};

struct TrackingResult {
  KeyframeFeatures features;       // of the current keyframe
  std::vector<int64_t> track_ids;  // one per current keypoint
  std::vector<FeatureMatch> matches;  // accepted (RANSAC inlier) matches prev -> cur
  int num_previous = 0;            // keypoints of the previous keyframe
  int num_candidates = 0;          // descriptor matches before RANSAC
  int num_matched = 0;             // tracks continued (= matches.size())
  int num_rejected_ransac = 0;     // descriptor matches RANSAC rejected
  int num_new = 0;                 // new track ids
  bool ransac_verified = false;    // RANSAC ran (enough matches, method != "none")
  bool rotation_only = false;      // RANSAC chose the no-translation model
  Eigen::Vector3d t_dir = Eigen::Vector3d::Zero();  // direction of p_Ck_Ckm1 if estimated
  double extract_ms = 0.0;         // detection + description time [ms]
  double match_ms = 0.0;           // prediction + matching + RANSAC time [ms]
};

// One per camera. Not thread-safe; buffers are reused between calls.
class FeatureTracker {
 public:
  // Throws InputError if options.Validate() fails. Track ids start at `first_track_id` and
  // count up by one per new track (several trackers can use disjoint ranges).
  explicit FeatureTracker(const KeyframeFeatureOptions& options, int64_t first_track_id = 0);

  // Extracts features of `image` and tracks them from the previous call's keyframe.
  // `q_Ck_Ckm1`: rotation from the previous to the current camera frame (p_Ck = R p_Ckm1 for
  // a pure rotation), from the integrated gyroscope and the camera extrinsics. The first call
  // (or the first after Reset) starts a new track for every keypoint.
  TrackingResult Track(const cv::Mat& image, const Camera& camera,
                       const Eigen::Quaterniond& q_Ck_Ckm1);
  // Same with features extracted elsewhere (same options); they become the previous keyframe.
  TrackingResult TrackFeatures(KeyframeFeatures features, const Camera& camera,
                               const Eigen::Quaterniond& q_Ck_Ckm1);

  // Forgets the previous keyframe (track ids keep counting up).
  void Reset();

  const FeatureExtractor& extractor() const { return extractor_; }
  const KeyframeFeatures& previous_features() const { return prev_features_; }
  const std::vector<int64_t>& previous_track_ids() const { return prev_track_ids_; }
  int64_t next_track_id() const { return next_track_id_; }

 private:
  // Grid index over points: cell of side `cell` [px], indices listed per cell (CSR).
  struct GridIndex {
    double cell = 1.0;
    int cols = 0;
    int rows = 0;
    std::vector<int> offsets;  // cols * rows + 1
    std::vector<int> items;
    std::vector<int> cell_of;  // per point, -1 if outside
    void Build(const std::vector<Eigen::Vector2d>& points, const std::vector<char>& valid,
               int width, int height, double cell_size);
  };

  KeyframeFeatureOptions options_;
  FeatureExtractor extractor_;
  int64_t next_track_id_ = 0;
  bool has_previous_ = false;
  KeyframeFeatures prev_features_;
  std::vector<int64_t> prev_track_ids_;
  std::vector<Eigen::Vector3d> prev_bearings_;
  std::vector<char> prev_bearing_valid_;

  // Per-call buffers.
  std::vector<Eigen::Vector2d> predicted_;
  std::vector<char> predicted_valid_;
  std::vector<Eigen::Vector2d> cur_points_;
  std::vector<char> cur_valid_;
  std::vector<Eigen::Vector3d> cur_bearings_;
  GridIndex cur_grid_;
  std::vector<int> reverse_best_;  // per current keypoint: best previous index so far
  std::vector<int> reverse_dist_;
  std::vector<FeatureMatch> forward_;       // per previous keypoint (cur_index -1: none)
  std::vector<std::pair<int, int>> window_;  // (cur index, distance) candidates of one window
  std::vector<Eigen::Vector3d> ransac_a_;
  std::vector<Eigen::Vector3d> ransac_f_;
};

}  // namespace vilma::localizer
