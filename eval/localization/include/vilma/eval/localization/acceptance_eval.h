// Acceptance benchmark of the localizer (docs/localizer.md, "Acceptance: a wrong pose is never
// accepted"): queries with ground truth are localized, every accepted pose is judged right or
// wrong (0.3 m / 2 deg), and a ground-truth oracle says which queries had a correct answer in
// their matches at all, so that precision and recall can be told apart. Hard cases are made
// from real images by perturbing the query (descriptors swapped between keypoints, few
// keypoints, keypoints from one image corner) or the map (kitti_scenarios.h). Used by the tool
// vilma-loc-acceptance (scripts/bench-localizer-acceptance.sh) and by tests/localizer.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <ostream>
#include <string>
#include <vector>

#include "vilma/core/camera.h"
#include "vilma/core/geometry.h"
#include "vilma/eval/localization/residual_calibration.h"
#include "vilma/localizer/localizer.h"

namespace vilma::eval {

// The localizer's types this harness is written in.
using localizer::Localizer;
using localizer::LocalizationStatus;
using localizer::LocalizerStats;
using localizer::PoseQuality;

// What is done to a query's features before it is localized. Applied in this order: box,
// max_keypoints, swap_fraction.
struct QueryPerturbation {
  // Keep only the keypoints inside [box_min, box_max] in fractions of the image width (x) and
  // height (y): inliers clustered in one part of the image.
  double box_min_x = 0.0, box_min_y = 0.0, box_max_x = 1.0, box_max_y = 1.0;
  // Keep only the first N keypoints (the extractor sorts them best first); 0 = all: few matches.
  int max_keypoints = 0;
  // This share of the remaining keypoints get the descriptor of another one of them (a seeded
  // cyclic shift over a random subset): wrong matches that pass every descriptor check.
  double swap_fraction = 0.0;
  uint64_t seed = 1;
  bool IsIdentity() const;
  std::string Validate() const;
};

// Applies `perturbation` to the query in place (descriptors: `descriptor_bytes` per keypoint).
void PerturbQuery(const QueryPerturbation& perturbation, const Camera& camera,
                  std::vector<Eigen::Vector2d>* keypoints, std::vector<uint8_t>* descriptors,
                  int descriptor_bytes);

struct AcceptanceGates {
  double max_position_error_m = 0.3;    // an accepted pose farther off is wrong
  double max_rotation_error_deg = 2.0;  // likewise
  // Oracle: a query "has a correct answer" when at least oracle_min_matches distinct keypoints
  // of its matches (the RANSAC input) reproject within oracle_threshold_px under the ground
  // truth. Looser than RANSAC's 2 px because the ground truth and the map's landmarks carry
  // their own errors (EuRoC: Vicon ~1 cm / 0.5 deg, landmarks triangulated from it).
  double oracle_threshold_px = 4.0;
  int oracle_min_matches = 12;
};

// One match of an accepted query, for diagnosis (vilma-loc-acceptance --inliers): every
// inlier of the estimate and every match that agrees with the ground truth (the oracle's).
struct MatchRecord {
  int keypoint = 0;
  Eigen::Vector2d uv = Eigen::Vector2d::Zero();  // the query keypoint [px]
  bool inlier = false;                           // of the accepted estimate
  bool oracle = false;                           // within oracle_threshold_px under the truth
  double error_estimate_px = -1.0;  // |reprojection error| under the estimate (-1: not seen)
  double error_truth_px = -1.0;     // likewise under the ground truth
  double depth_m = -1.0;            // landmark depth in the true query camera
  int observers = 0;                // map vertices observing the landmark
  double sigma_ray_m = -1.0;        // landmark sigma along the query ray (-1: no covariance)
  double sigma_max_m = -1.0;        // and along its worst direction
};

struct AcceptanceQuery {
  int frame = 0;
  LocalizationStatus status = LocalizationStatus::kNoKeypoints;
  int keypoints = 0;
  int matches = 0;         // after covisibility
  int inliers = 0;
  int oracle_matches = 0;  // distinct keypoints whose match agrees with the ground truth
  bool possible = false;   // oracle_matches >= oracle_min_matches
  bool accepted = false;   // status ok
  bool wrong = false;      // accepted and beyond a gate
  double position_error_m = -1.0;    // -1 if not accepted
  double rotation_error_deg = -1.0;
  // The error of the pose the gates judged, accepted or not (-1 when no pose reached the
  // gates: no keypoints, too few matches, RANSAC failed): which gate caught which pose.
  double judged_position_error_m = -1.0;
  double judged_rotation_error_deg = -1.0;
  double position_sigma_m = 0.0;     // sqrt of the largest eigenvalue of the position covariance
  double rotation_sigma_deg = 0.0;   // likewise of the rotation covariance (IMU frame)
  PoseQuality quality;               // what the acceptance gates measured
  double localize_ms = 0.0;          // Localize() thread CPU time (match + pose + gates)
  double pose_ms = 0.0;              // of which RANSAC, refinement and gates (CPU)
  // A right pose's inlier residuals (residual_calibration.h; empty unless accepted and right).
  std::vector<ResidualSample> residuals;
  // Accepted queries: estimate minus truth of the camera position in the true camera frame
  // (x right, y down, z forward) [m], and the inliers' and the oracle's matches.
  Eigen::Vector3d position_error_C = Eigen::Vector3d::Zero();
  std::vector<MatchRecord> match_records;
};

// Localizes one query (camera C with extrinsics T_I_C) and judges it against T_G_I_gt.
AcceptanceQuery EvaluateAcceptanceQuery(const Localizer& localizer, const Camera& camera,
                                        const Transformation& T_I_C,
                                        const std::vector<Eigen::Vector2d>& keypoints,
                                        const std::vector<uint8_t>& descriptors,
                                        const Transformation& T_G_I_gt,
                                        const AcceptanceGates& gates);

struct AcceptanceSummary {
  std::string name;
  int queries = 0;
  int possible = 0;          // queries with a correct answer in their matches (oracle)
  int accepted = 0;
  int accepted_wrong = 0;
  int accepted_correct = 0;  // over the possible queries (the recall's numerator)
  double recall = 0.0;       // accepted_correct / possible (0 when none is possible)
  double median_position_error_m = 0.0;  // over the accepted queries
  double median_rotation_error_deg = 0.0;
  double max_wrong_position_error_m = 0.0;
  double max_wrong_rotation_error_deg = 0.0;
  double p50_localize_ms = 0.0;
  double p50_pose_ms = 0.0;
  double max_localize_ms = 0.0;
  LocalizerStats stats;
  // The residual noise model on the right accepted poses (chi^2 / dof ~ 1 when calibrated).
  NoiseCalibration noise;

  // "name: accepted A (wrong W), recall R % of P possible" (core/report.h's shape).
  std::string BriefReport() const;
  // The summary's figures, one per line (the benchmark's table row has them in columns).
  std::string FullReport() const;
};

AcceptanceSummary SummarizeAcceptance(const std::string& name,
                                      const std::vector<AcceptanceQuery>& queries);

// Markdown table: header (with its separator line) and one row per data set; the rejection
// reasons are the non-zero status counts other than ok.
void WriteAcceptanceHeader(std::ostream& out);
void WriteAcceptanceRow(std::ostream& out, const AcceptanceSummary& summary);
// One line per query (frame, status, counts, oracle, errors, sigmas).
void WriteAcceptanceQueries(std::ostream& out, const std::vector<AcceptanceQuery>& queries);
// An accepted query's position error in its camera frame and one line per match record
// (sorted by depth), with a summary of the inliers' depths and error under the truth.
void WriteMatchRecords(std::ostream& out, const AcceptanceQuery& query);

}  // namespace vilma::eval
