// On-manifold IMU preintegration between two vertices (Forster, Carlone, Dellaert, Scaramuzza,
// "On-Manifold Preintegration for Real-Time Visual-Inertial Odometry", T-RO 2017; docs/optimization.md).
//
// The raw samples s_0..s_n of a VI-map IMU edge cover [t_i, t_j] exactly (s_0 at t_i, s_n at
// t_j). Each interval [t_k, t_k+1] uses the mean of its two samples, minus the linearization
// biases b̄ (trapezoidal in the measurement, so an edge that merges several, as after kfh, is
// integrated exactly as its parts were):
//   w = (w_k + w_k+1)/2 - b̄_g,  a = (a_k + a_k+1)/2 - b̄_a,  dt = t_k+1 - t_k
//   ΔR_k+1 = ΔR_k Exp(w dt)
//   Δv_k+1 = Δv_k + ΔR_k½ a dt
//   Δp_k+1 = Δp_k + Δv_k dt + ½ ΔR_k½ a dt²       (Forster eq. 37, ΔR_k½ = ΔR_k Exp(w dt/2):
//                                                   the rotation at the interval's middle)
// with the bias Jacobians (Forster appendix B) and the covariance of [δφ, δv, δp] propagated with
// the discrete noise σ²/dt of the continuous densities (eq. 62-63), jointly with the bias random
// walk inside the edge: the state [δφ, δv, δp, w_g, w_a] with w = b(t) - b_i, whose steps add
// σ_bw² dt and feed δφ (-J_r dt w_g), δv (-ΔR dt w_a) and δp (-½ ΔR dt² w_a). Without that
// coupling an edge of 1 s under-states the velocity variance by ~1/3 (EuRoC's densities; the
// test noise_consistency_test.cpp), so long keyframed edges were over-weighted. A bias change δb from b̄ is
// applied to first order (eq. 44):
//   ΔR(b) = ΔR Exp(∂R/∂b_g δb_g),  Δv(b) = Δv + ∂v/∂b_g δb_g + ∂v/∂b_a δb_a,  Δp likewise.
// When the bias moves far from b̄ (NeedsReintegration), integrate again at the new bias.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <array>
#include <vector>

#include "vilma/core/imu.h"

namespace vilma::mapping {

struct PreintegrationOptions {
  // Re-integrate when |b_g - b̄_g| or |b_a - b̄_a| exceeds these (first order no longer enough).
  double reintegrate_gyro_bias_rad_s = 2e-3;
  double reintegrate_accel_bias_m_s2 = 5e-2;
  std::string Validate() const;
};

class ImuPreintegration {
 public:
  // Throws std::invalid_argument (naming the problem) for fewer than 2 samples, times not
  // strictly increasing, or a non-finite value.
  ImuPreintegration(std::vector<ImuSample> samples, const ImuNoise& noise,
                    const Eigen::Vector3d& gyro_bias, const Eigen::Vector3d& accel_bias);

  // Integrates again with new linearization biases.
  void Reintegrate(const Eigen::Vector3d& gyro_bias, const Eigen::Vector3d& accel_bias);
  bool NeedsReintegration(const Eigen::Vector3d& gyro_bias, const Eigen::Vector3d& accel_bias,
                          const PreintegrationOptions& options) const;

  double dt_s() const { return dt_s_; }
  const Eigen::Quaterniond& delta_R() const { return delta_R_; }
  const Eigen::Vector3d& delta_v() const { return delta_v_; }
  const Eigen::Vector3d& delta_p() const { return delta_p_; }
  const Eigen::Matrix3d& dR_dbg() const { return dR_dbg_; }
  const Eigen::Matrix3d& dv_dbg() const { return dv_dbg_; }
  const Eigen::Matrix3d& dv_dba() const { return dv_dba_; }
  const Eigen::Matrix3d& dp_dbg() const { return dp_dbg_; }
  const Eigen::Matrix3d& dp_dba() const { return dp_dba_; }
  // Covariance of [δφ, δv, δp] (rad, m/s, m).
  Eigen::Matrix<double, 9, 9> covariance() const { return covariance_.topLeftCorner<9, 9>(); }
  // Joint covariance of [δφ, δv, δp, b_g,j - b_g,i, b_a,j - b_a,i] (the inertial residual's).
  const Eigen::Matrix<double, 15, 15>& full_covariance() const { return covariance_; }
  const Eigen::Vector3d& gyro_bias() const { return gyro_bias_; }  // b̄_g
  const Eigen::Vector3d& accel_bias() const { return accel_bias_; }
  const ImuNoise& noise() const { return noise_; }
  // The four parts of full_covariance() that come from one noise density each: gyroscope
  // white noise, accelerometer white noise, gyroscope random walk, accelerometer random walk
  // (in that order). The propagation is linear in the four variances, so the parts add up to
  // full_covariance() (but for its 1e-12 floor): Σ = Σ_gw + Σ_aw + Σ_gb + Σ_ab. Variance
  // component estimation (variance_components.h) weighs each part on its own.
  std::array<Eigen::Matrix<double, 15, 15>, 4> NoiseComponents() const;
  std::size_t num_samples() const { return samples_.size(); }

  // The deltas corrected to first order for biases (b_g, b_a).
  Eigen::Quaterniond CorrectedDeltaR(const Eigen::Vector3d& gyro_bias) const;
  Eigen::Vector3d CorrectedDeltaV(const Eigen::Vector3d& gyro_bias,
                                  const Eigen::Vector3d& accel_bias) const;
  Eigen::Vector3d CorrectedDeltaP(const Eigen::Vector3d& gyro_bias,
                                  const Eigen::Vector3d& accel_bias) const;

 private:
  void Integrate();
  // One interval [t_k, t_k+1] at the linearization biases: the mean rates over it (the samples'
  // average minus the bias), Δt, φ = w Δt and what both passes over the samples need of it.
  struct Interval {
    double dt;                      // [s]
    Eigen::Vector3d w, a, phi;      // [rad/s], [m/s²], [rad]
    Eigen::Matrix3d a_skew, dR, Jr;  // [a]x, Exp(φ), Jr(φ)
  };
  Interval IntervalAt(std::size_t k) const;
  // σ_g², σ_a² (white) and σ_bg², σ_ba² (random walk) of the rig's IMU; a zero random walk (a
  // noise-free simulated IMU) still gets a finite weight.
  std::array<double, 4> NoiseVariances() const;
  // Propagates the covariance of [δφ, δv, δp, w_g, w_a] over the samples with the given
  // variances (σ_g², σ_a² white, σ_bg², σ_ba² random walk) at the current linearization biases.
  Eigen::Matrix<double, 15, 15> PropagateCovariance(double sg2, double sa2, double sbg2,
                                                    double sba2) const;

  std::vector<ImuSample> samples_;
  ImuNoise noise_;
  Eigen::Vector3d gyro_bias_, accel_bias_;
  double dt_s_ = 0.0;
  Eigen::Quaterniond delta_R_ = Eigen::Quaterniond::Identity();
  Eigen::Vector3d delta_v_ = Eigen::Vector3d::Zero(), delta_p_ = Eigen::Vector3d::Zero();
  Eigen::Matrix3d dR_dbg_, dv_dbg_, dv_dba_, dp_dbg_, dp_dba_;
  Eigen::Matrix<double, 15, 15> covariance_;
};

}  // namespace vilma::mapping
