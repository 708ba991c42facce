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
  o.drift_position_m_per_sqrt_s = 0.0;  // both drifts 0: the forgetting factor (the random walk
  o.drift_yaw_deg_per_sqrt_s = 0.0;     // is the default since 2026-11-28)
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

// Random-walk fusion (drift_* > 0): a Kalman filter with P += Q dt between results.
GlobalFrameOptions RandomWalk(double q_p, double q_yaw_deg) {
  GlobalFrameOptions o;
  o.drift_position_m_per_sqrt_s = q_p;
  o.drift_yaw_deg_per_sqrt_s = q_yaw_deg;
  o.min_sigma_position_m = 1e-4;
  o.min_sigma_yaw_deg = 1e-3;
  return o;
}

constexpr int64_t kSec = 1000000000;

TEST_CASE("T_G_M random walk: no drift is the plain average of equal-weight results",
          "[estimator][localization]") {
  GlobalFrameEstimator e(RandomWalk(1e-9, 1e-9));
  const Transformation T_M_I = YawPose(0.0, {0, 0, 0});
  const Matrix6d c = Cov(0.02, 0.3 * kDeg);
  const double xs[] = {0.01, -0.02, 0.03, 0.0, 0.015};
  double mean = 0.0;
  for (int k = 0; k < 5; ++k) {
    REQUIRE(e.Update(YawPose(0.001 * k, {xs[k], 0, 0}) * T_M_I, c, T_M_I, k * kSec) ==
            GlobalFrameUpdate::kAccepted);
    mean += xs[k] / 5.0;
  }
  Eigen::Vector4d z;
  Eigen::Matrix4d R;
  GlobalFrameEstimator::Measure(YawPose(0.0, {0, 0, 0}), c, T_M_I, &z, &R, RandomWalk(1e-9, 1e-9));
  CHECK(e.state()[0] == Approx(mean).margin(1e-9));
  CHECK(e.state()[3] == Approx(0.002).margin(1e-9));
  CHECK(e.covariance()(0, 0) == Approx(R(0, 0) / 5.0).epsilon(1e-6));
  CHECK(e.covariance()(3, 3) == Approx(R(3, 3) / 5.0).epsilon(1e-6));
}

TEST_CASE("T_G_M random walk: the prediction grows with the time between results",
          "[estimator][localization]") {
  const GlobalFrameOptions o = RandomWalk(0.01, 0.1);
  const Transformation T_M_I = YawPose(0.0, {0, 0, 0});
  const Matrix6d c = Cov(0.02, 0.3 * kDeg);
  Eigen::Vector4d z;
  Eigen::Matrix4d R;
  GlobalFrameEstimator::Measure(T_M_I, c, T_M_I, &z, &R, o);
  for (const double dt : {0.5, 4.0}) {
    GlobalFrameEstimator e(o);
    REQUIRE(e.Update(YawPose(0.0, {0, 0, 0}), c, T_M_I, 10 * kSec) == GlobalFrameUpdate::kAccepted);
    const int64_t t1 = 10 * kSec + static_cast<int64_t>(dt * 1e9);
    REQUIRE(e.Update(YawPose(0.02, {0.1, 0, 0}), c, T_M_I, t1) == GlobalFrameUpdate::kAccepted);
    // Scalar Kalman filter per axis: P- = R + q^2 dt, gain K = P- / (P- + R), P+ = (1 - K) P-.
    const double qy = 0.1 * kDeg;
    const double pp = R(0, 0) + 0.01 * 0.01 * dt, py = R(3, 3) + qy * qy * dt;
    const double kp = pp / (pp + R(0, 0)), ky = py / (py + R(3, 3));
    CHECK(e.state()[0] == Approx(kp * 0.1).epsilon(1e-9));
    CHECK(e.state()[3] == Approx(ky * 0.02).epsilon(1e-9));
    CHECK(e.covariance()(0, 0) == Approx((1 - kp) * pp).epsilon(1e-9));
    CHECK(e.covariance()(3, 3) == Approx((1 - ky) * py).epsilon(1e-9));
  }
}

