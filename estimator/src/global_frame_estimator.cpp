#include "vilma/estimator/global_frame_estimator.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <Eigen/Geometry>
#include <cmath>

namespace vilma::estimator {
namespace {

constexpr double kDegToRad = M_PI / 180.0;

double WrapAngle(double a) { return std::atan2(std::sin(a), std::cos(a)); }

}  // namespace

std::string GlobalFrameOptions::Validate() const {
  if (!(std::isfinite(max_jump_m) && max_jump_m > 0.0)) return "max_jump_m: expected > 0 [m]";
  if (!(std::isfinite(max_jump_deg) && max_jump_deg > 0.0 && max_jump_deg <= 180.0)) {
    return "max_jump_deg: expected 0 < deg <= 180";
  }
  if (!(std::isfinite(max_gravity_misalignment_deg) && max_gravity_misalignment_deg > 0.0 &&
        max_gravity_misalignment_deg <= 90.0)) {
    return "max_gravity_misalignment_deg: expected 0 < deg <= 90";
  }
  if (min_consistent_results < 1) return "min_consistent_results: expected >= 1";
  if (!(std::isfinite(forgetting_factor) && forgetting_factor > 0.0 && forgetting_factor <= 1.0)) {
    return "forgetting_factor: expected 0 < f <= 1";
  }
  if (max_consecutive_gated < 1) return "max_consecutive_gated: expected >= 1";
  if (!(std::isfinite(drift_position_m_per_sqrt_s) && drift_position_m_per_sqrt_s >= 0.0)) {
    return "drift_position_m_per_sqrt_s: expected >= 0 [m/sqrt(s)]";
  }
  if (!(std::isfinite(drift_yaw_deg_per_sqrt_s) && drift_yaw_deg_per_sqrt_s >= 0.0)) {
    return "drift_yaw_deg_per_sqrt_s: expected >= 0 [deg/sqrt(s)]";
  }
  if ((drift_position_m_per_sqrt_s > 0.0) != (drift_yaw_deg_per_sqrt_s > 0.0)) {
    return "drift_yaw_deg_per_sqrt_s: expected > 0 together with drift_position_m_per_sqrt_s "
           "(both 0: the forgetting factor)";
  }
  if (!(std::isfinite(min_sigma_position_m) && min_sigma_position_m > 0.0)) {
    return "min_sigma_position_m: expected > 0 [m]";
  }
  if (!(std::isfinite(min_sigma_yaw_deg) && min_sigma_yaw_deg > 0.0)) {
    return "min_sigma_yaw_deg: expected > 0 [deg]";
  }
  if (noise_scale_window < 0) return "noise_scale_window: expected >= 0 (0 = off) [results]";
  if (noise_scale_window > 0 && !random_walk()) {
    return "noise_scale_window: expected 0 without the random-walk fusion "
           "(drift_position_m_per_sqrt_s, drift_yaw_deg_per_sqrt_s > 0)";
  }
  if (!(std::isfinite(noise_scale_prior) && noise_scale_prior >= 1.0)) {
    return "noise_scale_prior: expected >= 1 [variance ratio]";
  }
  if (!(std::isfinite(noise_scale_prior_weight) && noise_scale_prior_weight >= 0.0)) {
    return "noise_scale_prior_weight: expected >= 0 [results]";
  }
  return "";
}

double GlobalFrameEstimator::Measure(const Transformation& T_G_I, const Matrix6d& covariance_I,
                                     const Transformation& T_M_I, Eigen::Vector4d* z,
                                     Eigen::Matrix4d* R, const GlobalFrameOptions& options) {
  // T_G_M = T_G_I T_M_I^-1 (yaw and translation kept). A right perturbation of the result,
  // T_G_I Exp(xi), is the left perturbation Exp(Ad_{T_G_I} xi) T_G_I (the VIO's uncertainty of
  // T_M_I is neglected: small over the seconds between localizations; the floors cover it).
  const Transformation T_G_M = T_G_I * T_M_I.inverse();
  const Eigen::Matrix3d R_G_M = T_G_M.rotation().toRotationMatrix();
  const double yaw = std::atan2(R_G_M(1, 0), R_G_M(0, 0));
  // The position goes with the yaw-only rotation, p_G_M = p_G_I - Rz(yaw) p_M_I, so that the
  // published T_G_M T_M_I reproduces the measured position at this frame exactly (with the
  // full R_G_M, the VIO's small roll/pitch error times |p_M_I| would become a position error).
  const Eigen::Vector3d Rz_p_M_I = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()) * T_M_I.translation();
  const Eigen::Vector3d p = T_G_I.translation() - Rz_p_M_I;
  (*z) << p, yaw;
  // Left perturbation of T_G_I, eps = [rho; phi] = Ad_{T_G_I} xi: p_G_I' = p_G_I + rho +
  // phi x p_G_I, yaw' = yaw + phi_z (first order, R_G_M nearly a yaw rotation), so
  //   dz/deps = [I, -[p_G_I]x - (e_z x Rz p_M_I) e_z^T; 0, e_z^T].
  Eigen::Matrix<double, 4, 6> J = Eigen::Matrix<double, 4, 6>::Zero();
  J.block<3, 3>(0, 0).setIdentity();
  J.block<3, 3>(0, 3) = -Skew(T_G_I.translation());
  J.block<3, 1>(0, 5) -= Eigen::Vector3d::UnitZ().cross(Rz_p_M_I);
  J(3, 5) = 1.0;
  const Matrix6d Ad = T_G_I.Adjoint();
  *R = J * Ad * covariance_I * Ad.transpose() * J.transpose();
  const double sp = options.min_sigma_position_m;
  const double sy = options.min_sigma_yaw_deg * kDegToRad;
  R->diagonal() += Eigen::Vector4d(sp * sp, sp * sp, sp * sp, sy * sy);
  const double c = std::clamp(R_G_M(2, 2), -1.0, 1.0);  // cos of the tilt of M's z axis in G
  return std::acos(c);
}

