#include "vilma/estimator/propagation.h"

#include <catch2/catch.hpp>
#include <random>

#include "core/test_utils.h"
#include "test_random.h"
#include "vilma/core/geometry.h"

namespace vilma::estimator {
namespace {

FilterState RandomState(std::mt19937* rng, int slots) {
  std::normal_distribution<double> n(0.0, 1.0);
  auto vec = [&](double s) -> Eigen::Vector3d {
    return vilma::testing::DrawVector3([&] { return n(*rng); }) * s;
  };
  FilterState x;
  x.p_M_I = vec(2.0);
  x.v_M = vec(1.5);
  x.q_M_I = ExpSO3(vec(1.0));
  x.b_g = vec(0.05);
  x.b_a = vec(0.2);
  x.q_I_C = ExpSO3(vec(1.0));
  x.p_I_C = vec(0.1);
  x.td = 0.003;
  x.features.resize(static_cast<std::size_t>(slots));
  for (int i = 0; i < slots; ++i) {
    FeatureState& f = x.features[static_cast<std::size_t>(i)];
    f.active = i != 1;  // slot 1 stays inactive
    const double mu_y = 0.4 * n(*rng);  // y before x, as GCC drew them (tests/test_random.h)
    const double mu_x = 0.4 * n(*rng);
    f.mu_C = Eigen::Vector3d(mu_x, mu_y, 1.0).normalized();
    f.rho = 0.2 + 0.3 * std::abs(n(*rng));
  }
  return x;
}

Eigen::MatrixXd DenseF(const PropagationJacobians& J, const FilterState& x) {
  const int n = x.dim();
  Eigen::MatrixXd F = Eigen::MatrixXd::Identity(n, n);
  F.topLeftCorner<kCoreDim, kCoreDim>() = J.F_core;
  for (std::size_t i = 0; i < x.features.size(); ++i) {
    const int k = FeatureIndex(static_cast<int>(i));
    F.block<kFeatureDim, kCoreDim>(k, 0) = J.F_feature_core[i];
    F.block<kFeatureDim, kFeatureDim>(k, k) = J.F_feature_self[i];
  }
  return F;
}

TEST_CASE("propagation Jacobians match central differences of the discrete step") {
  std::mt19937 rng(7);
  const double dt = GENERATE(0.005, 0.05);
  for (int trial = 0; trial < 5; ++trial) {
    const FilterState x0 = RandomState(&rng, 4);
    const Eigen::Vector3d omega_m(0.3, -0.5, 0.8), a_m(0.4, 9.5, -1.2);
    PropagationJacobians J;
    J.Resize(4);
    FilterState x1 = x0;
    PropagateMean(omega_m, a_m, dt, 9.81, &x1, &J);
    const Eigen::MatrixXd F = DenseF(J, x0);
    const int n = x0.dim();
    Eigen::MatrixXd F_num(n, n);
    const double h = 1e-6;
    for (int j = 0; j < n; ++j) {
      Eigen::VectorXd d = Eigen::VectorXd::Zero(n);
      d[j] = h;
      FilterState xp, xm;
      BoxPlus(x0, d, &xp);
      BoxPlus(x0, -d, &xm);
      PropagateMean(omega_m, a_m, dt, 9.81, &xp, nullptr);
      PropagateMean(omega_m, a_m, dt, 9.81, &xm, nullptr);
      F_num.col(j) = (BoxMinus(xp, x1) - BoxMinus(xm, x1)) / (2.0 * h);
    }
    // Inactive slot: identity rows in F, zero in the numeric one (BoxMinus skips it).
    const int k1 = FeatureIndex(1);
    F_num.block<kFeatureDim, kFeatureDim>(k1, k1).setIdentity();
    VILMA_CHECK_MATRIX_NEAR(F, F_num, 1e-6);
  }
}

TEST_CASE("a wrong Jacobian block is detected by the numeric comparison") {
  // Guards the test above against comparing a matrix with itself.
  std::mt19937 rng(9);
  const FilterState x0 = RandomState(&rng, 2);
  PropagationJacobians J;
  J.Resize(2);
  FilterState x1 = x0;
  PropagateMean(Eigen::Vector3d(0.1, 0.2, 0.3), Eigen::Vector3d(0, 0, 9.81), 0.01, 9.81, &x1, &J);
  Eigen::MatrixXd F = DenseF(J, x0);
  const Eigen::MatrixXd F_ok = F;
  F(FeatureIndex(0), kIdxV) += 1e-3;
  CHECK_FALSE(test::MatricesNear(F, F_ok, 1e-6));
}

TEST_CASE("structured covariance propagation equals F P F^T + G Q G^T") {
  std::mt19937 rng(11);
  const FilterState x0 = RandomState(&rng, 3);
  const int n = x0.dim();
  Eigen::MatrixXd L = Eigen::MatrixXd::Random(n, n);
  Eigen::MatrixXd P = L * L.transpose() + Eigen::MatrixXd::Identity(n, n);
  const int k1 = FeatureIndex(1);  // inactive slot: zero rows and columns
  P.middleRows<3>(k1).setZero();
  P.middleCols<3>(k1).setZero();
  PropagationJacobians J;
  J.Resize(3);
  FilterState x1 = x0;
  const double dt = 0.005;
  PropagateMean(Eigen::Vector3d(0.1, 0.2, 0.3), Eigen::Vector3d(0.5, 0, 9.81), dt, 9.81, &x1,
                &J);
  PropagationNoise noise;
  noise.gyro_noise_density = 1e-3;
  noise.accel_noise_density = 2e-2;
  noise.gyro_random_walk = 1e-4;
  noise.accel_random_walk = 1e-3;
  noise.bearing = 1e-3;
  noise.inverse_depth = 2e-3;
  const Eigen::MatrixXd F = DenseF(J, x0);
  Eigen::MatrixXd G = Eigen::MatrixXd::Zero(n, 6);
  G.leftCols<3>() = F.middleCols<3>(kIdxBg);
  G.rightCols<3>() = F.middleCols<3>(kIdxBa);
  G.block<3, 3>(kIdxBg, 0).setZero();
  G.block<3, 3>(kIdxBa, 3).setZero();
  G.middleRows<3>(k1).setZero();
  Eigen::VectorXd q = Eigen::VectorXd::Zero(6);
  q << Eigen::Vector3d::Constant(1e-6 / dt), Eigen::Vector3d::Constant(4e-4 / dt);
  Eigen::MatrixXd expected = F * P * F.transpose() + G * q.asDiagonal() * G.transpose();
  for (int j = 0; j < 3; ++j) {
    expected(kIdxBg + j, kIdxBg + j) += 1e-8 * dt;
    expected(kIdxBa + j, kIdxBa + j) += 1e-6 * dt;
  }
  for (int s : {0, 2}) {
    const int k = FeatureIndex(s);
    expected(k, k) += 1e-6 * dt;
    expected(k + 1, k + 1) += 1e-6 * dt;
    expected(k + 2, k + 2) += 4e-6 * dt;
  }
  expected.middleRows<3>(k1).setZero();
  expected.middleCols<3>(k1).setZero();
  PropagationWorkspace work;
  PropagateCovariance(J, noise, dt, x0.features, &P, &work);
  VILMA_CHECK_MATRIX_NEAR(P, expected, 1e-12);
}

// The yaw null vector N(x) = [e_z x p, e_z x v_M, R_M_I^T e_z, 0, ...] (propagation.h,
// ConstrainYawNullspace) as a full error-state vector.
Eigen::VectorXd YawNullVector(const FilterState& x) {
  Eigen::VectorXd N = Eigen::VectorXd::Zero(x.dim());
  const Eigen::Vector3d e_z = Eigen::Vector3d::UnitZ();
  N.segment<3>(kIdxP) = e_z.cross(x.p_M_I);
  N.segment<3>(kIdxV) = e_z.cross(x.v_M);
  N.segment<3>(kIdxQ) = x.q_M_I.conjugate() * e_z;
  return N;
}

TEST_CASE("one propagation step maps the yaw null vector onto the next state's") {
  // Turning the scene about the vertical is unobservable: F(x) N(x) = N(x') exactly, at any
  // state (features included: they do not see the turn).
  std::mt19937 rng(13);
  for (int trial = 0; trial < 5; ++trial) {
    const FilterState x0 = RandomState(&rng, 3);
    PropagationJacobians J;
    J.Resize(3);
    FilterState x1 = x0;
    PropagateMean(Eigen::Vector3d(0.3, -0.5, 0.8), Eigen::Vector3d(0.4, 9.5, -1.2), 0.005, 9.81,
                  &x1, &J);
    Eigen::VectorXd FN = DenseF(J, x0) * YawNullVector(x0);
    FN.segment<3>(FeatureIndex(1)).setZero();  // inactive slot (identity rows in DenseF)
    VILMA_CHECK_MATRIX_NEAR(FN, YawNullVector(x1), 1e-12);
  }
}

TEST_CASE("the yaw constraint maps the anchor's null vector onto the next state's") {
  std::mt19937 rng(17);
  for (int trial = 0; trial < 5; ++trial) {
    const FilterState x0 = RandomState(&rng, 3);
    PropagationJacobians J;
    J.Resize(3);
    FilterState x1 = x0;
    PropagateMean(Eigen::Vector3d(0.3, -0.5, 0.8), Eigen::Vector3d(0.4, 9.5, -1.2), 0.005, 9.81,
                  &x1, &J);
    const PropagationJacobians J_plain = J;
    SECTION("anchor = the step's start: F is unchanged") {
      ConstrainYawNullspace(x0.p_M_I, x0.v_M, x0.q_M_I, x1, &J);
      VILMA_CHECK_MATRIX_NEAR(DenseF(J, x0), DenseF(J_plain, x0), 1e-12);
    }
    SECTION("anchor = the state before an update: F N(anchor) = N(x')") {
      // The update moved position, velocity and attitude (tilt and yaw) away from the anchor.
      FilterState anchor = x0;
      anchor.p_M_I += Eigen::Vector3d(0.02, 0.01, -0.01);
      anchor.v_M += Eigen::Vector3d(0.03, -0.02, 0.01);
      anchor.q_M_I = anchor.q_M_I * ExpSO3(Eigen::Vector3d(0.01, -0.02, 0.015));
      ConstrainYawNullspace(anchor.p_M_I, anchor.v_M, anchor.q_M_I, x1, &J);
      const Eigen::MatrixXd F = DenseF(J, x0), F_plain = DenseF(J_plain, x0);
      Eigen::VectorXd FN = F * YawNullVector(anchor);
      Eigen::VectorXd expected = YawNullVector(x1);
      FN.segment<3>(FeatureIndex(1)).setZero();
      VILMA_CHECK_MATRIX_NEAR(FN, expected, 1e-12);
      // Without the constraint the feature rows see the turn (the spurious information).
      CHECK((F_plain * YawNullVector(anchor)).segment<3>(FeatureIndex(0)).norm() > 1e-6);
      // Only the attitude columns change.
      Eigen::MatrixXd D = F - F_plain;
      D.middleCols<3>(kIdxQ).setZero();
      CHECK(D.norm() == 0.0);
    }
  }
}

TEST_CASE("a static point stays consistent with the propagated camera pose") {
  // Propagate 200 small steps with constant body rates and compare the feature with the
  // point re-projected from the propagated pose (the Euler steps converge to the truth).
  FilterState x;
  x.v_M = Eigen::Vector3d(0.5, -0.2, 0.1);
  x.q_M_I = ExpSO3(Eigen::Vector3d(0.1, -0.2, 0.3));
  x.q_I_C = ExpSO3(Eigen::Vector3d(-1.5, 0.0, -1.5));
  x.p_I_C = Eigen::Vector3d(0.05, -0.02, 0.01);
  x.features.resize(1);
  x.features[0].active = true;
  x.features[0].mu_C = Eigen::Vector3d(0.1, -0.2, 1.0).normalized();
  x.features[0].rho = 0.25;
  const Transformation T_I_C(x.q_I_C, x.p_I_C);
  const Transformation T_M_C0 = Transformation(x.q_M_I, x.p_M_I) * T_I_C;
  const Eigen::Vector3d p_M = T_M_C0 * (x.features[0].mu_C / x.features[0].rho);
  const Eigen::Vector3d omega_m(0.2, 0.1, -0.3);
  // Accelerometer reading that keeps the world velocity constant: a_I = R^T (0 - g_M).
  for (int i = 0; i < 2000; ++i) {
    const Eigen::Vector3d a_m = x.q_M_I.conjugate() * Eigen::Vector3d(0, 0, 9.81);
    PropagateMean(omega_m, a_m, 0.0005, 9.81, &x, nullptr);
  }
  const Transformation T_M_C = Transformation(x.q_M_I, x.p_M_I) * T_I_C;
  const Eigen::Vector3d p_C = T_M_C.inverse() * p_M;
  CHECK((x.features[0].mu_C - p_C.normalized()).norm() < 2e-3);
  CHECK(std::abs(x.features[0].rho - 1.0 / p_C.norm()) < 2e-3);
}

}  // namespace
}  // namespace vilma::estimator
