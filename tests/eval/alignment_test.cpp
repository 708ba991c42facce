#include "vilma/eval/alignment.h"

#include <catch2/catch.hpp>

#include <cmath>
#include <random>
#include <string>

#include "eval/test_trajectories.h"
#include "test_random.h"

namespace vilma {
namespace {

using namespace eval_test;  // NOLINT: the shared test trajectories

TEST_CASE("GravityYaw is the yaw closest to a rotation, roll/pitch does not leak", "[eval]") {
  // Pure swings (rotations about horizontal axes) have no yaw.
  for (double axis_deg : {0.0, 30.0, 90.0, 135.0, -60.0}) {
    const Eigen::Vector3d u(std::cos(axis_deg * kDeg), std::sin(axis_deg * kDeg), 0.0);
    for (double beta_deg : {-40.0, 5.0, 89.0, 170.0}) {
      const Eigen::Quaterniond S(Eigen::AngleAxisd(beta_deg * kDeg, u));
      INFO("axis " << axis_deg << " deg, swing " << beta_deg << " deg");
      CHECK(std::abs(GravityYaw(S)) < 1e-12);
      for (double yaw_deg : {-170.0, -45.0, 0.0, 30.0, 120.0}) {
        CHECK(GravityYaw(Rz(yaw_deg * kDeg) * S) == Approx(yaw_deg * kDeg).margin(1e-12));
        CHECK(GravityYaw(S * Rz(yaw_deg * kDeg)) == Approx(yaw_deg * kDeg).margin(1e-12));
      }
    }
  }
  // For any rotation it minimizes the angle of Rz(theta)^T R: no theta on a 0.01 deg grid is
  // better.
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  for (int trial = 0; trial < 20; ++trial) {
    // z, y, x: the order GCC drew them in (tests/test_random.h).
    const double z = 3.0 * u(rng);
    const double y = u(rng);
    const double x = u(rng);
    const Eigen::Quaterniond R = ExpSO3(Eigen::Vector3d(x, y, z));
    const double yaw = GravityYaw(R);
    const double best = AngleBetween(Rz(yaw), R);
    double grid_best = 10.0;
    for (int i = -18000; i < 18000; ++i) {
      grid_best = std::min(grid_best, AngleBetween(Rz(i * 0.01 * kDeg), R));
    }
    INFO("trial " << trial);
    CHECK(best <= grid_best + 1e-12);
    CHECK(best > grid_best - 0.01 * kDeg);  // the grid gets close to it
  }
}

}  // namespace
}  // namespace vilma