void GlobalFrameEstimator::Reset() {
  has_estimate_ = false;
  consistent_ = 0;
  consecutive_gated_ = 0;
  t_ns_ = 0;
  x_.setZero();
  info_.setZero();
  noise_samples_.clear();
}

Eigen::Vector2d GlobalFrameEstimator::noise_scale() const {
  if (!options_.adaptive_noise()) return Eigen::Vector2d::Ones();
  // Covariance matching with a prior: lambda = (n0 lambda0 + sum r) / (n0 + n), at least 1.
  const double n0 = options_.noise_scale_prior_weight;
  Eigen::Vector2d sum = n0 * options_.noise_scale_prior * Eigen::Vector2d::Ones();
  for (const Eigen::Vector2d& r : noise_samples_) sum += r;
  const double n = n0 + static_cast<double>(noise_samples_.size());
  if (n <= 0.0) return Eigen::Vector2d::Ones();
  return (sum / n).cwiseMax(1.0);
}

GlobalFrameUpdate GlobalFrameEstimator::Update(const Transformation& T_G_I,
                                               const Matrix6d& covariance_I,
                                               const Transformation& T_M_I, int64_t t_ns) {
  Eigen::Vector4d z;
  Eigen::Matrix4d R;
  const double tilt = Measure(T_G_I, covariance_I, T_M_I, &z, &R, options_);
  if (!(tilt <= options_.max_gravity_misalignment_deg * kDegToRad) || !z.allFinite() ||
      !R.allFinite()) {
    return GlobalFrameUpdate::kRejectedGravity;
  }
  // R scaled by the adaptive noise scales: D R D, D = diag(sqrt(lp), sqrt(lp), sqrt(lp), sqrt(ly)).
  auto scaled_information = [&] {
    const Eigen::Vector2d lambda = noise_scale();
    const Eigen::Vector4d d(std::sqrt(lambda[0]), std::sqrt(lambda[0]), std::sqrt(lambda[0]),
                            std::sqrt(lambda[1]));
    const Eigen::Matrix4d R_scaled = d.asDiagonal() * R * d.asDiagonal();
    return Eigen::Matrix4d(R_scaled.llt().solve(Eigen::Matrix4d::Identity()));
  };
  Eigen::Matrix4d W = R.llt().solve(Eigen::Matrix4d::Identity());  // R^-1
  auto start = [&] {
    has_estimate_ = true;
    consistent_ = 1;
    consecutive_gated_ = 0;
    t_ns_ = t_ns;
    x_ = z;
    noise_samples_.clear();  // innovations against an estimate that is given up
    info_ = options_.adaptive_noise() ? scaled_information() : W;
  };
  if (!has_estimate_) {
    start();
    return GlobalFrameUpdate::kAccepted;
  }
  Eigen::Vector4d dz = z - x_;
  dz[3] = WrapAngle(dz[3]);
  const bool jump = dz.head<3>().norm() > options_.max_jump_m ||
                    std::abs(dz[3]) > options_.max_jump_deg * kDegToRad;
  if (jump) {
    if (!initialized()) {
      // Not confirmed yet: the newest result becomes the candidate (the previous one may have
      // been the outlier).
      start();
      return GlobalFrameUpdate::kAccepted;
    }
    if (++consecutive_gated_ >= options_.max_consecutive_gated) {
      // The estimate itself is wrong (or M moved, e.g. a filter reset we did not see).
      start();
      return GlobalFrameUpdate::kReinitialized;
    }
    return GlobalFrameUpdate::kRejectedJump;
  }
  consecutive_gated_ = 0;
  if (options_.random_walk()) {
    // Kalman filter on a random-walk T_G_M: prediction P += Q dt over the time since the last
    // fused result, then the update with R (in information form: Lambda = (P + Q dt)^-1 + W).
    const double dt = std::max(0.0, 1e-9 * static_cast<double>(t_ns - t_ns_));
    const double qp = options_.drift_position_m_per_sqrt_s;
    const double qy = options_.drift_yaw_deg_per_sqrt_s * kDegToRad;
    Eigen::Matrix4d P = info_.llt().solve(Eigen::Matrix4d::Identity());
    P.diagonal() += dt * Eigen::Vector4d(qp * qp, qp * qp, qp * qp, qy * qy);
    if (options_.adaptive_noise()) {
      // Covariance matching (Mehra 1972; Myers & Tapley 1976): E[nu nu^T] = P- + R, so per
      // axis (nu_j^2 - P-_jj) / R_jj estimates R's scale; averaged over the position axes and
      // kept for the yaw. This result's own innovation is included before it is fused; only
      // innovations against a confirmed estimate count (before, the candidate may be the
      // outlier).
      if (initialized()) {
        Eigen::Vector2d r;
        r[0] = 0.0;
        for (int j = 0; j < 3; ++j) r[0] += (dz[j] * dz[j] - P(j, j)) / R(j, j) / 3.0;
        r[1] = (dz[3] * dz[3] - P(3, 3)) / R(3, 3);
        noise_samples_.push_back(r);
        while (static_cast<int>(noise_samples_.size()) > options_.noise_scale_window) {
          noise_samples_.pop_front();
        }
      }
      W = scaled_information();
    }
    info_ = P.llt().solve(Eigen::Matrix4d::Identity()) + W;
    t_ns_ = std::max(t_ns_, t_ns);
    x_ += info_.llt().solve(W * dz);
    x_[3] = WrapAngle(x_[3]);
    ++consistent_;
    return GlobalFrameUpdate::kAccepted;
  }
  // Information filter with forgetting (a random walk on T_G_M that follows the VIO drift):
  //   Lambda_k = f Lambda_{k-1} + W,   x_k = x_{k-1} + Lambda_k^-1 W (z - x_{k-1}),
  // the inverse-covariance weighted average of the measurements with weights decaying by f
  // per update.
  info_ = options_.forgetting_factor * info_ + W;
  x_ += info_.llt().solve(W * dz);
  x_[3] = WrapAngle(x_[3]);
  ++consistent_;
  return GlobalFrameUpdate::kAccepted;
}

Transformation GlobalFrameEstimator::T_G_M() const {
  return Transformation(Eigen::Quaterniond(Eigen::AngleAxisd(x_[3], Eigen::Vector3d::UnitZ())),
                        x_.head<3>());
}

Eigen::Matrix4d GlobalFrameEstimator::covariance() const {
  if (!has_estimate_) return Eigen::Matrix4d::Zero();
  return info_.llt().solve(Eigen::Matrix4d::Identity());
}

}  // namespace vilma::estimator
