// Localization against a prior map (docs/localizer.md, "Localization"): keyframe keypoints and
// BRISK descriptors -> projected-descriptor inverted multi-index (k nearest neighbours) ->
// exact Hamming check -> covisibility filter (largest component of matches connected through
// shared observer vertices) -> P3P RANSAC + Gauss-Newton refinement -> T_G_I with covariance.
// Every rejection reason is counted (LocalizerStats). No LCM, no threads: the daemon's LOC
// stage calls Localize() on its own thread.
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "vilma/core/camera.h"
#include "vilma/core/geometry.h"
#include "vilma/localizer/descriptor_index.h"
#include "vilma/localizer/localization_map.h"
#include "vilma/localizer/pose_acceptance.h"
#include "vilma/localizer/pose_ransac.h"

namespace vilma::localizer {

struct MatchingOptions {
  int max_hamming_distance = 90;       // of 512 bits, exact check of the k neighbours
  int max_landmarks_per_keypoint = 3;  // distinct landmarks kept per keypoint (best Hamming)
  bool covisibility_filter = true;
  int min_matches = 10;                // after the covisibility filter, else kTooFewMatches
  std::string Validate() const;
};

struct LocalizerOptions {
  LocalizationMapOptions map;
  ProjectionTrainingOptions projection;
  DescriptorIndexOptions index;
  MatchingOptions matching;
  PoseRansacOptions ransac;
  PoseAcceptanceOptions acceptance;  // gates a RANSAC pose must pass to be returned as ok
  // Empty if valid, else "section.key: expected ...".
  std::string Validate() const;
};

// Strict YAML (config/localizer.yaml): sections map, projection, index, matching, ransac,
// acceptance;
// unknown keys and bad values throw InputError naming the file and key. Missing keys keep
// their defaults.
LocalizerOptions LoadLocalizerOptions(const std::string& path);
LocalizerOptions ParseLocalizerOptions(const std::string& yaml_text, const std::string& source);
// Every option as YAML (sections as above) that ParseLocalizerOptions reads back to equal values.
std::string LocalizerOptionsToYaml(const LocalizerOptions& options);

enum class LocalizationStatus : uint8_t {
  kOk = 0,
  kNoKeypoints,
  kNoDescriptorMatches,  // no neighbour passed the Hamming check
  kTooFewMatches,        // fewer than matching.min_matches (after covisibility) or for P3P
  kRansacFailed,
  kTooFewInliers,
  // Rejected by the acceptance gates (pose_acceptance.h), one status per gate:
  kLowInlierRatio,        // inliers below acceptance.min_inlier_ratio x matches
  kHighReprojectionError, // inlier reprojection error median / p90 above its gate
  kClusteredInliers,      // inliers cover too few image cells or too small a hull
  kUncertainPose,         // position / rotation standard deviation above its gate
  kAmbiguousPose,         // a rival hypothesis with nearly as many inliers
  kNumStatuses
};
const char* LocalizationStatusName(LocalizationStatus status);
// True when the result's pose is a refined RANSAC winner: accepted (kOk), or judged and
// rejected after refinement (kTooFewInliers and every acceptance gate's status). False when no
// pose was estimated (no keypoints, matches or RANSAC model). Evaluations measure the error of
// such poses; kept as a switch so that a reordered or new status cannot change it silently.
bool HasRefinedPose(LocalizationStatus status);

struct Match2D3D {
  int keypoint = 0;
  uint32_t landmark = 0;  // index in the localization map
  int hamming = 0;
};

struct LocalizationResult {
  LocalizationStatus status = LocalizationStatus::kNoKeypoints;
  Transformation T_G_C;
  Transformation T_G_I;
  // Covariance of xi = [rho; phi] in T_G_I * Exp(xi) (IMU-frame right perturbation) [m^2, rad^2].
  Matrix6d covariance_I = Matrix6d::Zero();
  std::vector<Match2D3D> matches;  // after the covisibility filter (the RANSAC input)
  std::vector<int> inliers;        // indices into `matches`
  // What the acceptance gates measured (also for rejected poses, as far as the checks got).
  PoseQuality quality;
  int num_raw_matches = 0;         // before the covisibility filter
  int ransac_iterations = 0;
  double rms_reprojection_px = 0.0;
  double match_ms = 0.0;           // retrieval + Hamming + covisibility [ms]
  double pose_ms = 0.0;            // RANSAC + refinement [ms]
  // The same two stages in CPU time of the calling thread [ms]: wall minus these is the time
  // the thread waited for a core (the machine's load), not work.
  double match_cpu_ms = 0.0;
  double pose_cpu_ms = 0.0;
};

struct LocalizerStats {
  int64_t queries = 0;
  std::array<int64_t, static_cast<int>(LocalizationStatus::kNumStatuses)> status_counts{};
  void Add(const LocalizationResult& result) {
    ++queries;
    ++status_counts[static_cast<int>(result.status)];
  }
  // "queries N, ok n, no_keypoints n, ..." on one line (core/report.h's shape).
  std::string BriefReport() const;
  // "queries N" and one "  status count" line per status.
  std::string FullReport() const;
};

// Keeps the matches whose landmarks form the largest connected component of the graph in
// which two matched landmarks are linked when a map vertex observed both (union-find over
// observers). Ties: the component holding the earliest match. Returns indices into `matches`.
std::vector<int> LargestCovisibleComponent(const LocalizationMap& map,
                                           const std::vector<Match2D3D>& matches);

class Localizer {
 public:
  // Builds the index (trains the projection from the map when it carries none).
  // Throws InputError for invalid options or an empty map.
  Localizer(std::shared_ptr<const LocalizationMap> map, const LocalizerOptions& options);

  // keypoints[i] with descriptor descriptors[i * map.descriptor_bytes ...] in camera C with
  // extrinsics T_I_C. Thread-safe (const).
  LocalizationResult Localize(const Camera& camera, const Transformation& T_I_C,
                              const std::vector<Eigen::Vector2d>& keypoints,
                              const uint8_t* descriptors) const;
  // Matching only (retrieval, Hamming check, covisibility): the RANSAC input.
  std::vector<Match2D3D> Match(const std::vector<Eigen::Vector2d>& keypoints,
                               const uint8_t* descriptors, int* num_raw_matches) const;

  const LocalizationMap& map() const { return *map_; }
  const LocalizerOptions& options() const { return options_; }
  const DescriptorIndex& index() const { return index_; }
  const Eigen::MatrixXf& projection() const { return projection_; }
  double projection_train_ms() const { return projection_train_ms_; }
  double index_build_ms() const { return index_build_ms_; }

 private:
  std::shared_ptr<const LocalizationMap> map_;
  LocalizerOptions options_;
  Eigen::MatrixXf projection_;
  DescriptorIndex index_;
  double projection_train_ms_ = 0.0;
  double index_build_ms_ = 0.0;
};

}  // namespace vilma::localizer
