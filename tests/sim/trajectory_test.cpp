#include "vilma/sim/trajectory.h"

#include <catch2/catch.hpp>
#include <algorithm>
#include <cmath>
#include <stdexcept>

#include "vilma/core/geometry.h"

using Eigen::Vector3d;
using vilma::sim::Trajectory;
using vilma::sim::TrajectoryOptions;
using vilma::sim::TrajectoryReport;
using vilma::sim::TrajectoryState;

namespace {
Trajectory GenerateRoom(uint64_t seed, double seconds) {
  const vilma::sim::World world = vilma::sim::MakePresetWorld("room", 1);
  TrajectoryOptions o;
  o.duration_s = seconds;
  return vilma::sim::GenerateTrajectory(world, o, seed);
}
}  // namespace

TEST_CASE("trajectory derivatives match central differences", "[sim][trajectory]") {
  const Trajectory traj = GenerateRoom(5, 30.0);
  const double h = 1e-5;
  for (double t = 3.3; t < 29.0; t += 1.37) {
    INFO("t = " << t);
    const TrajectoryState s = traj.Evaluate(t);
    const TrajectoryState sp = traj.Evaluate(t + h), sm = traj.Evaluate(t - h);
    const Vector3d v_num = (sp.T_W_I.translation() - sm.T_W_I.translation()) / (2 * h);
    const Vector3d a_num = (sp.v_W - sm.v_W) / (2 * h);
    CHECK((v_num - s.v_W).norm() < 1e-7);
    CHECK((a_num - s.a_W).norm() < 1e-5);
    // omega_I from R_W_I(t)^T R_W_I(t + h) = Exp(omega_I h) (to first order, central form).
    const Vector3d omega_num =
        vilma::LogSO3(sm.T_W_I.rotation().conjugate() * sp.T_W_I.rotation()) / (2 * h);
    CHECK((omega_num - s.omega_I).norm() < 1e-6);
  }
}

TEST_CASE("trajectory starts static and is C2 at knots", "[sim][trajectory]") {
  const Trajectory traj = GenerateRoom(6, 20.0);
  for (double t = 0.0; t <= 3.0; t += 0.1) {
    const TrajectoryState s = traj.Evaluate(t);
    CHECK(s.v_W.norm() < 1e-12);
    CHECK(s.a_W.norm() < 1e-12);
    CHECK(s.omega_I.norm() < 1e-12);
  }
  const double dt = traj.knot_interval_s();
  for (int k = 5; k < 20; ++k) {
    const double t = k * dt;
    const TrajectoryState a = traj.Evaluate(t - 1e-9), b = traj.Evaluate(t + 1e-9);
    CHECK((a.a_W - b.a_W).norm() < 1e-6);
    CHECK((a.omega_I - b.omega_I).norm() < 1e-6);
  }
}

TEST_CASE("camera looks forward along body z with the image x to the right", "[sim][trajectory]") {
  // Level look frame facing +x: body z (camera optical axis) = +x, body x = up.
  const Trajectory traj(1.0, std::vector<Vector3d>(4, Vector3d::Zero()),
                        std::vector<Vector3d>(4, Vector3d::Zero()));
  const Eigen::Matrix3d R = traj.Evaluate(0.5).T_W_I.rotationMatrix();
  CHECK((R.col(2) - Vector3d::UnitX()).norm() < 1e-12);
  CHECK((R.col(0) - Vector3d::UnitZ()).norm() < 1e-12);
  CHECK((R.col(1) + Vector3d::UnitY()).norm() < 1e-12);
  CHECK(vilma::IsRotationMatrix(R));
  // Static trajectories reproduce their pose.
  const vilma::Transformation T(vilma::ExpSO3(Vector3d(0.1, -0.2, 0.3)) *
                                    Eigen::Quaterniond(Trajectory::R_L_I()),
                                Vector3d(1, 2, 3));
  const Trajectory still = vilma::sim::MakeStaticTrajectory(T, 5.0);
  const TrajectoryState s = still.Evaluate(2.5);
  CHECK(vilma::AngleBetween(s.T_W_I.rotation(), T.rotation()) < 1e-9);
  CHECK((s.T_W_I.translation() - T.translation()).norm() < 1e-12);
}

TEST_CASE("preset trajectories are collision-free, EuRoC-like and look at geometry", "[sim][trajectory]") {
  struct Case {
    std::string preset;
    double min_mean_speed, max_speed, max_rate;
  };
  for (const Case& c : {Case{"room", 0.3, 1.6, 1.2}, Case{"room-fast", 0.9, 3.2, 2.5},
                        Case{"hall", 0.5, 2.0, 1.4}, Case{"street", 0.9, 2.5, 1.2}}) {
    INFO(c.preset);
    const vilma::sim::World world = vilma::sim::MakePresetWorld(c.preset, 1);
    TrajectoryOptions o;
    o.duration_s = 60.0;
    TrajectoryReport r;
    vilma::sim::GenerateTrajectory(world, o, 11, &r);
    CHECK(r.collision_samples == 0);
    CHECK(r.mean_speed > c.min_mean_speed);
    CHECK(r.max_speed < c.max_speed);
    CHECK(r.max_angular_rate < c.max_rate);
    CHECK(r.min_view_depth > 0.5 * world.motion.min_view_depth);
    CHECK(std::isfinite(r.min_view_depth));
  }
}

