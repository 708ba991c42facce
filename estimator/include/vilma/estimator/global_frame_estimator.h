// T_G_M estimation for LOC mode (docs/daemon.md "Localization"): from localization results
// T_G_I (with covariance) and the filter's T_M_I of the same frame, the transformation from the
// odometry frame M to the map frame G. Both frames are gravity aligned, so T_G_M has 4 degrees
// of freedom (x, y, z, yaw); measurements with roll/pitch are rejected, measurements that jump
// from the estimate are gated, and the accepted ones are fused by inverse-covariance weighting,
// either with a forgetting factor per update or (drift_* > 0) as a Kalman filter on a random-walk
// T_G_M whose process noise grows with the time between results, optionally with measurement
// noise scales learned from the innovations (noise_scale_window > 0). Used by
// vilma-estimatord's filter thread (LOC mode); not thread-safe.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <deque>
#include <string>

#include "vilma/core/geometry.h"
namespace vilma::estimator {

// Gating and fusion of T_G_M measurements (the daemon's localization.* keys of the same names).
struct GlobalFrameOptions {
  // Gating against the current estimate (after initialization).
  double max_jump_m = 0.5;    // position [m]
  double max_jump_deg = 5.0;  // yaw [deg]
  // Both G and M are gravity aligned: T_G_M must be a yaw rotation. A measurement whose
  // roll/pitch exceeds this is rejected [deg].
  double max_gravity_misalignment_deg = 3.0;
  int min_consistent_results = 2;  // consistent results before the estimate is initialized
  // Information kept per update of the estimate (1 = plain inverse-covariance average, < 1 lets
  // the estimate follow the VIO drift) [fraction].
  double forgetting_factor = 0.8;
  // Consecutive gated (jumping) results after which the estimate is dropped and re-initialized.
  int max_consecutive_gated = 5;
  // Random-walk fusion (both > 0; then forgetting_factor is not used): T_G_M drifts like the
  // VIO, P += diag(q_p^2, q_p^2, q_p^2, q_yaw^2) dt between results dt seconds apart, so the
  // estimate does not depend on how many results are accepted. 0 and 0 = the forgetting factor.
  // The default since 2026-11-28 (docs/daemon.md "T_G_M estimation": better on ground-truth and
  // optimized maps, a few % worse on raw VIO maps of the room).
  double drift_position_m_per_sqrt_s = 0.01;  // q_p [m/sqrt(s)]
  double drift_yaw_deg_per_sqrt_s = 0.3;      // q_yaw [deg/sqrt(s)]
  // Floors added to the measurement variances (the P3P covariance only holds the pixel noise,
  // not map errors nor the VIO's own error at that frame) [m, deg].
  double min_sigma_position_m = 0.01;
  double min_sigma_yaw_deg = 0.2;
  // Adaptive measurement noise (random-walk fusion only; 0 = off): each result's R (P3P
  // covariance + floors) is scaled by lambda_p (position block) and lambda_yaw >= 1, estimated by
  // covariance matching from the innovations nu = z - x of the last noise_scale_window fused
  // results: r = mean_j (nu_j^2 - P-_jj) / R_jj per block, lambda = max(1, (n0 lambda0 + sum r)
  // / (n0 + n)), with the prior lambda0 = noise_scale_prior held as n0 =
  // noise_scale_prior_weight results. Against an exact map the innovations match R and recent
  // results are trusted; against a drifting map they scatter and the estimate averages longer.
  int noise_scale_window = 0;             // results [count]
  double noise_scale_prior = 4.0;         // lambda0 [variance ratio, >= 1]
  double noise_scale_prior_weight = 5.0;  // n0 [results, >= 0]
  bool adaptive_noise() const { return noise_scale_window > 0; }
  bool random_walk() const {
    return drift_position_m_per_sqrt_s > 0.0 || drift_yaw_deg_per_sqrt_s > 0.0;
  }
  std::string Validate() const;  // "" or "field: expectation"
};

enum class GlobalFrameUpdate : uint8_t {
  kAccepted,          // fused into the estimate (or started a new candidate)
  kRejectedGravity,   // roll/pitch of T_G_M beyond max_gravity_misalignment_deg
  kRejectedJump,      // beyond max_jump_m / max_jump_deg from the estimate
  kReinitialized,     // max_consecutive_gated jumps in a row: the estimate restarts from this one
};

class GlobalFrameEstimator {
 public:
  explicit GlobalFrameEstimator(const GlobalFrameOptions& options) : options_(options) {}

  // T_G_I: the localization result, covariance_I of xi in T_G_I Exp(xi), xi = [rho; phi]
  // [m^2, rad^2]; T_M_I: the filter's pose at that same frame; t_ns: that frame's time (the
  // random walk's dt; unused with the forgetting factor) [ns].
  GlobalFrameUpdate Update(const Transformation& T_G_I, const Matrix6d& covariance_I,
                           const Transformation& T_M_I, int64_t t_ns = 0);
  // Drops the estimate (a new M frame: filter restart or reset).
  void Reset();

  // At least min_consistent_results consistent measurements fused.
  bool initialized() const { return consistent_ >= options_.min_consistent_results; }
  Transformation T_G_M() const;
  // Covariance of (x, y, z, yaw) at the last fused result [m^2, rad^2].
  Eigen::Matrix4d covariance() const;
  const Eigen::Vector4d& state() const { return x_; }
  // The measurement noise scales (lambda_p, lambda_yaw) the next result gets (1, 1 without
  // adaptive noise).
  Eigen::Vector2d noise_scale() const;

  // The 4-DoF measurement z = (p_G_M, yaw) and its covariance from a result (public for tests).
  // Returns the tilt of R_G_M (angle between its z axis and G's) [rad].
  // Floors: min_sigma_position_m / min_sigma_yaw_deg of the options.
  static double Measure(const Transformation& T_G_I, const Matrix6d& covariance_I,
                        const Transformation& T_M_I, Eigen::Vector4d* z, Eigen::Matrix4d* R,
                        const GlobalFrameOptions& options = GlobalFrameOptions());

 private:
  GlobalFrameOptions options_;
  bool has_estimate_ = false;
  int consistent_ = 0;       // measurements fused since the last (re)start
  int consecutive_gated_ = 0;
  int64_t t_ns_ = 0;         // time of the last fused result (random walk)
  Eigen::Vector4d x_ = Eigen::Vector4d::Zero();        // (x, y, z, yaw) [m, rad]
  Eigen::Matrix4d info_ = Eigen::Matrix4d::Zero();     // information matrix
  // Adaptive noise: per fused result (random walk, after the first), the innovation's
  // (r_position, r_yaw) [variance ratio]; the last noise_scale_window of them.
  std::deque<Eigen::Vector2d> noise_samples_;
};

}  // namespace vilma::estimator
