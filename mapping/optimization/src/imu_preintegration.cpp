#include "vilma/mapping/optimization/imu_preintegration.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <string>

#include "vilma/core/geometry.h"

namespace vilma::mapping {

std::string PreintegrationOptions::Validate() const {
  if (!(reintegrate_gyro_bias_rad_s > 0)) return "reintegrate_gyro_bias_rad_s: expected > 0";
  if (!(reintegrate_accel_bias_m_s2 > 0)) return "reintegrate_accel_bias_m_s2: expected > 0";
  return "";
}

ImuPreintegration::ImuPreintegration(std::vector<ImuSample> samples, const ImuNoise& noise,
                                     const Eigen::Vector3d& gyro_bias,
                                     const Eigen::Vector3d& accel_bias)
    : samples_(std::move(samples)), noise_(noise), gyro_bias_(gyro_bias), accel_bias_(accel_bias) {
  if (samples_.size() < 2) {
    throw std::invalid_argument("IMU preintegration: " + std::to_string(samples_.size()) +
                                " samples, expected at least 2 (the edge's two ends)");
  }
  for (std::size_t k = 0; k < samples_.size(); ++k) {
    if (!samples_[k].omega_I.allFinite() || !samples_[k].a_I.allFinite()) {
      throw std::invalid_argument("IMU preintegration: sample " + std::to_string(k) +
                                  " is not finite");
    }
    if (k > 0 && samples_[k].t_ns <= samples_[k - 1].t_ns) {
      throw std::invalid_argument("IMU preintegration: sample times not strictly increasing at " +
                                  std::to_string(k));
    }
  }
  if (!gyro_bias.allFinite() || !accel_bias.allFinite()) {
    throw std::invalid_argument("IMU preintegration: the biases are not finite");
  }
  Integrate();
}

void ImuPreintegration::Reintegrate(const Eigen::Vector3d& gyro_bias,
                                    const Eigen::Vector3d& accel_bias) {
  gyro_bias_ = gyro_bias;
  accel_bias_ = accel_bias;
  Integrate();
}

bool ImuPreintegration::NeedsReintegration(const Eigen::Vector3d& gyro_bias,
                                           const Eigen::Vector3d& accel_bias,
                                           const PreintegrationOptions& options) const {
  return (gyro_bias - gyro_bias_).norm() > options.reintegrate_gyro_bias_rad_s ||
         (accel_bias - accel_bias_).norm() > options.reintegrate_accel_bias_m_s2;
}

void ImuPreintegration::Integrate() {
  delta_R_.setIdentity();
  delta_v_.setZero();
  delta_p_.setZero();
  dR_dbg_.setZero();
  dv_dbg_.setZero();
  dv_dba_.setZero();
  dp_dbg_.setZero();
  dp_dba_.setZero();
  dt_s_ = 0.0;
  for (std::size_t k = 0; k + 1 < samples_.size(); ++k) {
    const auto [dt, w, a, phi, a_skew, dR, Jr] = IntervalAt(k);
    const Eigen::Matrix3d R = delta_R_.toRotationMatrix();  // ΔR_k
    // Bias Jacobians (Forster appendix B), from the values at k.
    dp_dba_ += dv_dba_ * dt - 0.5 * R * dt * dt;
    dp_dbg_ += dv_dbg_ * dt - 0.5 * R * a_skew * dR_dbg_ * dt * dt;
    dv_dba_ -= R * dt;
    dv_dbg_ -= R * a_skew * dR_dbg_ * dt;
    dR_dbg_ = dR.transpose() * dR_dbg_ - Jr * dt;

    // The deltas (eq. 37), with the specific force rotated at the interval's middle
    // (ΔR_k Exp(w dt / 2)): second-order accurate where eq. 37's ΔR_k is first order.
    const Eigen::Matrix3d R_mid = R * ExpSO3(0.5 * phi).toRotationMatrix();
    delta_p_ += delta_v_ * dt + 0.5 * R_mid * a * dt * dt;
    delta_v_ += R_mid * a * dt;
    delta_R_ = (delta_R_ * ExpSO3(phi)).normalized();
    dt_s_ += dt;
  }
  const std::array<double, 4> s2 = NoiseVariances();
  covariance_ = PropagateCovariance(s2[0], s2[1], s2[2], s2[3]);
  // Strictly positive definite (a zero-noise rig would give a singular one).
  covariance_.topLeftCorner<9, 9>() += 1e-12 * Eigen::Matrix<double, 9, 9>::Identity();
}

Eigen::Matrix<double, 15, 15> ImuPreintegration::PropagateCovariance(double sg2, double sa2,
                                                                     double sbg2,
                                                                     double sba2) const {
  const Eigen::Matrix3d I = Eigen::Matrix3d::Identity();
  Eigen::Matrix<double, 15, 15> covariance = Eigen::Matrix<double, 15, 15>::Zero();
  Eigen::Quaterniond delta_R = Eigen::Quaterniond::Identity();
  for (std::size_t k = 0; k + 1 < samples_.size(); ++k) {
    const auto [dt, w, a, phi, a_skew, dR, Jr] = IntervalAt(k);
    const Eigen::Matrix3d R = delta_R.toRotationMatrix();  // ΔR_k
    // Covariance of [δφ, δv, δp, w_g, w_a] (Forster eq. 62 with the bias random walk w = b - b_i
    // as states): Σ <- A Σ Aᵀ + B_g Σ_g B_gᵀ + B_a Σ_a B_aᵀ + Σ_w.
    Eigen::Matrix<double, 15, 15> A = Eigen::Matrix<double, 15, 15>::Identity();
    A.block<3, 3>(0, 0) = dR.transpose();
    A.block<3, 3>(3, 0) = -R * a_skew * dt;
    A.block<3, 3>(6, 0) = -0.5 * R * a_skew * dt * dt;
    A.block<3, 3>(6, 3) = I * dt;
    A.block<3, 3>(0, 9) = -Jr * dt;
    A.block<3, 3>(3, 12) = -R * dt;
    A.block<3, 3>(6, 12) = -0.5 * R * dt * dt;
    Eigen::Matrix<double, 15, 3> Bg = Eigen::Matrix<double, 15, 3>::Zero();
    Bg.block<3, 3>(0, 0) = Jr * dt;
    Eigen::Matrix<double, 15, 3> Ba = Eigen::Matrix<double, 15, 3>::Zero();
    Ba.block<3, 3>(3, 0) = R * dt;
    Ba.block<3, 3>(6, 0) = 0.5 * R * dt * dt;
    covariance = A * covariance * A.transpose() + Bg * (sg2 / dt) * Bg.transpose() +
                 Ba * (sa2 / dt) * Ba.transpose();
    covariance.block<3, 3>(9, 9).diagonal().array() += sbg2 * dt;
    covariance.block<3, 3>(12, 12).diagonal().array() += sba2 * dt;
    delta_R = (delta_R * ExpSO3(phi)).normalized();
  }
  return 0.5 * (covariance + covariance.transpose());
}

std::array<Eigen::Matrix<double, 15, 15>, 4> ImuPreintegration::NoiseComponents() const {
  const std::array<double, 4> s2 = NoiseVariances();
  return {PropagateCovariance(s2[0], 0, 0, 0), PropagateCovariance(0, s2[1], 0, 0),
          PropagateCovariance(0, 0, s2[2], 0), PropagateCovariance(0, 0, 0, s2[3])};
}

ImuPreintegration::Interval ImuPreintegration::IntervalAt(std::size_t k) const {
  Interval in;
  in.dt = 1e-9 * static_cast<double>(samples_[k + 1].t_ns - samples_[k].t_ns);
  in.w = 0.5 * (samples_[k].omega_I + samples_[k + 1].omega_I) - gyro_bias_;
  in.a = 0.5 * (samples_[k].a_I + samples_[k + 1].a_I) - accel_bias_;
  in.phi = in.w * in.dt;
  in.a_skew = Skew(in.a);
  in.dR = ExpSO3(in.phi).toRotationMatrix();
  in.Jr = RightJacobianSO3(in.phi);
  return in;
}

std::array<double, 4> ImuPreintegration::NoiseVariances() const {
  return {noise_.gyroscope_noise_density * noise_.gyroscope_noise_density,
          noise_.accelerometer_noise_density * noise_.accelerometer_noise_density,
          std::pow(std::max(noise_.gyroscope_random_walk, 1e-9), 2),
          std::pow(std::max(noise_.accelerometer_random_walk, 1e-9), 2)};
}

Eigen::Quaterniond ImuPreintegration::CorrectedDeltaR(const Eigen::Vector3d& gyro_bias) const {
  return delta_R_ * ExpSO3(dR_dbg_ * (gyro_bias - gyro_bias_));
}

Eigen::Vector3d ImuPreintegration::CorrectedDeltaV(const Eigen::Vector3d& gyro_bias,
                                                   const Eigen::Vector3d& accel_bias) const {
  return delta_v_ + dv_dbg_ * (gyro_bias - gyro_bias_) + dv_dba_ * (accel_bias - accel_bias_);
}

Eigen::Vector3d ImuPreintegration::CorrectedDeltaP(const Eigen::Vector3d& gyro_bias,
                                                   const Eigen::Vector3d& accel_bias) const {
  return delta_p_ + dp_dbg_ * (gyro_bias - gyro_bias_) + dp_dba_ * (accel_bias - accel_bias_);
}

}  // namespace vilma::mapping
