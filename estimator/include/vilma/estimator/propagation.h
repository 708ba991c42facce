// IMU propagation of the filter state and its error-state Jacobians (ROVIO, IJRR 2017,
// sec. 3.2-3.3, discretized by one explicit Euler step per IMU interval).
//
// Continuous model (omega_I = omega_m - b_g - n_g, a_I = a_m - b_a - n_a):
//   p_dot = v_M,  v_dot = R_M_I a_I + g_M,  q_dot = q (x) [0, omega_I / 2],  b_dot = n_b
// and for each feature, with the camera's angular and linear velocity in C
//   omega_C = R_C_I omega_I,  v_C = R_C_I (R_M_I^T v_M + omega_I x p_I_C),
// the robocentric point p_C = mu / rho moves as p_C_dot = -omega_C x p_C - v_C, i.e.
// (IJRR 2017, eq. 12-13) mu_dot = -omega_C x mu - rho (I - mu mu^T) v_C,
// rho_dot = rho^2 mu^T v_C. Discretized exactly in the ray direction:
//   m = Exp(-omega_C dt) (mu - rho dt v_C),  mu' = m / |m|,  rho' = rho / |m|
// which is well defined for features at infinity (rho = 0).
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <vector>

#include "vilma/estimator/filter_state.h"

namespace vilma::estimator {

// d x' / d x of one step (error-state, dx' = F dx): the core block and, per feature slot, its
// rows against the core and against itself (F is otherwise the identity).
struct PropagationJacobians {
  Eigen::Matrix<double, kCoreDim, kCoreDim> F_core;
  std::vector<Eigen::Matrix<double, kFeatureDim, kCoreDim>> F_feature_core;
  std::vector<Eigen::Matrix<double, kFeatureDim, kFeatureDim>> F_feature_self;
  // Allocates for `num_slots` feature slots (once; Propagate reuses the storage).
  void Resize(int num_slots);
};

// Noise of one step in continuous-time densities (units as the rig's ImuNoise).
struct PropagationNoise {
  double gyro_noise_density = 0.0;       // [rad/s/sqrt(Hz)]
  double accel_noise_density = 0.0;      // [m/s^2/sqrt(Hz)]
  double gyro_random_walk = 0.0;         // [rad/s^2/sqrt(Hz)]
  double accel_random_walk = 0.0;        // [m/s^3/sqrt(Hz)]
  double bearing = 0.0;                  // [rad/sqrt(s)]
  double inverse_depth = 0.0;            // [1/m/sqrt(s)]
  double extrinsic_rotation = 0.0;       // [rad/sqrt(s)], 0 when extrinsics are fixed
  double extrinsic_translation = 0.0;    // [m/sqrt(s)]
  double time_offset = 0.0;              // [s/sqrt(s)], 0 when td is fixed
};

// One step of the mean over dt [s] with the IMU measurement (omega_m [rad/s], a_m [m/s^2])
// held over the interval (VioFilter passes the measurement interpolated at its midpoint):
// q' = q Exp(omega_I dt), and the specific force is rotated into M with the midpoint attitude,
// a_M = R_M_I Exp(omega_I dt / 2) a_I + g_M (session 35; the start attitude lagged by dt / 2),
// v' = v + a_M dt, p' = p + v dt + a_M dt^2 / 2; gravity g_M = (0, 0, -gravity). Writes the Jacobians
// if J is not null (J must have been resized to the slot count). Allocation-free.
void PropagateMean(const Eigen::Vector3d& omega_m, const Eigen::Vector3d& a_m, double dt,
                   double gravity, FilterState* x, PropagationJacobians* J);

// Observability-constrained propagation of the yaw direction (OC-EKF: J. A. Hesch, D. G.
// Kottas, S. L. Bowman, S. I. Roumeliotis, "Consistency analysis and improvement of vision-aided
// inertial navigation", IEEE T-RO 30(1), 2014, sec. V; the first-estimate idea of G. P. Huang,
// A. I. Mourikis, S. I. Roumeliotis, "A first-estimates Jacobian EKF for improving SLAM
// consistency", ISER 2008). Turning the whole scene about M's vertical changes nothing the
// filter measures. Its error-state direction at a state x is the yaw null vector
//   N(x) = [dp = e_z x p, dv = e_z x v_M, dtheta = R_M_I^T e_z, 0 (biases, extrinsics, td,
//           features)],
// every measurement has H N = 0 (it depends on features and td only), and one step's F(x)
// maps N(x) onto N(x') exactly (x' the propagated mean; tested). But after an update the next
// step's F is evaluated at the corrected state x+ while the covariance carries the direction
// of the state before the update, x-: F(x+) N(x-) != N(x'), and the filter can gain
// information about yaw (and through it the gyro bias about the vertical) that the data do not
// hold. (Measured in session 35: the default filter gains none on the simulated street, and
// this option changes the ATE by <= 2 %; it is off by default.)
// ConstrainYawNullspace changes F's attitude columns by a rank-one term so that
// F N(anchor) = N(x') in every row, where the anchor is the state from which the covariance's
// null direction was propagated (the state before the update on the first step after a frame;
// on every other step the anchor is the step's own start and the change is zero to rounding).
// `p_anchor`, `v_anchor`, `q_anchor`: position, velocity and attitude of the anchor state;
// `x_next`: the mean after PropagateMean; J: that step's Jacobians (modified in place).
void ConstrainYawNullspace(const Eigen::Vector3d& p_anchor, const Eigen::Vector3d& v_anchor,
                           const Eigen::Quaterniond& q_anchor, const FilterState& x_next,
                           PropagationJacobians* J);

// Scratch for PropagateCovariance (sized on first use, then reused).
struct PropagationWorkspace {
  Eigen::MatrixXd FP;                          // n x n
  Eigen::Matrix<double, Eigen::Dynamic, 6> G;  // n x 6 noise input matrix
};

// P <- F P F^T + G Q G^T exploiting the block structure of F (O(n^2 * 21) instead of O(n^3)).
// The gyro and accelerometer white noise enter through the columns of F that belong to the
// biases (omega_I = omega_m - b_g - n_g), so the correlated noise of the features is exact.
// Only active feature slots are propagated; inactive slots keep zero covariance. `work` is
// scratch.
void PropagateCovariance(const PropagationJacobians& J, const PropagationNoise& noise, double dt,
                         const std::vector<FeatureState>& features, Eigen::MatrixXd* P,
                         PropagationWorkspace* work);

}  // namespace vilma::estimator
