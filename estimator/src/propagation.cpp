#include "vilma/estimator/propagation.h"

#include <cmath>

#include "vilma/core/geometry.h"

namespace vilma::estimator {

void PropagationJacobians::Resize(int num_slots) {
  F_feature_core.resize(static_cast<std::size_t>(num_slots));
  F_feature_self.resize(static_cast<std::size_t>(num_slots));
}

void PropagateMean(const Eigen::Vector3d& omega_m, const Eigen::Vector3d& a_m, double dt,
                   double gravity, FilterState* x, PropagationJacobians* J) {
  using Eigen::Matrix3d;
  using Eigen::Vector3d;
  const Vector3d g_M(0.0, 0.0, -gravity);
  const Vector3d omega_I = omega_m - x->b_g;
  const Vector3d a_I = a_m - x->b_a;
  const Matrix3d R_M_I = x->q_M_I.toRotationMatrix();
  const Matrix3d R_C_I = x->q_I_C.toRotationMatrix().transpose();
  const Vector3d v_I = R_M_I.transpose() * x->v_M;
  const Vector3d phi = omega_I * dt;
  const Matrix3d R_step = ExpSO3(phi).toRotationMatrix();
  // The specific force (measured at the interval's midpoint) is rotated into M with the
  // attitude at the midpoint, R_M_I Exp(phi / 2): with the attitude at the start the
  // acceleration lags by dt / 2 of rotation, |omega x a| dt / 2 (a few mm/s^2 while the body
  // pitches or rolls under gravity, as large as the accelerometer's white noise over 1 s;
  // tests/estimator/propagation_consistency_sim_test.cpp).
  const Matrix3d R_half = ExpSO3(0.5 * phi).toRotationMatrix();
  const Vector3d a_half = R_half * a_I;  // the specific force in the midpoint frame's axes
  const Vector3d a_M = R_M_I * a_half + g_M;

  // Camera velocities in C (see the header).
  const Vector3d omega_C = R_C_I * omega_I;
  const Vector3d v_C = R_C_I * (v_I + omega_I.cross(x->p_I_C));
  const Vector3d phi_C = -omega_C * dt;
  const Matrix3d R_feat = ExpSO3(phi_C).toRotationMatrix();

  if (J != nullptr) {
    // Core block: p' = p + v dt + a_M dt^2 / 2, v' = v + a_M dt, q' = q Exp(omega dt).
    auto& F = J->F_core;
    F.setIdentity();
    // d a_M / d theta = -R [R_half a_I]x; d a_M / d b_a = -R R_half;
    // d a_M / d b_g = R (d Exp(phi/2) a_I / d phi) (-dt) = R R_half [a_I]x Jr(phi/2) dt / 2.
    const Matrix3d R_skew_a = R_M_I * Skew(a_half);
    const Matrix3d da_dba = -R_M_I * R_half;
    const Matrix3d da_dbg = 0.5 * dt * R_M_I * R_half * Skew(a_I) * RightJacobianSO3(0.5 * phi);
    F.block<3, 3>(kIdxP, kIdxV) = Matrix3d::Identity() * dt;
    F.block<3, 3>(kIdxP, kIdxQ) = -0.5 * dt * dt * R_skew_a;
    F.block<3, 3>(kIdxP, kIdxBg) = 0.5 * dt * dt * da_dbg;
    F.block<3, 3>(kIdxP, kIdxBa) = 0.5 * dt * dt * da_dba;
    F.block<3, 3>(kIdxV, kIdxQ) = -dt * R_skew_a;
    F.block<3, 3>(kIdxV, kIdxBg) = dt * da_dbg;
    F.block<3, 3>(kIdxV, kIdxBa) = dt * da_dba;
    F.block<3, 3>(kIdxQ, kIdxQ) = R_step.transpose();
    F.block<3, 3>(kIdxQ, kIdxBg) = -RightJacobianSO3(phi) * dt;

    // d v_C / d core and d omega_C / d core (only v, theta, b_g and the extrinsics).
    Eigen::Matrix<double, 3, kCoreDim> dvC = Eigen::Matrix<double, 3, kCoreDim>::Zero();
    Eigen::Matrix<double, 3, kCoreDim> dwC = Eigen::Matrix<double, 3, kCoreDim>::Zero();
    dvC.block<3, 3>(0, kIdxV) = R_C_I * R_M_I.transpose();
    dvC.block<3, 3>(0, kIdxQ) = R_C_I * Skew(v_I);
    dvC.block<3, 3>(0, kIdxBg) = R_C_I * Skew(x->p_I_C);
    dvC.block<3, 3>(0, kIdxQIC) = Skew(v_C);
    dvC.block<3, 3>(0, kIdxPIC) = R_C_I * Skew(omega_I);
    dwC.block<3, 3>(0, kIdxBg) = -R_C_I;
    dwC.block<3, 3>(0, kIdxQIC) = Skew(omega_C);

    for (std::size_t i = 0; i < x->features.size(); ++i) {
      const FeatureState& f = x->features[i];
      auto& Fc = J->F_feature_core[i];
      auto& Fs = J->F_feature_self[i];
      if (!f.active) {
        Fc.setZero();
        Fs.setIdentity();
        continue;
      }
      const Vector3d u = f.mu_C - f.rho * dt * v_C;
      const Vector3d m = R_feat * u;
      const double n = m.norm();
      const Vector3d mu_new = m / n;
      const Eigen::Matrix<double, 3, 2> B = BearingBasis(f.mu_C);
      const Eigen::Matrix<double, 3, 2> B_new = BearingBasis(mu_new);
      // d m / d v_C, d m / d omega_C (d Exp(phi) u / d phi = -Exp(phi) [u]x Jr(phi)).
      const Matrix3d dm_dvC = -f.rho * dt * R_feat;
      const Matrix3d dm_dwC = R_feat * Skew(u) * RightJacobianSO3(phi_C) * dt;
      const Eigen::Matrix<double, 3, kCoreDim> dm_dcore = dm_dvC * dvC + dm_dwC * dwC;
      const Vector3d dm_drho = -dt * R_feat * v_C;
      const Eigen::Matrix<double, 3, 2> dm_dmu = R_feat * B;
      // dmu' = B'^T dm / |m| (B' is orthogonal to mu'); drho' = drho / |m| - rho mu'^T dm / |m|^2.
      Fc.topRows<2>() = B_new.transpose() * dm_dcore / n;
      Fc.row(2) = -f.rho / (n * n) * mu_new.transpose() * dm_dcore;
      Fs.block<2, 2>(0, 0) = B_new.transpose() * dm_dmu / n;
      Fs.block<2, 1>(0, 2) = B_new.transpose() * dm_drho / n;
      Fs.block<1, 2>(2, 0) = -f.rho / (n * n) * mu_new.transpose() * dm_dmu;
      Fs(2, 2) = 1.0 / n - f.rho / (n * n) * mu_new.dot(dm_drho);
    }
  }

  // Mean.
  for (FeatureState& f : x->features) {
    if (!f.active) continue;
    const Vector3d m = R_feat * (f.mu_C - f.rho * dt * v_C);
    const double n = m.norm();
    f.mu_C = m / n;
    f.rho = f.rho / n;
  }
  x->p_M_I += x->v_M * dt + 0.5 * dt * dt * a_M;
  x->v_M += a_M * dt;
  x->q_M_I = (x->q_M_I * ExpSO3(phi)).normalized();
  x->t_ns += static_cast<int64_t>(std::llround(dt * 1e9));
}

void ConstrainYawNullspace(const Eigen::Vector3d& p_anchor, const Eigen::Vector3d& v_anchor,
                           const Eigen::Quaterniond& q_anchor, const FilterState& x_next,
                           PropagationJacobians* J) {
  using Eigen::Vector3d;
  using CoreVector = Eigen::Matrix<double, kCoreDim, 1>;
  const Vector3d e_z = Vector3d::UnitZ();
  CoreVector u = CoreVector::Zero();  // N(anchor), core part (its feature part is zero)
  u.segment<3>(kIdxP) = e_z.cross(p_anchor);
  u.segment<3>(kIdxV) = e_z.cross(v_anchor);
  u.segment<3>(kIdxQ) = q_anchor.conjugate() * e_z;
  CoreVector w = CoreVector::Zero();  // N(x_next)
  w.segment<3>(kIdxP) = e_z.cross(x_next.p_M_I);
  w.segment<3>(kIdxV) = e_z.cross(x_next.v_M);
  w.segment<3>(kIdxQ) = x_next.q_M_I.conjugate() * e_z;
  const Vector3d u_theta = u.segment<3>(kIdxQ);  // a unit vector
  // Rank-one change of the attitude columns, A* = A + (w - F u) u_theta^T: the smallest change
  // (Frobenius norm) of A that gives F* u = w (the OC-EKF's constrained least squares).
  const CoreVector r = w - J->F_core * u;
  J->F_core.middleCols<3>(kIdxQ) += r * u_theta.transpose();
  for (auto& Fc : J->F_feature_core) {
    // Required: F_feature_core N(anchor) = 0 (inactive slots have Fc = 0: no change).
    const Eigen::Matrix<double, kFeatureDim, 1> rf = -(Fc * u);
    Fc.middleCols<3>(kIdxQ) += rf * u_theta.transpose();
  }
}

void PropagateCovariance(const PropagationJacobians& J, const PropagationNoise& noise, double dt,
                         const std::vector<FeatureState>& features, Eigen::MatrixXd* P_ptr,
                         PropagationWorkspace* work) {
  Eigen::MatrixXd& P = *P_ptr;
  const int n = static_cast<int>(P.rows());
  Eigen::MatrixXd& A = work->FP;
  if (A.rows() != n || A.cols() != n) A.resize(n, n);
  auto& G = work->G;
  if (G.rows() != n) G.resize(n, 6);

  // A = F P (rows).
  A.topRows<kCoreDim>().noalias() = J.F_core * P.topRows<kCoreDim>();
  for (std::size_t i = 0; i < features.size(); ++i) {
    const int k = FeatureIndex(static_cast<int>(i));
    if (!features[i].active) {
      A.middleRows<kFeatureDim>(k).setZero();
      continue;
    }
    A.middleRows<kFeatureDim>(k).noalias() = J.F_feature_core[i] * P.topRows<kCoreDim>();
    A.middleRows<kFeatureDim>(k).noalias() += J.F_feature_self[i] * P.middleRows<kFeatureDim>(k);
  }
  // P = A F^T (columns).
  P.leftCols<kCoreDim>().noalias() = A.leftCols<kCoreDim>() * J.F_core.transpose();
  for (std::size_t i = 0; i < features.size(); ++i) {
    const int k = FeatureIndex(static_cast<int>(i));
    if (!features[i].active) {
      P.middleCols<kFeatureDim>(k).setZero();
      continue;
    }
    P.middleCols<kFeatureDim>(k).noalias() =
        A.leftCols<kCoreDim>() * J.F_feature_core[i].transpose();
    P.middleCols<kFeatureDim>(k).noalias() +=
        A.middleCols<kFeatureDim>(k) * J.F_feature_self[i].transpose();
  }

  // White IMU noise through the bias columns of F (G = dF/db with the bias rows removed),
  // discrete variance sigma^2 / dt per sample.
  G.setZero();
  G.block<kCoreDim, 3>(0, 0) = J.F_core.block<kCoreDim, 3>(0, kIdxBg);
  G.block<kCoreDim, 3>(0, 3) = J.F_core.block<kCoreDim, 3>(0, kIdxBa);
  G.block<3, 3>(kIdxBg, 0).setZero();
  G.block<3, 3>(kIdxBa, 3).setZero();
  for (std::size_t i = 0; i < features.size(); ++i) {
    if (!features[i].active) continue;
    const int k = FeatureIndex(static_cast<int>(i));
    G.block<kFeatureDim, 3>(k, 0) = J.F_feature_core[i].middleCols<3>(kIdxBg);
    G.block<kFeatureDim, 3>(k, 3) = J.F_feature_core[i].middleCols<3>(kIdxBa);
  }
  G.leftCols<3>() *= noise.gyro_noise_density / std::sqrt(dt);
  G.rightCols<3>() *= noise.accel_noise_density / std::sqrt(dt);
  P.noalias() += G * G.transpose();

  // Random walks.
  auto add_diag = [&](int index, int count, double density) {
    const double q = density * density * dt;
    for (int j = 0; j < count; ++j) P(index + j, index + j) += q;
  };
  add_diag(kIdxBg, 3, noise.gyro_random_walk);
  add_diag(kIdxBa, 3, noise.accel_random_walk);
  add_diag(kIdxQIC, 3, noise.extrinsic_rotation);
  add_diag(kIdxPIC, 3, noise.extrinsic_translation);
  add_diag(kIdxTd, 1, noise.time_offset);
  for (std::size_t i = 0; i < features.size(); ++i) {
    if (!features[i].active) continue;
    const int k = FeatureIndex(static_cast<int>(i));
    add_diag(k, 2, noise.bearing);
    add_diag(k + 2, 1, noise.inverse_depth);
  }
}

}  // namespace vilma::estimator