// Static truth, results at 1 Hz with sigma s or at 4 Hz with sigma 2 s (the same information
// per second): the random walk converges to nearly the same covariance; the forgetting factor
// keeps 1 / (1 - f) updates of information, i.e. four times less in the second case.
TEST_CASE("T_G_M random walk: the estimate does not depend on the update rate",
          "[estimator][localization]") {
  const Transformation T_M_I = YawPose(0.0, {0, 0, 0});
  auto run = [&](const GlobalFrameOptions& o, double hz, double sigma) {
    GlobalFrameEstimator e(o);
    std::mt19937 rng(5);
    std::normal_distribution<double> n(0.0, 1.0);
    for (int k = 0; k < static_cast<int>(120 * hz); ++k) {
      const Transformation T_G_I = YawPose(0.0, {sigma * n(rng), sigma * n(rng), 0});
      e.Update(T_G_I, Cov(sigma, 0.2 * kDeg), T_M_I, static_cast<int64_t>(k / hz * 1e9));
    }
    return e.covariance()(0, 0);
  };
  const GlobalFrameOptions rw = RandomWalk(0.005, 0.05);
  const double p1 = run(rw, 1.0, 0.02), p4 = run(rw, 4.0, 0.04);
  CHECK(p4 / p1 == Approx(1.0).margin(0.1));
  GlobalFrameOptions forgetting = rw;
  forgetting.drift_position_m_per_sqrt_s = forgetting.drift_yaw_deg_per_sqrt_s = 0.0;
  const double f1 = run(forgetting, 1.0, 0.02), f4 = run(forgetting, 4.0, 0.04);
  CHECK(f4 / f1 == Approx(4.0).epsilon(0.01));
}

// Adaptive measurement noise (noise_scale_window > 0): R scaled by lambda learned from the
// innovations by covariance matching.
GlobalFrameOptions Adaptive(int window, double prior, double prior_weight) {
  GlobalFrameOptions o = RandomWalk(1e-4, 1e-3);
  o.noise_scale_window = window;
  o.noise_scale_prior = prior;
  o.noise_scale_prior_weight = prior_weight;
  return o;
}

// Static truth, results at 2 Hz whose true scatter is k times the sigma their covariance
// states (white); returns the noise scales after n results.
Eigen::Vector2d ScaleAfter(const GlobalFrameOptions& o, double k, int n, unsigned seed) {
  GlobalFrameEstimator e(o);
  const Transformation T_M_I = YawPose(0.0, {0, 0, 0});
  const double sp = 0.01, sy = 0.2 * kDeg;
  std::mt19937 rng(seed);
  std::normal_distribution<double> g(0.0, 1.0);
  for (int i = 0; i < n; ++i) {
    const Transformation T_G_I =
        YawPose(k * sy * g(rng), {k * sp * g(rng), k * sp * g(rng), k * sp * g(rng)});
    REQUIRE(e.Update(T_G_I, Cov(sp, sy), T_M_I, static_cast<int64_t>(i) * kSec / 2) ==
            GlobalFrameUpdate::kAccepted);
  }
  return e.noise_scale();
}

TEST_CASE("T_G_M adaptive noise: the scale converges to the true noise of a white sequence",
          "[estimator][localization]") {
  // No prior, 200 innovations: lambda estimates k^2 (position: 600 squared innovations, relative
  // sigma sqrt(2 / 600) = 6 %; yaw: 200, 10 %); checked at 3 sigma over three seeds.
  for (const unsigned seed : {1u, 2u, 3u}) {
    const Eigen::Vector2d l3 = ScaleAfter(Adaptive(200, 1.0, 0.0), 3.0, 400, seed);
    CHECK(l3[0] == Approx(9.0).epsilon(0.18));
    CHECK(l3[1] == Approx(9.0).epsilon(0.30));
    const Eigen::Vector2d l2 = ScaleAfter(Adaptive(200, 1.0, 0.0), 2.0, 400, seed);
    CHECK(l2[0] == Approx(4.0).epsilon(0.18));
    CHECK(l2[1] == Approx(4.0).epsilon(0.30));
  }
}

TEST_CASE("T_G_M adaptive noise: large for a scattered sequence, 1 for a tight one",
          "[estimator][localization]") {
  // With the default prior (4, 5 results) and window (20): results better than their covariance
  // says pull lambda down to about 1 (its floor; the prior keeps 5 of the 25 weights) ...
  const GlobalFrameOptions o = Adaptive(20, 4.0, 5.0);
  const Eigen::Vector2d tight = ScaleAfter(o, 0.5, 60, 7);
  CHECK(tight[0] <= 1.1);
  CHECK(tight[1] <= 1.1);
  // ... results 5x more scattered push it up (the estimate then averages longer).
  const Eigen::Vector2d scattered = ScaleAfter(o, 5.0, 60, 7);
  CHECK(scattered[0] > 10.0);
  CHECK(scattered[1] > 10.0);
  // Before any innovation (the first result), the prior.
  GlobalFrameEstimator e(o);
  CHECK(e.noise_scale()[0] == Approx(4.0));
  // Off: scales 1.
  CHECK(GlobalFrameEstimator(RandomWalk(0.01, 0.1)).noise_scale() == Eigen::Vector2d::Ones());
}

