#include "vilma/mapping/optimization/inertial_residual.h"

#include <ceres/jet.h>
#include <ceres/rotation.h>

#include <Eigen/Cholesky>

#include "jet_pose.h"

namespace vilma::mapping {

namespace {

// The unwhitened residual at (x ⊞ δ) for the four blocks.
template <typename T>
void Residual(const ImuPreintegration& pre, double gravity, double const* const* x,
              const T* delta, T* r) {
  T p_i[3], q_i[4], p_j[3], q_j[4];
  PlusPose(x[0], delta, p_i, q_i);
  PlusPose(x[2], delta + 15, p_j, q_j);
  T sb_i[9], sb_j[9];
  for (int k = 0; k < 9; ++k) {
    sb_i[k] = T(x[1][k]) + delta[6 + k];
    sb_j[k] = T(x[3][k]) + delta[21 + k];
  }
  const T* v_i = sb_i;
  const T* bg_i = sb_i + 3;
  const T* ba_i = sb_i + 6;
  const T* v_j = sb_j;

  // First-order bias correction (Forster eq. 44).
  T dbg[3], dba[3];
  for (int k = 0; k < 3; ++k) {
    dbg[k] = bg_i[k] - T(pre.gyro_bias()[k]);
    dba[k] = ba_i[k] - T(pre.accel_bias()[k]);
  }
  T phi[3], dv[3], dp[3];
  for (int a = 0; a < 3; ++a) {
    phi[a] = T(0);
    dv[a] = T(pre.delta_v()[a]);
    dp[a] = T(pre.delta_p()[a]);
    for (int b = 0; b < 3; ++b) {
      phi[a] += T(pre.dR_dbg()(a, b)) * dbg[b];
      dv[a] += T(pre.dv_dbg()(a, b)) * dbg[b] + T(pre.dv_dba()(a, b)) * dba[b];
      dp[a] += T(pre.dp_dbg()(a, b)) * dbg[b] + T(pre.dp_dba()(a, b)) * dba[b];
    }
  }
  const Eigen::Quaterniond& dR = pre.delta_R();
  const T dR0[4] = {T(dR.w()), T(dR.x()), T(dR.y()), T(dR.z())};
  T dq_corr[4], dR_corrected[4];
  ceres::AngleAxisToQuaternion(phi, dq_corr);
  ceres::QuaternionProduct(dR0, dq_corr, dR_corrected);

  // r_R = Log(ΔR̃ᵀ R_iᵀ R_j)
  T qi_inv[4], dR_inv[4], q_ij[4], err[4];
  Conjugate(q_i, qi_inv);
  ceres::QuaternionProduct(qi_inv, q_j, q_ij);
  Conjugate(dR_corrected, dR_inv);
  ceres::QuaternionProduct(dR_inv, q_ij, err);
  if (err[0] < T(0)) {  // the shorter rotation
    for (T& e : err) e = -e;
  }
  ceres::QuaternionToAngleAxis(err, r);

  const double dt = pre.dt_s();
  const T g[3] = {T(0), T(0), T(-gravity)};
  T a[3], b[3];
  for (int k = 0; k < 3; ++k) {
    a[k] = v_j[k] - v_i[k] - g[k] * dt;
    b[k] = p_j[k] - p_i[k] - v_i[k] * dt - T(0.5) * g[k] * dt * dt;
  }
  T Ra[3], Rb[3];
  RotateInverse(q_i, a, Ra);
  RotateInverse(q_i, b, Rb);
  for (int k = 0; k < 3; ++k) {
    r[3 + k] = Ra[k] - dv[k];
    r[6 + k] = Rb[k] - dp[k];
    r[9 + k] = sb_j[3 + k] - sb_i[3 + k];
    r[12 + k] = sb_j[6 + k] - sb_i[6 + k];
  }
}

}  // namespace

Eigen::Matrix<double, 15, 15> InertialCostFunction::SqrtInformation() const {
  // The joint covariance of the five residual blocks (imu_preintegration.h): the bias random
  // walk inside the edge is correlated with Δv and Δp.
  const Eigen::Matrix<double, 15, 15> information =
      preintegration_->full_covariance().inverse();
  return information.llt().matrixU();
}

Eigen::Matrix<double, 15, 1> InertialCostFunction::RawResidual(
    double const* const* parameters) const {
  const double zero[30] = {};
  Eigen::Matrix<double, 15, 1> r;
  Residual(*preintegration_, gravity_m_s2_, parameters, zero, r.data());
  return r;
}

bool InertialCostFunction::Evaluate(double const* const* parameters, double* residuals,
                                    double** jacobians) const {
  const Eigen::Matrix<double, 15, 15> U = SqrtInformation();
  Eigen::Map<Eigen::Matrix<double, 15, 1>> out(residuals);
  if (jacobians == nullptr) {
    out = U * RawResidual(parameters);
    return true;
  }
  using Jet = ceres::Jet<double, 30>;
  Jet delta[30];
  for (int k = 0; k < 30; ++k) delta[k] = Jet(0.0, k);
  Jet r[15];
  Residual(*preintegration_, gravity_m_s2_, parameters, delta, r);
  Eigen::Matrix<double, 15, 1> value;
  Eigen::Matrix<double, 15, 30> J;
  for (int i = 0; i < 15; ++i) {
    value[i] = r[i].a;
    J.row(i) = r[i].v.transpose();
  }
  out = U * value;
  const Eigen::Matrix<double, 15, 30> WJ = U * J;
  // Tangent columns of each block: pose 6 (+1 zero column), speed-bias 9.
  const int offset[4] = {0, 6, 15, 21};
  const int tangent[4] = {6, 9, 6, 9};
  const int ambient[4] = {7, 9, 7, 9};
  for (int b = 0; b < 4; ++b) {
    if (jacobians[b] == nullptr) continue;
    Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> Jb(
        jacobians[b], 15, ambient[b]);
    Jb.setZero();
    Jb.leftCols(tangent[b]) = WJ.middleCols(offset[b], tangent[b]);
  }
  return true;
}

}  // namespace vilma::mapping
