// IMU preintegration between camera frames for the dynamic (moving-start) initializer
// (docs/estimator.md, "Moving start"). With frame 0 as reference, biases held constant:
//
//   R_0_k  = prod Exp((omega_m - b_g) dt)                 (rotation I_0 <- I_k)
//   beta_k  = sum R_0_s (a_m - b_a) dt                     (velocity change without gravity, in I_0)
//   alpha_k = sum beta_s dt + R_0_s (a_m - b_a) dt^2 / 2   (position change likewise)
// (R_0_s at the middle of each piece: second order in dt)
//
// so that, with v_0 and g in I_0 (g = R_M_I0^T g_M):
//   p_I0_Ik = v_0 t_k + g t_k^2 / 2 + alpha_k,   v_Ik (in I_0) = v_0 + g t_k + beta_k.
// The bias Jacobians are the exact derivatives of this discrete scheme (first-order bias
// correction in the manner of Forster et al., "On-manifold preintegration", T-RO 2017):
//   R_0_k(b_g + d) ~ R_0_k Exp(d_R_d_bg d),  alpha(b + d) ~ alpha + d_alpha_d_b d, ...
// Sampling: the interval [t_0, t_K] is cut at every IMU sample and frame time; each piece uses
// the measurement linearly interpolated at its middle (held constant outside the samples), as
// the filter's propagation does.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

#include "vilma/core/imu.h"

namespace vilma::estimator {

struct PreintegratedImu {
  double dt_s = 0.0;  // t_k - t_0 [s]
  Eigen::Quaterniond q_0_k = Eigen::Quaterniond::Identity();  // R_I0_Ik
  Eigen::Vector3d alpha = Eigen::Vector3d::Zero();  // [m]
  Eigen::Vector3d beta = Eigen::Vector3d::Zero();   // [m/s]
  Eigen::Matrix3d d_R_d_bg = Eigen::Matrix3d::Zero();  // right perturbation of R_0_k [s]
  Eigen::Matrix3d d_alpha_d_bg = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d d_alpha_d_ba = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d d_beta_d_bg = Eigen::Matrix3d::Zero();
  Eigen::Matrix3d d_beta_d_ba = Eigen::Matrix3d::Zero();
};

// Preintegrates `samples` (sorted by time) from frame_t_ns[0] to every frame time (sorted,
// non-decreasing); result k is frame 0 -> frame k (result 0 is the identity). Empty `samples`
// or frame times outside them hold the nearest measurement constant.
std::vector<PreintegratedImu> PreintegrateImu(const std::vector<ImuSample>& samples,
                                              const std::vector<int64_t>& frame_t_ns,
                                              const Eigen::Vector3d& b_g,
                                              const Eigen::Vector3d& b_a);

}  // namespace vilma::estimator