TEST_CASE("T_G_M adaptive noise: a fixed scale of 1 is the plain random walk, the scale weights the results",
          "[estimator][localization]") {
  // A prior of 1 with an overwhelming weight keeps lambda at 1: the same numbers as without
  // adaptive noise (the old mode reachable and unchanged).
  const GlobalFrameOptions plain = RandomWalk(0.01, 0.1);
  GlobalFrameOptions fixed1 = plain;
  fixed1.noise_scale_window = 5;
  fixed1.noise_scale_prior = 1.0;
  fixed1.noise_scale_prior_weight = 1e12;
  GlobalFrameEstimator a(plain), b(fixed1);
  const Transformation T_M_I = YawPose(0.3, {1, 2, 0});
  std::mt19937 rng(11);
  std::normal_distribution<double> g(0.0, 1.0);
  for (int i = 0; i < 30; ++i) {
    const Transformation T_G_I = YawPose(0.5 + 0.01 * g(rng), {0.05 * g(rng), 0.05 * g(rng), 0}) * T_M_I;
    const int64_t t = static_cast<int64_t>(i) * kSec / 2;
    REQUIRE(a.Update(T_G_I, Cov(0.02, 0.3 * kDeg), T_M_I, t) ==
            b.Update(T_G_I, Cov(0.02, 0.3 * kDeg), T_M_I, t));
  }
  CHECK((a.state() - b.state()).norm() < 1e-10);
  CHECK((a.covariance() - b.covariance()).norm() <= 1e-9 * a.covariance().norm());
  // A scale lambda on R is the Kalman gain with lambda R: a first result at 0 and a second at
  // 0.1 m 0.5 s later give x = K 0.1, K = P- / (P- + lambda R), P- = lambda R + q^2 dt (lambda
  // held at the prior 9 by its weight).
  GlobalFrameOptions o = Adaptive(10, 9.0, 1e12);
  GlobalFrameEstimator c(o);
  const Transformation I = YawPose(0.0, {0, 0, 0});
  REQUIRE(c.Update(YawPose(0.0, {0, 0, 0}), Cov(0.02, 0.3 * kDeg), I, 0) == GlobalFrameUpdate::kAccepted);
  REQUIRE(c.Update(YawPose(0.0, {0.1, 0, 0}), Cov(0.02, 0.3 * kDeg), I, kSec / 2) ==
          GlobalFrameUpdate::kAccepted);
  Eigen::Vector4d z;
  Eigen::Matrix4d R;
  GlobalFrameEstimator::Measure(I, Cov(0.02, 0.3 * kDeg), I, &z, &R, o);
  const double pm = 9.0 * R(0, 0) + 1e-8 * 0.5;  // P- = lambda R (first result) + q^2 dt
  CHECK(c.state()[0] == Approx(pm / (pm + 9.0 * R(0, 0)) * 0.1).epsilon(1e-6));
}

TEST_CASE("T_G_M options: drift and floors validated", "[estimator][localization]") {
  GlobalFrameOptions o = RandomWalk(0.01, 0.1);
  CHECK(o.Validate().empty());
  o.drift_yaw_deg_per_sqrt_s = 0.0;
  CHECK(o.Validate().find("drift_yaw_deg_per_sqrt_s") == 0);
  o = RandomWalk(-0.01, 0.1);
  CHECK(o.Validate().find("drift_position_m_per_sqrt_s") == 0);
  o = RandomWalk(0.01, 0.1);
  o.min_sigma_position_m = 0.0;
  CHECK(o.Validate().find("min_sigma_position_m") == 0);
  o = RandomWalk(0.01, 0.1);
  o.min_sigma_yaw_deg = std::nan("");
  CHECK(o.Validate().find("min_sigma_yaw_deg") == 0);
  // Adaptive noise: only with the random walk; prior >= 1, weight >= 0, window >= 0.
  o = Adaptive(20, 4.0, 5.0);
  CHECK(o.Validate().empty());
  o.drift_position_m_per_sqrt_s = o.drift_yaw_deg_per_sqrt_s = 0.0;
  CHECK(o.Validate().find("noise_scale_window") == 0);
  o = Adaptive(-1, 4.0, 5.0);
  CHECK(o.Validate().find("noise_scale_window") == 0);
  o = Adaptive(20, 0.9, 5.0);
  CHECK(o.Validate().find("noise_scale_prior:") == 0);
  o = Adaptive(20, 4.0, -1.0);
  CHECK(o.Validate().find("noise_scale_prior_weight") == 0);
}

}  // namespace
}  // namespace vilma::estimator
