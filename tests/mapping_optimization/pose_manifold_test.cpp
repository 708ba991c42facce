// GaugePoseManifold (pose_manifold.cpp): the held degrees of freedom do not move, the free ones
// do, and PlusJacobian / MinusJacobian match differences of Plus / Minus.
#include <catch2/catch.hpp>

#include <cmath>
#include <random>

#include "vilma/mapping/optimization/pose_manifold.h"

namespace vilma::mapping {
namespace {

constexpr double kDeg = M_PI / 180.0;

// The hall's first VIO pose (T_M_I of bench-loc's map, 2026-11-27): a camera-like IMU mount, its
// z axis 99° from up (swing β), where the body's own yaw ψ(R) and the heading in M part.
Eigen::Quaterniond CameraLikeMount() {
  return Eigen::Quaterniond(0.020922162, -0.758158108, -0.017978462, -0.651487008).normalized();
}

std::array<double, 7> Block(const Eigen::Vector3d& p, const Eigen::Quaterniond& q) {
  std::array<double, 7> x;
  PoseToBlock(Transformation(q, p), x.data());
  return x;
}

Eigen::Quaterniond Rotation(const std::array<double, 7>& x) {
  return Eigen::Quaterniond(Eigen::Map<const Eigen::Quaterniond>(x.data() + 3)).normalized();
}

// Angle between the up axis seen from the body before and after [rad].
double TiltChange(const Eigen::Quaterniond& a, const Eigen::Quaterniond& b) {
  const Eigen::Vector3d up_a = a.conjugate() * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d up_b = b.conjugate() * Eigen::Vector3d::UnitZ();
  return std::atan2(up_a.cross(up_b).norm(), up_a.dot(up_b));
}

// Central differences of δ -> PoseManifold's [δp, δθ] of Plus(x, δ) relative to x: the columns
// PlusJacobian's lift must hold.
Eigen::MatrixXd NumericBasis(const GaugePoseManifold& m, const std::array<double, 7>& x) {
  const int n = m.TangentSize();
  Eigen::MatrixXd J(6, n);
  const double eps = 1e-6;
  for (int k = 0; k < n; ++k) {
    Eigen::VectorXd d = Eigen::VectorXd::Zero(n);
    std::array<double, 7> plus, minus;
    d(k) = eps;
    REQUIRE(m.Plus(x.data(), d.data(), plus.data()));
    d(k) = -eps;
    REQUIRE(m.Plus(x.data(), d.data(), minus.data()));
    Eigen::Matrix<double, 6, 1> a, b;
    PoseManifold().Minus(plus.data(), x.data(), a.data());
    PoseManifold().Minus(minus.data(), x.data(), b.data());
    J.col(k) = (a - b) / (2.0 * eps);
  }
  return J;
}

TEST_CASE("GaugePoseManifold holds position and heading exactly while roll and pitch move") {
  const Eigen::Quaterniond q_held = CameraLikeMount();
  const Eigen::Vector3d p_held(1.0, -2.0, 0.5);
  const GaugePoseManifold gauge(true, q_held);
  REQUIRE(gauge.TangentSize() == 2);
  std::array<double, 7> x = Block(p_held, q_held);
  std::mt19937_64 rng(7);
  std::normal_distribution<double> n(0.0, 0.01);
  for (int step = 0; step < 200; ++step) {
    const double delta[2] = {n(rng), n(rng)};
    std::array<double, 7> next;
    REQUIRE(gauge.Plus(x.data(), delta, next.data()));
    x = next;
  }
  const Eigen::Quaterniond q = Rotation(x);
  CHECK((Eigen::Map<const Eigen::Vector3d>(x.data()) - p_held).norm() == 0.0);
  // The held DoF: the heading of the body in the frame, ψ(R R_heldᵀ).
  CHECK(std::abs(YawAboutZ(q * q_held.conjugate())) < 1e-12);
  // The free DoF moved: the tilt (the direction of up in the body).
  const double tilt = TiltChange(q_held, q);
  CHECK(tilt > 2.0 * kDeg);
  // The body's own yaw ψ(R) is not what is held: on this mount it moves with the tilt (holding
  // it turned the whole map with every tilt correction of its first vertex).
  const double body_yaw_change = std::remainder(YawAboutZ(q) - YawAboutZ(q_held), 2.0 * M_PI);
  INFO("tilt " << tilt / kDeg << " deg, body yaw change " << body_yaw_change / kDeg << " deg");
  CHECK(std::abs(body_yaw_change) > 0.5 * tilt);
}

TEST_CASE("GaugePoseManifold's Jacobians match differences of Plus and Minus") {
  const Eigen::Quaterniond q_held = CameraLikeMount();
  const Eigen::Vector3d p(0.3, 0.1, -0.2);
  const Eigen::Vector3d direction = Eigen::Vector3d(1.0, 2.0, -0.5).normalized();
  const GaugePoseManifold held(true, q_held);
  const GaugePoseManifold scale(direction);
  // At the held rotation and 5° of tilt away from it (there the heading correction enters the
  // first-order Plus: the basis's e_z part).
  const std::array<double, 2> tilted_delta = {4.0 * kDeg, -3.0 * kDeg};
  std::array<double, 7> tilted;
  const std::array<double, 7> at_held = Block(p, q_held);
  REQUIRE(held.Plus(at_held.data(), tilted_delta.data(), tilted.data()));
  struct Case {
    const char* name;
    const GaugePoseManifold* manifold;
    std::array<double, 7> x;
  };
  for (const Case& c : {Case{"heading held, at the reference", &held, at_held},
                        Case{"heading held, 5 deg tilted", &held, tilted},
                        Case{"scale gauge", &scale, Block(p, CameraLikeMount())}}) {
    INFO(c.name);
    const GaugePoseManifold& m = *c.manifold;
    const int n = m.TangentSize();
    Eigen::Matrix<double, 7, Eigen::Dynamic, Eigen::RowMajor> plus_jacobian(7, n);
    REQUIRE(m.PlusJacobian(c.x.data(), plus_jacobian.data()));
    CHECK(plus_jacobian.row(6).isZero());
    const Eigen::MatrixXd numeric = NumericBasis(m, c.x);
    INFO("analytic\n" << plus_jacobian.topRows<6>() << "\nnumeric\n" << numeric);
    CHECK((plus_jacobian.topRows<6>() - numeric).cwiseAbs().maxCoeff() < 1e-8);
    // Minus undoes Plus (to second order), and its Jacobian inverts the lift.
    Eigen::Matrix<double, Eigen::Dynamic, 7, Eigen::RowMajor> minus_jacobian(n, 7);
    REQUIRE(m.MinusJacobian(c.x.data(), minus_jacobian.data()));
    CHECK((minus_jacobian * plus_jacobian - Eigen::MatrixXd::Identity(n, n)).norm() < 1e-12);
    Eigen::VectorXd delta = Eigen::VectorXd::LinSpaced(n, 1e-4, -2e-4);
    std::array<double, 7> y;
    REQUIRE(m.Plus(c.x.data(), delta.data(), y.data()));
    Eigen::VectorXd back(n);
    REQUIRE(m.Minus(y.data(), c.x.data(), back.data()));
    CHECK((back - delta).norm() < 1e-7);
  }
  // The scale gauge moves the position only across its direction; the rotation is free.
  REQUIRE(scale.TangentSize() == 5);
  const double delta[5] = {0.3, -0.2, 0.1, 0.2, -0.1};
  const std::array<double, 7> x = Block(p, q_held);
  std::array<double, 7> y;
  REQUIRE(scale.Plus(x.data(), delta, y.data()));
  CHECK(std::abs((Eigen::Map<const Eigen::Vector3d>(y.data()) - p).dot(direction)) < 1e-15);
  CHECK(Rotation(y).angularDistance(q_held) > 0.2);
}

}  // namespace
}  // namespace vilma::mapping
