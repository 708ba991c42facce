// State of the ROVIO-style filter (Bloesch et al., IJRR 2017, sec. 3) and its error-state
// ("boxplus") parametrization. Frames: M, the mission (gravity-aligned odometry) frame
// (g_M = (0, 0, -g)); I the IMU; C the camera. Hamilton quaternions (Eigen).
//
// Mean:   p_M_I, v_M, q_M_I, b_g, b_a, q_I_C, p_I_C, and per feature slot a unit bearing mu_C
//         (camera frame, robocentric) and an inverse distance rho (|p_C| = 1 / rho).
// Error:  dx = [dp(3) dv(3) dtheta(3) dbg(3) dba(3) dphi_IC(3) dp_IC(3) dtd(1) |
//               per slot dmu(2) drho]
//         with p = p + dp, q_M_I = q_M_I Exp(dtheta) (right perturbation), q_I_C likewise, and
//         mu (+) dmu = Exp([mu]x B(mu) dmu) mu: the rotation that moves mu by B(mu) dmu to
//         first order, B(mu) a 3x2 orthonormal basis of the tangent plane (BearingBasis).
// The covariance always has rows for every slot (preallocated to max features): an inactive
// slot has zero rows and columns. The extrinsics and the time-offset correction td are always
// in the state; when they are not estimated their covariance is zero, which keeps them fixed.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <vector>

namespace vilma::estimator {

// Error-state indices of the core block.
constexpr int kIdxP = 0;
constexpr int kIdxV = 3;
constexpr int kIdxQ = 6;
constexpr int kIdxBg = 9;
constexpr int kIdxBa = 12;
constexpr int kIdxQIC = 15;
constexpr int kIdxPIC = 18;
constexpr int kIdxTd = 21;
constexpr int kCoreDim = 22;
constexpr int kFeatureDim = 3;  // dmu (2), drho (1)

inline int FeatureIndex(int slot) { return kCoreDim + kFeatureDim * slot; }

// Tangent basis of the unit sphere at mu: the first two columns of the minimal rotation that
// takes e_z to mu. Orthonormal, orthogonal to mu and smooth everywhere except mu = -e_z
// (a bearing pointing straight backwards, which a tracked feature never has).
Eigen::Matrix<double, 3, 2> BearingBasis(const Eigen::Vector3d& mu);
// mu (+) d = Exp([mu]x B(mu) d) mu: rotates mu by angle |d| towards B(mu) d.
Eigen::Vector3d BearingBoxPlus(const Eigen::Vector3d& mu, const Eigen::Vector2d& d);
// Inverse of BearingBoxPlus: mu1 (-) mu0 in the tangent basis of mu0.
Eigen::Vector2d BearingBoxMinus(const Eigen::Vector3d& mu1, const Eigen::Vector3d& mu0);

struct FeatureState {
  bool active = false;
  Eigen::Vector3d mu_C = Eigen::Vector3d::UnitZ();  // unit bearing in C
  double rho = 0.5;                                  // inverse distance [1/m]
};

struct FilterState {
  int64_t t_ns = 0;  // IMU clock [ns]
  Eigen::Vector3d p_M_I = Eigen::Vector3d::Zero();  // [m]
  Eigen::Vector3d v_M = Eigen::Vector3d::Zero();    // [m/s]
  Eigen::Quaterniond q_M_I = Eigen::Quaterniond::Identity();
  Eigen::Vector3d b_g = Eigen::Vector3d::Zero();  // gyroscope bias [rad/s]
  Eigen::Vector3d b_a = Eigen::Vector3d::Zero();  // accelerometer bias [m/s^2]
  Eigen::Quaterniond q_I_C = Eigen::Quaterniond::Identity();
  Eigen::Vector3d p_I_C = Eigen::Vector3d::Zero();  // [m]
  // Correction of the rig's camera time offset: an image stamped t_cam was taken at
  // t_imu = t_cam + time_offset_ns (rig) + td. The state is propagated to t_cam + offset; the
  // features are predicted to the image time to first order (see vio_filter.cpp) [s].
  double td = 0.0;
  std::vector<FeatureState> features;              // one per slot (max features)

  int dim() const { return kCoreDim + kFeatureDim * static_cast<int>(features.size()); }
  int num_active() const;
};

// Median inverse depth of the active features with sqrt(P_rho) / rho <= max_ratio (rho > 0),
// over at least min_count of them (the upper median for an even count); false when fewer.
// P: the filter covariance over x's slots.
bool MedianInverseDepth(const FilterState& x, const Eigen::MatrixXd& P, double max_ratio,
                        int min_count, double* rho);

// x (+) dx, dx of size x.dim(); inactive slots are left as they are.
void BoxPlus(const FilterState& x, const Eigen::VectorXd& dx, FilterState* result);
// a (-) b (same slot layout); inactive slots of b give zeros.
Eigen::VectorXd BoxMinus(const FilterState& a, const FilterState& b);

}  // namespace vilma::estimator