TEST_CASE("trajectories are deterministic per seed and differ between seeds", "[sim][trajectory]") {
  const Trajectory a = GenerateRoom(21, 15.0), b = GenerateRoom(21, 15.0), c = GenerateRoom(22, 15.0);
  for (double t = 0.0; t < 15.0; t += 0.5) {
    CHECK(a.Evaluate(t).T_W_I.translation() == b.Evaluate(t).T_W_I.translation());
  }
  CHECK((a.Evaluate(0.0).T_W_I.translation() - c.Evaluate(0.0).T_W_I.translation()).norm() > 0.1);
}

namespace {
// Fraction of `query` samples (every 0.5 s after the static start) that some `reference` sample
// sees from nearby: within `max_distance_m` and with the camera axes (body z) within
// `max_angle_deg`.
double ViewCoverage(const Trajectory& reference, const Trajectory& query, double max_distance_m,
                    double max_angle_deg) {
  int covered = 0, total = 0;
  for (double t = 3.0; t <= query.duration_s(); t += 0.5, ++total) {
    const vilma::Transformation q = query.Evaluate(t).T_W_I;
    for (double s = 0.0; s <= reference.duration_s(); s += 0.1) {
      const vilma::Transformation r = reference.Evaluate(s).T_W_I;
      const double angle_deg = std::acos(std::clamp(
          (q.rotation() * Vector3d::UnitZ()).dot(r.rotation() * Vector3d::UnitZ()), -1.0, 1.0)) *
          180.0 / M_PI;
      if ((q.translation() - r.translation()).norm() < max_distance_m && angle_deg < max_angle_deg) {
        ++covered;
        break;
      }
    }
  }
  return static_cast<double>(covered) / std::max(1, total);
}
}  // namespace

TEST_CASE("revisiting sessions see what the reference session saw", "[sim][trajectory]") {
  // The hall is large: an independent 60 s path rarely comes back to session 0's views (this
  // is why the re-localization datasets revisit).
  const vilma::sim::World world = vilma::sim::MakePresetWorld("hall", 1);
  TrajectoryOptions o;
  o.duration_s = 120.0;
  const Trajectory reference = vilma::sim::GenerateTrajectory(world, o, 31);
  o.duration_s = 60.0;
  const Trajectory independent = vilma::sim::GenerateTrajectory(world, o, 32);
  vilma::sim::RevisitOptions revisit;
  TrajectoryReport report;
  const Trajectory again =
      vilma::sim::GenerateRevisitTrajectory(world, reference, o, revisit, 33, &report);
  CHECK(again.duration_s() >= 60.0);
  CHECK(report.collision_samples == 0);
  CHECK(report.max_speed < 2.5);
  CHECK(report.max_angular_rate < 1.6);
  CHECK(report.min_view_depth > 0.5 * world.motion.min_view_depth);
  const double covered = ViewCoverage(reference, again, 1.5, 30.0);
  const double covered_independent = ViewCoverage(reference, independent, 1.5, 30.0);
  INFO("coverage revisit " << covered << ", independent " << covered_independent);
  CHECK(covered >= 0.9);
  CHECK(covered_independent < 0.5);
  // Not a copy: the views are offset (the offsets' stationary std is 0.6 m and 0.25 rad).
  double mean_offset_m = 0.0;
  int n = 0;
  for (double t = 3.0; t <= 60.0; t += 0.5, ++n) {
    const Vector3d p = again.Evaluate(t).T_W_I.translation();
    double nearest = 1e9;
    for (double s = 0.0; s <= reference.duration_s(); s += 0.05)
      nearest = std::min(nearest, (reference.Evaluate(s).T_W_I.translation() - p).norm());
    mean_offset_m += nearest;
  }
  mean_offset_m /= n;
  CHECK(mean_offset_m > 0.15);
  CHECK(mean_offset_m < 1.5);
  // Deterministic per seed.
  const Trajectory again2 = vilma::sim::GenerateRevisitTrajectory(world, reference, o, revisit, 33);
  CHECK(again2.Evaluate(20.0).T_W_I.translation() == again.Evaluate(20.0).T_W_I.translation());
}

TEST_CASE("revisit options are validated", "[sim][trajectory]") {
  vilma::sim::RevisitOptions r;
  CHECK(r.Validate().empty());
  r.correlation = 1.0;
  CHECK(r.Validate().find("correlation") != std::string::npos);
  r = {};
  r.min_speed_ratio = 2.0;
  r.max_speed_ratio = 1.0;
  CHECK(r.Validate().find("speed_ratio") != std::string::npos);
  const vilma::sim::World world = vilma::sim::MakePresetWorld("room", 1);
  const Trajectory standing = vilma::sim::MakeStaticTrajectory(vilma::Transformation(), 10.0);
  TrajectoryOptions o;
  o.duration_s = 10.0;
  CHECK_THROWS_AS(vilma::sim::GenerateRevisitTrajectory(world, standing, o, {}, 1),
                  std::invalid_argument);
}
