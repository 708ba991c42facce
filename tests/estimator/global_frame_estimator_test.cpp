#include "vilma/estimator/global_frame_estimator.h"

#include <Eigen/Geometry>
#include <catch2/catch.hpp>
#include <cmath>
#include <random>

namespace vilma::estimator {
namespace {

constexpr double kDeg = M_PI / 180.0;

Transformation YawPose(double yaw, const Eigen::Vector3d& p) {
  return Transformation(Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ())), p);
}

Matrix6d Cov(double sigma_p, double sigma_r) {
  Matrix6d c = Matrix6d::Zero();
  c.diagonal() << Eigen::Vector3d::Constant(sigma_p * sigma_p), Eigen::Vector3d::Constant(sigma_r * sigma_r);
  return c;
}

TEST_CASE("T_G_M: fuses consistent results, initializes after min_consistent_results",
          "[estimator][localization]") {
  GlobalFrameOptions o;
  GlobalFrameEstimator e(o);
  const Transformation T_G_M = YawPose(0.7, {1.0, -2.0, 0.3});
  std::mt19937 rng(3);
  std::normal_distribution<double> n(0.0, 1.0);
  for (int k = 0; k < 20; ++k) {
    // A tilted IMU pose in M; the result is T_G_I = T_G_M T_M_I with 2 cm / 0.2 deg noise.
    const Transformation T_M_I(
        Eigen::Quaterniond(Eigen::AngleAxisd(0.1 * k, Eigen::Vector3d(0.2, 0.1, 1.0).normalized())),
        Eigen::Vector3d(0.3 * k, 0.1 * k, 1.0));
    Vector6d xi;
    xi << 0.02 * n(rng), 0.02 * n(rng), 0.02 * n(rng), 0.2 * kDeg * n(rng), 0.2 * kDeg * n(rng),
        0.2 * kDeg * n(rng);
    const Transformation T_G_I = T_G_M * T_M_I * Transformation::Exp(xi);
    CHECK(e.Update(T_G_I, Cov(0.02, 0.2 * kDeg), T_M_I) == GlobalFrameUpdate::kAccepted);
    CHECK(e.initialized() == (k + 1 >= o.min_consistent_results));
  }
  const Transformation est = e.T_G_M();
  CHECK((est.translation() - T_G_M.translation()).norm() < 0.03);
  CHECK(AngleBetween(est.rotation(), T_G_M.rotation()) < 0.3 * kDeg);
  CHECK(e.covariance()(0, 0) > 0.0);
}

TEST_CASE("T_G_M: gravity-misaligned and jumping results are rejected, a lasting jump re-initializes",
          "[estimator][localization]") {
  GlobalFrameOptions o;
  GlobalFrameEstimator e(o);
  const Transformation T_M_I = YawPose(0.2, {0.5, 0.0, 1.0});
  const Transformation T_G_M = YawPose(-1.0, {3.0, 1.0, 0.0});
  const Matrix6d c = Cov(0.02, 0.3 * kDeg);
  // A roll of 10 deg: not a gravity-aligned T_G_M.
  const Transformation tilted(
      Eigen::Quaterniond(Eigen::AngleAxisd(10 * kDeg, Eigen::Vector3d::UnitX())), Eigen::Vector3d::Zero());
  CHECK(e.Update(tilted * T_G_M * T_M_I, c, T_M_I) == GlobalFrameUpdate::kRejectedGravity);
  CHECK_FALSE(e.initialized());
  // An outlier first, then two consistent results: the candidate restarts, then initializes.
  CHECK(e.Update(YawPose(0.0, {9, 9, 0}) * T_M_I, c, T_M_I) == GlobalFrameUpdate::kAccepted);
  CHECK(e.Update(T_G_M * T_M_I, c, T_M_I) == GlobalFrameUpdate::kAccepted);
  CHECK_FALSE(e.initialized());
  CHECK(e.Update(T_G_M * T_M_I, c, T_M_I) == GlobalFrameUpdate::kAccepted);
  REQUIRE(e.initialized());
  // Jumps of 1 m and of 10 deg are gated ...
  const Transformation far = YawPose(-1.0, {4.0, 1.0, 0.0});
  CHECK(e.Update(far * T_M_I, c, T_M_I) == GlobalFrameUpdate::kRejectedJump);
  CHECK(e.Update(YawPose(-1.0 + 10 * kDeg, {3.0, 1.0, 0.0}) * T_M_I, c, T_M_I) ==
        GlobalFrameUpdate::kRejectedJump);
  CHECK((e.T_G_M().translation() - T_G_M.translation()).norm() < 1e-6);
  // ... until max_consecutive_gated of them in a row: the estimate restarts from the newest.
  for (int k = 2; k < o.max_consecutive_gated - 1; ++k) {
    CHECK(e.Update(far * T_M_I, c, T_M_I) == GlobalFrameUpdate::kRejectedJump);
  }
  CHECK(e.Update(far * T_M_I, c, T_M_I) == GlobalFrameUpdate::kReinitialized);
  CHECK_FALSE(e.initialized());
  CHECK((e.T_G_M().translation() - far.translation()).norm() < 1e-6);
  e.Reset();
  CHECK_FALSE(e.initialized());
}

TEST_CASE("T_G_M: the forgetting factor follows a drifting M", "[estimator][localization]") {
  GlobalFrameOptions o;
  GlobalFrameEstimator e(o);
  const Transformation T_M_I = YawPose(0.0, {0, 0, 1});
  const Matrix6d c = Cov(0.02, 0.3 * kDeg);
  // M drifts 5 cm per result along x; the estimate lags by a bounded amount.
  for (int k = 0; k < 40; ++k) {
    const Transformation T_G_M = YawPose(0.0, {0.05 * k, 0, 0});
    REQUIRE(e.Update(T_G_M * T_M_I, c, T_M_I) == GlobalFrameUpdate::kAccepted);
  }
  // Steady-state lag of the exponentially weighted average: 0.05 f / (1 - f) = 0.2 m at f = 0.8.
  CHECK(std::abs(e.T_G_M().translation().x() - 0.05 * 39) < 0.25);
}

}  // namespace
}  // namespace vilma::estimator
