// How the filter starts (docs/estimator.md, "Initialization"): from a static IMU window, from a
// moving start by visual-inertial alignment (VisualInertialInitializer), or from a given state
// (StartFrom: ground truth or a previous run). Split from vio_filter.cpp, which holds the
// propagation and the photometric updates.
#include "vilma/estimator/vio_filter.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>

#include "vilma/core/error.h"
#include "vilma/core/imu.h"
#include "vilma/estimator/feature_detector.h"

namespace vilma::estimator {
namespace {

double Yaw(const Eigen::Quaterniond& q_M_I) {
  const Eigen::Vector3d x_M = q_M_I * Eigen::Vector3d::UnitX();
  return std::atan2(x_M.y(), x_M.x());
}

}  // namespace

std::string GivenState::Validate() const {
  if (!p_M_I.allFinite() || !v_M.allFinite() || !b_g.allFinite() || !b_a.allFinite() ||
      !q_M_I.coeffs().allFinite() || std::abs(q_M_I.norm() - 1.0) > 1e-6) {
    return "state: expected finite values and a unit quaternion";
  }
  for (const double sigma :
       {sigma_velocity, sigma_roll_pitch, sigma_yaw, sigma_gyro_bias, sigma_accel_bias}) {
    if (!(sigma > 0.0) || !std::isfinite(sigma)) return "sigma_*: expected > 0";
  }
  return "";
}

void VioFilter::StartFrom(const GivenState& state) {
  ThrowIfInvalid(state.Validate(), "given start state");
  given_state_ = state;
  have_given_state_ = true;
  initialized_ = false;
}

void VioFilter::Start(int64_t t_ns, const Eigen::Quaterniond& q_M_I, const Eigen::Vector3d& p_M_I,
                      const Eigen::Vector3d& v_M, const Eigen::Vector3d& b_g,
                      const Eigen::Vector3d& b_a, const Eigen::Matrix<double, 12, 12>& cov12,
                      double yaw_sigma) {
  x_.t_ns = t_ns;
  x_.p_M_I = p_M_I;
  x_.v_M = v_M;
  x_.q_M_I = q_M_I.normalized();
  x_.b_g = b_g;
  x_.b_a = b_a;
  x_.q_I_C = camera_.T_I_C.rotation();
  x_.p_I_C = camera_.T_I_C.translation();
  x_.td = 0.0;
  for (std::size_t i = 0; i < x_.features.size(); ++i) {
    x_.features[i].active = false;
    tracks_[i] = Track();
  }
  const InitOptions& o = options_.init;
  P_.setZero();
  P_.block<3, 3>(kIdxP, kIdxP) = Eigen::Matrix3d::Identity() * 1e-8;
  // (dv, dtheta, db_g, db_a) are contiguous in the error state.
  static_assert(kIdxQ == kIdxV + 3 && kIdxBg == kIdxV + 6 && kIdxBa == kIdxV + 9);
  P_.block<12, 12>(kIdxV, kIdxV) = cov12;
  // Yaw is stated about M's z axis; the error dtheta is in I: Sigma_I = R^T Sigma_M R.
  const Eigen::Vector3d z_I = x_.q_M_I.conjugate() * Eigen::Vector3d::UnitZ();
  P_.block<3, 3>(kIdxQ, kIdxQ) += yaw_sigma * yaw_sigma * z_I * z_I.transpose();
  if (options_.estimate_extrinsics) {
    P_.block<3, 3>(kIdxQIC, kIdxQIC) =
        Eigen::Matrix3d::Identity() * o.sigma_extrinsic_rotation * o.sigma_extrinsic_rotation;
    P_.block<3, 3>(kIdxPIC, kIdxPIC) = Eigen::Matrix3d::Identity() *
                                        o.sigma_extrinsic_translation *
                                        o.sigma_extrinsic_translation;
  }
  if (options_.estimate_time_offset) {
    P_(kIdxTd, kIdxTd) = o.sigma_time_offset * o.sigma_time_offset;
  }
  yaw_anchor_p_ = x_.p_M_I;
  yaw_anchor_v_ = x_.v_M;
  yaw_anchor_q_ = x_.q_M_I;
  frames_without_updates_ = 0;
  initialized_ = true;
  initializer_.Reset();
}

bool VioFilter::InitializeFromGiven(int64_t t_ns, std::string* why_not) {
  const GivenState& g = given_state_;
  if (t_ns < g.t_ns) {
    *why_not = "frame before the given start state";
    return false;
  }
  if (imu_.empty() || imu_.front().t_ns > g.t_ns) {
    *why_not = "no IMU at the given start state's time";
    return false;
  }
  // Carry the given state to the frame time with the IMU (biases as given). ImuState's
  // gravity-aligned frame W is the filter's M here.
  ImuState s;
  s.t_ns = g.t_ns;
  s.q_W_I = g.q_M_I;
  s.p_W_I = g.p_M_I;
  s.v_W = g.v_M;
  s.b_g = g.b_g;
  s.b_a = g.b_a;
  if (t_ns > g.t_ns) s = IntegrateImu(s, imu_, t_ns, rig_.imu.gravity_magnitude);
  Eigen::Matrix<double, 12, 12> cov = Eigen::Matrix<double, 12, 12>::Zero();
  cov.block<3, 3>(0, 0) = Eigen::Matrix3d::Identity() * g.sigma_velocity * g.sigma_velocity;
  const Eigen::Matrix3d R = s.q_W_I.toRotationMatrix();
  const Eigen::Vector3d tilt(g.sigma_roll_pitch, g.sigma_roll_pitch, 0.0);
  cov.block<3, 3>(3, 3) = R.transpose() * tilt.cwiseAbs2().asDiagonal() * R;
  cov.block<3, 3>(6, 6) = Eigen::Matrix3d::Identity() * g.sigma_gyro_bias * g.sigma_gyro_bias;
  cov.block<3, 3>(9, 9) = Eigen::Matrix3d::Identity() * g.sigma_accel_bias * g.sigma_accel_bias;
  Start(t_ns, s.q_W_I, s.p_W_I, s.v_W, s.b_g, s.b_a, cov, g.sigma_yaw);
  have_given_state_ = false;  // a later reset re-initializes from the sensors
  ++stats_.given_starts;
  return true;
}

bool VioFilter::Initialize(int64_t t_ns, const cv::Mat& image, std::string* why_not) {
  if (have_given_state_) return InitializeFromGiven(t_ns, why_not);
  const int64_t window_ns = static_cast<int64_t>(options_.init.window_s * 1e9);
  // Motion test on 50 ms block means: vibration (EuRoC's rotors: 0.8 m/s^2 sample std at
  // rest) averages out, a change of velocity or attitude does not.
  constexpr int kMaxBlocks = 64;
  constexpr int64_t kBlockNs = 50'000'000;
  Eigen::Vector3d block_a[kMaxBlocks], block_g[kMaxBlocks];
  int block_n[kMaxBlocks] = {};
  for (int b = 0; b < kMaxBlocks; ++b) {
    block_a[b].setZero();
    block_g[b].setZero();
  }
  Eigen::Vector3d sum_a = Eigen::Vector3d::Zero(), sum_g = Eigen::Vector3d::Zero();
  int count = 0;
  int64_t first = 0, last = 0;
  for (const ImuSample& s : imu_) {
    if (s.t_ns < t_ns - window_ns || s.t_ns > t_ns) continue;
    if (count == 0) first = s.t_ns;
    last = s.t_ns;
    sum_a += s.a_I;
    sum_g += s.omega_I;
    const int b = static_cast<int>(
        std::min<int64_t>(kMaxBlocks - 1, (s.t_ns - (t_ns - window_ns)) / kBlockNs));
    block_a[b] += s.a_I;
    block_g[b] += s.omega_I;
    ++block_n[b];
    ++count;
  }
  // Half the window is enough (a reset right after start has less history).
  if (count < 5 || static_cast<double>(last - first) < 0.5 * static_cast<double>(window_ns)) {
    *why_not = "not enough IMU data before the frame";
    return false;
  }
  const Eigen::Vector3d mean_a = sum_a / count, mean_g = sum_g / count;
  if (!mean_a.allFinite() || !mean_g.allFinite()) {
    *why_not = "IMU samples not finite";
    return false;
  }
  const bool gravity_like =
      std::abs(mean_a.norm() - rig_.imu.gravity_magnitude) <= options_.init.max_gravity_error;
  double var_a = 0.0, var_g = 0.0;
  int blocks = 0;
  for (int b = 0; b < kMaxBlocks; ++b) {
    if (block_n[b] == 0) continue;
    var_a += (block_a[b] / block_n[b] - mean_a).squaredNorm();
    var_g += (block_g[b] / block_n[b] - mean_g).squaredNorm();
    ++blocks;
  }
  const double std_a = std::sqrt(var_a / blocks), std_g = std::sqrt(var_g / blocks);
  // Once a moving start is being aligned, a window that looks static (a turning point of the
  // motion, constant velocity) does not mean rest: the alignment goes on until it succeeds or
  // times out.
  const bool is_static = gravity_like && std_a < options_.init.max_static_accel_std &&
                         std_g < options_.init.max_static_gyro_std &&
                         !initializer_.collecting();
  const InitOptions& o = options_.init;

  // Puts the start into M: yaw 0 (or the last yaw before a reset), position 0 (or the last).
  auto into_w = [&](Eigen::Quaterniond* q, Eigen::Vector3d* v) {
    const double yaw = have_previous_reset_pose_ ? Yaw(reset_pose_.rotation()) : 0.0;
    const Eigen::AngleAxisd Rz(yaw - Yaw(*q), Eigen::Vector3d::UnitZ());
    *q = (Rz * *q).normalized();
    *v = Rz * *v;
    return have_previous_reset_pose_ ? reset_pose_.translation() : Eigen::Vector3d::Zero();
  };
  if (!is_static && o.dynamic.enabled) {
    InitialAlignment a;
    std::string reason;
    const bool aligned = initializer_.AddFrame(t_ns, image, &a, &reason);
    stats_.dynamic_init = initializer_.stats();
    if (aligned) {
      Eigen::Quaterniond q = a.q_M_I;
      Eigen::Vector3d v = a.v_M;
      const Eigen::Vector3d p = into_w(&q, &v);
      // The covariance is rotated with M's yaw change only through v (dtheta, biases are in I).
      Eigen::Matrix<double, 12, 12> cov = a.covariance;
      const Eigen::Matrix3d Rz = (q * a.q_M_I.conjugate()).toRotationMatrix();
      cov.block<3, 12>(0, 0) = Rz * cov.block<3, 12>(0, 0);
      cov.block<12, 3>(0, 0) = cov.block<12, 3>(0, 0) * Rz.transpose();
      // Floors for what the alignment does not model (rolling shutter, time offset, the
      // linearization): 1 cm/s, 0.2 deg, 0.002 rad/s, 0.02 m/s^2.
      const double floors[4] = {0.01, 0.0035, 0.002, 0.02};
      for (int i = 0; i < 12; ++i) cov(i, i) += floors[i / 3] * floors[i / 3];
      ++stats_.moving_starts;
      ++stats_.dynamic_starts;
      Start(t_ns, q, p, v, a.b_g, a.b_a, cov, o.sigma_yaw);
      return true;
    }
    if (initializer_.waited_s() < o.dynamic.timeout_s) {
      *why_not = "moving start: " + reason;
      return false;
    }
    initializer_.Reset();  // timed out: fall back, and start afresh after a later reset
  }
  if (!gravity_like) {
    *why_not = "mean accelerometer is not gravity";
    return false;
  }
  if (is_static) {
    ++stats_.static_starts;
  } else {
    ++stats_.moving_starts;
    ++stats_.fallback_starts;
  }
  // At rest the accelerometer measures -g in I: R_M_I mean_a is along +z of M. The minimal
  // rotation that does this fixes roll and pitch; yaw is free (set to 0, or kept on a reset).
  Eigen::Quaterniond q = Eigen::Quaterniond::FromTwoVectors(mean_a, Eigen::Vector3d::UnitZ());
  Eigen::Vector3d v = Eigen::Vector3d::Zero();
  const Eigen::Vector3d p = into_w(&q, &v);
  Eigen::Matrix<double, 12, 12> cov = Eigen::Matrix<double, 12, 12>::Zero();
  const double sv = is_static ? o.sigma_velocity_static : o.sigma_velocity_moving;
  cov.block<3, 3>(0, 0) = Eigen::Matrix3d::Identity() * sv * sv;
  // Roll/pitch uncertainty is stated in M; the error dtheta is in I: Sigma_I = R^T Sigma_M R.
  const Eigen::Matrix3d R = q.toRotationMatrix();
  const Eigen::Vector3d sigma_M(o.sigma_roll_pitch, o.sigma_roll_pitch, 0.0);
  cov.block<3, 3>(3, 3) = R.transpose() * sigma_M.cwiseAbs2().asDiagonal() * R;
  cov.block<3, 3>(6, 6) = Eigen::Matrix3d::Identity() * o.sigma_gyro_bias * o.sigma_gyro_bias;
  cov.block<3, 3>(9, 9) = Eigen::Matrix3d::Identity() * o.sigma_accel_bias * o.sigma_accel_bias;
  // A moving start cannot separate the gyro bias from the rotation: start at zero.
  Start(t_ns, q, p, v, is_static ? mean_g : Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), cov,
        o.sigma_yaw);
  return true;
}

}  // namespace vilma::estimator
