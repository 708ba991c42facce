// Lie-group laws of geometry.h (SO(3) / SE(3) in the T_A_B notation), checked on random
// elements from a fixed seed, including tiny and near-pi rotation angles.
#include "vilma/core/geometry.h"

#include <Eigen/Geometry>
#include <catch2/catch.hpp>
#include <cmath>
#include <random>
#include <unsupported/Eigen/MatrixFunctions>
#include <vector>

#include "core/test_utils.h"
#include "test_random.h"

namespace vilma {
namespace {

constexpr double kPi = M_PI;

// Random unit vector times a given angle [rad].
Eigen::Vector3d RandomRotationVector(std::mt19937* rng, double angle) {
  std::normal_distribution<double> normal(0.0, 1.0);
  const Eigen::Vector3d axis = vilma::testing::DrawVector3([&] { return normal(*rng); });
  return angle * axis.normalized();
}

// Angles that stress the special cases of Exp/Log/Jacobians: zero, below and above the Taylor
// thresholds, ordinary, and up to just below pi.
std::vector<double> TestAngles() {
  return {0.0, 1e-12, 1e-9, 1e-7, 1e-6, 3e-6,       1e-5,       2e-5,      1e-3,
          0.1, 0.5,   1.0,  2.0,  3.0,  kPi - 1e-3, kPi - 1e-6, kPi - 1e-9};
}

struct RandomTwists {
  std::vector<Vector6d> xis;
  RandomTwists() {
    std::mt19937 rng(42);
    std::uniform_real_distribution<double> uniform(-3.0, 3.0);
    for (double angle : TestAngles()) {
      for (int i = 0; i < 4; ++i) {
        Vector6d xi;
        xi << uniform(rng), uniform(rng), uniform(rng), RandomRotationVector(&rng, angle);
        xis.push_back(xi);
      }
    }
  }
};

Transformation RandomTransformation(std::mt19937* rng) {
  std::uniform_real_distribution<double> uniform(-1.0, 1.0);
  std::uniform_real_distribution<double> angle(0.0, kPi);
  // The translation first, then the angle, then the axis (tests/test_random.h).
  const Eigen::Vector3d p = vilma::testing::DrawVector3([&] { return uniform(*rng); }) * 5.0;
  const double a = angle(*rng);
  return Transformation(ExpSO3(RandomRotationVector(rng, a)), p);
}

// Twist matrix [Skew(phi) rho; 0 0] of xi = [rho; phi]; its matrix exponential is the
// independent reference for Transformation::Exp.
Eigen::Matrix4d Hat(const Vector6d& xi) {
  Eigen::Matrix4d X = Eigen::Matrix4d::Zero();
  X.topLeftCorner<3, 3>() = Skew(xi.tail<3>());
  X.topRightCorner<3, 1>() = xi.head<3>();
  return X;
}

bool TransformationsNear(const Transformation& a, const Transformation& b, double tol) {
  return test::MatricesNear(a.matrix(), b.matrix(), tol);
}

TEST_CASE("Skew is the cross-product matrix", "[geometry]") {
  const Eigen::Vector3d a(0.3, -1.2, 2.5), b(-0.7, 0.4, 1.1);
  VILMA_CHECK_MATRIX_NEAR(Skew(a) * b, a.cross(b), 1e-15);
  VILMA_CHECK_MATRIX_NEAR(Skew(a).transpose(), -Skew(a), 0.0);
}

TEST_CASE("ExpSO3 matches Rodrigues (Eigen::AngleAxis) and LogSO3 inverts it", "[geometry]") {
  std::mt19937 rng(1);
  for (double angle : TestAngles()) {
    for (int i = 0; i < 5; ++i) {
      const Eigen::Vector3d phi = RandomRotationVector(&rng, angle);
      INFO("angle " << angle << " phi " << phi.transpose());
      const Eigen::Quaterniond q = ExpSO3(phi);
      CHECK(std::abs(q.norm() - 1.0) < 1e-15);
      const Eigen::Matrix3d R_ref = angle > 0.0
                                        ? Eigen::AngleAxisd(angle, phi / angle).toRotationMatrix()
                                        : Eigen::Matrix3d::Identity();
      VILMA_CHECK_MATRIX_NEAR(q.toRotationMatrix(), R_ref, 1e-14);
      // Log(Exp(phi)) == phi to relative precision at every angle, tiny ones included (the
      // rotation vector is ill-conditioned only at exactly pi, not below it).
      CHECK((LogSO3(q) - phi).norm() <= 1e-14 * angle);
      // Log(-q) == Log(q): both quaternion signs are the same rotation.
      Eigen::Quaterniond q_neg = q;
      q_neg.coeffs() = -q.coeffs();
      CHECK((LogSO3(q_neg) - phi).norm() <= 1e-14 * angle);
    }
  }
}

TEST_CASE("LogSO3 angle lies in [0, pi] and wraps rotations beyond pi", "[geometry]") {
  const Eigen::Vector3d axis = Eigen::Vector3d(1.0, 2.0, -0.5).normalized();
  // A rotation by 1.5 pi about axis is a rotation by 0.5 pi about -axis.
  const Eigen::Vector3d phi = LogSO3(Eigen::Quaterniond(Eigen::AngleAxisd(1.5 * kPi, axis)));
  VILMA_CHECK_MATRIX_NEAR(phi, -0.5 * kPi * axis, 1e-14);
  // Exactly pi: either sign is right; the angle must be pi.
  const Eigen::Vector3d phi_pi = LogSO3(Eigen::Quaterniond(Eigen::AngleAxisd(kPi, axis)));
  CHECK(std::abs(phi_pi.norm() - kPi) < 1e-14);
  CHECK(std::abs(std::abs(phi_pi.normalized().dot(axis)) - 1.0) < 1e-14);
}

TEST_CASE("SE(3) Exp matches the matrix exponential and Log inverts it", "[geometry]") {
  const RandomTwists twists;
  for (const Vector6d& xi : twists.xis) {
    INFO("xi " << xi.transpose());
    const Transformation T = Transformation::Exp(xi);
    const Eigen::Matrix4d T_ref = Hat(xi).exp();
    VILMA_CHECK_MATRIX_NEAR(T.matrix(), T_ref, 1e-12);
    // Log(Exp(xi)) == xi, near pi and near zero too (this caught cancellation in the Jacobian
    // coefficients: 1e-9 errors at pi - 1e-9, 1e-11 at 2e-5 rad).
    VILMA_CHECK_MATRIX_NEAR(T.Log(), xi, 1e-12);
    // Exp(Log(T)) == T holds to full precision everywhere.
    CHECK(TransformationsNear(Transformation::Exp(T.Log()), T, 1e-13));
  }
}

TEST_CASE("Exp(Log(T)) == T for random transformations", "[geometry]") {
  std::mt19937 rng(7);
  for (int i = 0; i < 100; ++i) {
    const Transformation T = RandomTransformation(&rng);
    CHECK(TransformationsNear(Transformation::Exp(T.Log()), T, 1e-13));
  }
}

TEST_CASE("Transformation inverse, composition and matrix form agree", "[geometry]") {
  std::mt19937 rng(3);
  for (int i = 0; i < 50; ++i) {
    const Transformation T_A_B = RandomTransformation(&rng);
    const Transformation T_B_C = RandomTransformation(&rng);
    const Transformation T_C_D = RandomTransformation(&rng);
    const Eigen::Vector3d p_C(0.3 * i, -1.0, 2.0);

    // Inverse.
    CHECK(TransformationsNear(T_A_B * T_A_B.inverse(), Transformation(), 1e-14));
    CHECK(TransformationsNear(T_A_B.inverse() * T_A_B, Transformation(), 1e-14));
    VILMA_CHECK_MATRIX_NEAR(T_A_B.inverse().matrix(), T_A_B.matrix().inverse(), 1e-13);
    // Composition matches matrix products and point mapping.
    VILMA_CHECK_MATRIX_NEAR((T_A_B * T_B_C).matrix(), T_A_B.matrix() * T_B_C.matrix(), 1e-13);
    VILMA_CHECK_MATRIX_NEAR((T_A_B * T_B_C) * p_C, T_A_B * (T_B_C * p_C), 1e-13);
    // Associativity.
    CHECK(TransformationsNear((T_A_B * T_B_C) * T_C_D, T_A_B * (T_B_C * T_C_D), 1e-13));
    // Round trips through the matrix constructors.
    CHECK(TransformationsNear(Transformation(T_A_B.matrix()), T_A_B, 1e-14));
    CHECK(TransformationsNear(Transformation(T_A_B.rotationMatrix(), T_A_B.translation()), T_A_B,
                              1e-14));
  }
}

TEST_CASE("Adjoint: T Exp(xi) T^-1 == Exp(Ad_T xi)", "[geometry]") {
  std::mt19937 rng(11);
  const RandomTwists twists;
  for (const Vector6d& xi : twists.xis) {
    const Transformation T = RandomTransformation(&rng);
    INFO("xi " << xi.transpose());
    CHECK(TransformationsNear(T * Transformation::Exp(xi) * T.inverse(),
                              Transformation::Exp(T.Adjoint() * xi), 1e-12));
  }
  // Adjoint of a product is the product of adjoints.
  const Transformation T1 = RandomTransformation(&rng), T2 = RandomTransformation(&rng);
  VILMA_CHECK_MATRIX_NEAR((T1 * T2).Adjoint(), T1.Adjoint() * T2.Adjoint(), 1e-13);
}

TEST_CASE("Right and left Jacobians of SO(3) match numeric differentiation", "[geometry]") {
  std::mt19937 rng(5);
  for (double angle : TestAngles()) {
    // Central differences with h = 1e-5 straddle pi for angles within h of it.
    if (angle > kPi - 1e-4) continue;
    const Eigen::Vector3d phi = RandomRotationVector(&rng, angle);
    INFO("phi " << phi.transpose());
    // Exp(phi + d) ~ Exp(phi) Exp(Jr(phi) d).
    const Eigen::Matrix3d Jr_numeric =
        test::NumericJacobianToSO3<3>([](const Eigen::Vector3d& x) { return ExpSO3(x); }, phi);
    VILMA_CHECK_MATRIX_NEAR(RightJacobianSO3(phi), Jr_numeric, 1e-8);
    // Exp(phi + d) ~ Exp(Jl(phi) d) Exp(phi).
    const Eigen::Quaterniond q0 = ExpSO3(phi);
    const Eigen::Matrix3d Jl_numeric = test::NumericJacobian<3, 3>(
        [&](const Eigen::Vector3d& x) -> Eigen::Vector3d {
          return LogSO3(ExpSO3(x) * q0.conjugate());
        },
        phi);
    VILMA_CHECK_MATRIX_NEAR(LeftJacobianSO3(phi), Jl_numeric, 1e-8);
    // d Log(q Exp(d)) / d d = Jr^-1(Log q).
    const Eigen::Matrix3d Jr_inv_numeric =
        test::NumericJacobianSO3<3>([](const Eigen::Quaterniond& q) { return LogSO3(q); }, q0);
    VILMA_CHECK_MATRIX_NEAR(RightJacobianInverseSO3(phi), Jr_inv_numeric, 1e-8);
  }
}

TEST_CASE("Jr(phi) Jr^-1(phi) == I", "[geometry]") {
  std::mt19937 rng(9);
  for (double angle : TestAngles()) {
    for (int i = 0; i < 3; ++i) {
      const Eigen::Vector3d phi = RandomRotationVector(&rng, angle);
      INFO("phi " << phi.transpose());
      VILMA_CHECK_MATRIX_NEAR(RightJacobianSO3(phi) * RightJacobianInverseSO3(phi),
                              Eigen::Matrix3d::Identity(), 1e-13);
    }
  }
}

TEST_CASE("Interpolate hits the endpoints and the geodesic midpoint", "[geometry]") {
  std::mt19937 rng(13);
  for (int i = 0; i < 20; ++i) {
    const Transformation T_0 = RandomTransformation(&rng);
    const Transformation T_1 = RandomTransformation(&rng);
    CHECK(TransformationsNear(Interpolate(T_0, T_1, 0.0), T_0, 1e-14));
    CHECK(TransformationsNear(Interpolate(T_0, T_1, 1.0), T_1, 1e-13));
    const Transformation T_mid = Interpolate(T_0, T_1, 0.5);
    // Rotation: q_0 Exp(Log(q_0^-1 q_1) / 2); translation: the average.
    const Eigen::Quaterniond q_mid =
        T_0.rotation() * ExpSO3(0.5 * LogSO3(T_0.rotation().conjugate() * T_1.rotation()));
    CHECK(AngleBetween(T_mid.rotation(), q_mid) < 1e-12);
    VILMA_CHECK_MATRIX_NEAR(T_mid.translation(), 0.5 * (T_0.translation() + T_1.translation()),
                            1e-14);
    // Equal angular distance to both ends.
    CHECK(std::abs(AngleBetween(T_0.rotation(), T_mid.rotation()) -
                   AngleBetween(T_mid.rotation(), T_1.rotation())) < 1e-12);
  }
  // Shortest path even when the quaternions' signs disagree.
  const Eigen::Quaterniond q_0 = ExpSO3(Eigen::Vector3d(0.0, 0.0, 0.2));
  Eigen::Quaterniond q_1 = ExpSO3(Eigen::Vector3d(0.0, 0.0, 0.6));
  q_1.coeffs() = -q_1.coeffs();
  const Transformation T_mid = Interpolate(Transformation(q_0, Eigen::Vector3d::Zero()),
                                           Transformation(q_1, Eigen::Vector3d::Zero()), 0.5);
  VILMA_CHECK_MATRIX_NEAR(LogSO3(T_mid.rotation()), Eigen::Vector3d(0.0, 0.0, 0.4), 1e-14);
}

TEST_CASE("IsRotationMatrix accepts rotations and rejects other matrices", "[geometry]") {
  const Eigen::Matrix3d R = ExpSO3(Eigen::Vector3d(0.3, -0.2, 1.0)).toRotationMatrix();
  CHECK(IsRotationMatrix(R));
  CHECK(IsRotationMatrix(Eigen::Matrix3d::Identity()));
  CHECK_FALSE(IsRotationMatrix(1.01 * R));  // scaled
  Eigen::Matrix3d shear = Eigen::Matrix3d::Identity();
  shear(0, 1) = 0.05;
  CHECK_FALSE(IsRotationMatrix(R * shear));  // sheared
  Eigen::Matrix3d reflection = R;
  reflection.col(2) = -reflection.col(2);
  CHECK_FALSE(IsRotationMatrix(reflection));  // orthonormal but det = -1
  Eigen::Matrix3d nan = R;
  nan(1, 1) = std::nan("");
  CHECK_FALSE(IsRotationMatrix(nan));
  // Tolerance: a 1e-8 perturbation passes at the default 1e-6 and fails at 1e-10.
  Eigen::Matrix3d noisy = R;
  noisy(0, 0) += 1e-8;
  CHECK(IsRotationMatrix(noisy));
  CHECK_FALSE(IsRotationMatrix(noisy, 1e-10));
}

TEST_CASE("AngleBetween returns the relative rotation angle in [0, pi]", "[geometry]") {
  const Eigen::Vector3d axis = Eigen::Vector3d(-1.0, 0.5, 2.0).normalized();
  const Eigen::Quaterniond q_a = ExpSO3(Eigen::Vector3d(0.1, 0.2, -0.3));
  for (double angle : {0.0, 1e-9, 0.25, 1.0, 3.0, kPi - 1e-6}) {
    const Eigen::Quaterniond q_b = q_a * ExpSO3(angle * axis);
    CHECK(AngleBetween(q_a, q_b) == Approx(angle).margin(1e-12));
    CHECK(AngleBetween(q_b, q_a) == Approx(angle).margin(1e-12));
    Eigen::Quaterniond q_b_neg = q_b;
    q_b_neg.coeffs() = -q_b.coeffs();
    CHECK(AngleBetween(q_a, q_b_neg) == Approx(angle).margin(1e-12));
  }
  // 1.5 pi about an axis is 0.5 pi the other way.
  CHECK(AngleBetween(q_a, q_a * Eigen::Quaterniond(Eigen::AngleAxisd(1.5 * kPi, axis))) ==
        Approx(0.5 * kPi).margin(1e-12));
}

}  // namespace
}  // namespace vilma
