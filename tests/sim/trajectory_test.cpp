#include "vilma/sim/trajectory.h"

#include <catch2/catch.hpp>
#include <cmath>

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
