// Visual-inertial alignment for a moving start (docs/estimator.md, "Moving start"): from
// feature bearings tracked over a short window of frames and the IMU preintegrated between
// them, the velocity v_0 and the gravity g of the first frame's IMU frame I0, the IMU biases and
// the feature positions. Written from the linear formulation of Dong-Si & Mourikis ("Estimator
// initialization in vision-aided inertial navigation with unknown camera-IMU calibration",
// IROS 2012) and the refinement idea of Geneva et al. (OpenVINS dynamic initialization).
//
// Model (all in I0, frame 0 of the window; R_0k, alpha_k from imu_preintegration.h):
//   p_Ik = v_0 t_k + g t_k^2 / 2 + alpha_k,    q = R_0k^T (p_f - p_Ik)       (point in I_k)
//   p_C  = R_C_I (q - p_I_C),                  measured bearing b ~ p_C / |p_C|.
// 1. Linear: b x p_C = 0 gives two equations per observation, B(b)^T p_C = 0, linear in
//    (p_f, v_0, g) for given rotations; features and v_0 are eliminated (Schur complement) and
//    the 3x3 problem in g is solved with |g| = G exactly (trust-region secular equation).
// 2. Gauss-Newton / Levenberg-Marquardt on the bearing errors r = B(b)^T p_C / |p_C| [rad]
//    with g = G u, u on the unit sphere (tangent step via BearingBoxPlus), the biases (with
//    priors; the preintegration is recomputed at every new bias), Huber weights.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "vilma/core/geometry.h"
#include "vilma/core/imu.h"
#include "vilma/estimator/imu_preintegration.h"

namespace vilma::estimator {

struct AlignmentObservation {
  int feature = 0;  // 0 .. num_features - 1
  int frame = 0;    // 0 .. frames - 1
  Eigen::Vector3d bearing_C = Eigen::Vector3d::UnitZ();  // unit, undistorted
};

struct AlignmentInput {
  std::vector<int64_t> frame_t_ns;  // IMU clock, increasing; frame 0 defines I0
  std::vector<ImuSample> imu;       // covering the frames
  std::vector<AlignmentObservation> observations;
  int num_features = 0;
  Transformation T_I_C;
  double gravity_magnitude = kDefaultGravityMagnitude;  // G [m/s^2]
};

struct AlignmentOptions {
  double bearing_sigma = 1.0 / 450.0;  // observation noise [rad] (about 1 px)
  double huber_sigmas = 2.0;           // Huber threshold in units of bearing_sigma
  double gyro_bias_sigma = 0.1;        // prior std around 0 [rad/s]
  double accel_bias_sigma = 0.1;       // prior std around 0 [m/s^2]
  int max_iterations = 15;
};

// Parameter layout of the refinement and of the covariance.
constexpr int kAlignV = 0;    // v_0 (3)
constexpr int kAlignG = 3;    // tangent of u = g / G at u (2, BearingBasis(u))
constexpr int kAlignBg = 5;   // gyroscope bias (3)
constexpr int kAlignBa = 8;   // accelerometer bias (3)
constexpr int kAlignDim = 11;

struct AlignmentSolution {
  Eigen::Vector3d v_I0 = Eigen::Vector3d::Zero();  // velocity at frame 0, in I0 [m/s]
  Eigen::Vector3d g_I0 = Eigen::Vector3d::Zero();  // gravity in I0, |g| = G [m/s^2]
  Eigen::Vector3d b_g = Eigen::Vector3d::Zero();
  Eigen::Vector3d b_a = Eigen::Vector3d::Zero();
  std::vector<Eigen::Vector3d> p_I0_f;  // per feature [m]
  std::vector<bool> feature_valid;      // enough observations and a non-degenerate position
  // Linear step: |g| of the unconstrained solution (a check: should be close to G) [m/s^2].
  double unconstrained_gravity_norm = 0.0;
  // Refinement: marginal covariance of (v_0, u tangent, b_g, b_a), layout kAlign*.
  Eigen::Matrix<double, kAlignDim, kAlignDim> covariance =
      Eigen::Matrix<double, kAlignDim, kAlignDim>::Zero();
  double rms_inlier_rad = 0.0;  // RMS bearing error of the inliers (|r| < 3 sigma) [rad]
  int observations_used = 0;    // of valid features
  int inliers = 0;
  int iterations = 0;
};

// Step 1 for the given biases (the preintegration `pre` was computed with them). False (with
// the reason) when too few features are usable or the reduced system is singular.
bool SolveLinearAlignment(const AlignmentInput& input, const std::vector<PreintegratedImu>& pre,
                          AlignmentSolution* solution, std::string* why_not);

// Step 2 from `solution` (step 1's result); fills the covariance and residual statistics.
bool RefineAlignment(const AlignmentInput& input, const AlignmentOptions& options,
                     AlignmentSolution* solution, std::string* why_not);

// The bearing error of one observation in frame k (pre = preintegration 0 -> k at biases b_g,
// b_a) and, if J is given, its Jacobian d r / d [dv(3) du(2) db_g(3) db_a(3) dp_f(3)] with
// u (+) du = BearingBoxPlus(u, du). False if the point is not in front of the camera.
bool AlignmentResidual(const Eigen::Vector3d& v_I0, const Eigen::Vector3d& u_I0, double G,
                       const PreintegratedImu& pre, const Transformation& T_I_C,
                       const Eigen::Vector3d& p_I0_f, const Eigen::Vector3d& bearing_C,
                       Eigen::Vector2d* r, Eigen::Matrix<double, 2, 14>* J);

// argmin g^T A g - 2 b^T g subject to |g| = radius, A symmetric (any definiteness): the global
// minimizer from the Lagrange condition (A + lambda I) g = b, lambda >= -lambda_min(A).
Eigen::Vector3d MinimizeQuadraticOnSphere(const Eigen::Matrix3d& A, const Eigen::Vector3d& b,
                                          double radius);

}  // namespace vilma::estimator
