// Smooth body (IMU frame I) trajectories in the world frame W with exact analytic derivatives.
//
// Position is a uniform cubic B-spline (C2: continuous acceleration, so the simulated
// accelerometer is continuous); orientation is R_W_I = Rz(yaw) Ry(pitch) Rx(roll) R_L_I where
// yaw, pitch and roll are cubic B-splines too and R_L_I turns the "look" frame L (x forward,
// y left, z up) into the EuRoC body frame (body z forward, body x up, body y right: the VI-sensor
// camera looks along body z with its image x along body y). Angular velocity follows exactly
// from the Euler-angle rates:
//   omega_W = yaw' e_z + pitch' Rz e_y + roll' Rz Ry e_x,   omega_I = R_W_I^T omega_W.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "vilma/core/geometry.h"
#include "vilma/sim/world.h"

namespace vilma {
namespace sim {

struct TrajectoryState {
  double t_s = 0.0;  // time since the trajectory start [s]
  Transformation T_W_I;
  Eigen::Vector3d v_W = Eigen::Vector3d::Zero();      // [m/s]
  Eigen::Vector3d a_W = Eigen::Vector3d::Zero();      // [m/s^2], kinematic (no gravity)
  Eigen::Vector3d omega_I = Eigen::Vector3d::Zero();  // [rad/s], body angular velocity
};

class Trajectory {
 public:
  Trajectory() = default;
  // `position_W` and `yaw_pitch_roll` [rad] are control points (the same number, >= 4) of
  // uniform cubic B-splines with knots every `knot_interval_s`.
  Trajectory(double knot_interval_s, std::vector<Eigen::Vector3d> position_W,
             std::vector<Eigen::Vector3d> yaw_pitch_roll);

  // Valid times are [0, duration_s()]; Evaluate clamps to it.
  double duration_s() const;
  TrajectoryState Evaluate(double t_s) const;

  double knot_interval_s() const { return knot_interval_s_; }
  const std::vector<Eigen::Vector3d>& position_control_points() const { return position_W_; }
  const std::vector<Eigen::Vector3d>& angle_control_points() const { return yaw_pitch_roll_; }

  // Rotation from the look frame L (x forward, y left, z up) to the EuRoC body frame.
  static Eigen::Matrix3d R_L_I();

 private:
  double knot_interval_s_ = 1.0;
  std::vector<Eigen::Vector3d> position_W_;
  std::vector<Eigen::Vector3d> yaw_pitch_roll_;
};

// A trajectory that stands still at T_W_I for `duration_s` (the rotation must keep body x
// roughly up for the Euler parametrization; any rotation works, roll/pitch are recovered).
Trajectory MakeStaticTrajectory(const Transformation& T_W_I, double duration_s);

struct TrajectoryOptions {
  double duration_s = 60.0;       // total length including the static start [s]
  double static_start_s = 3.0;    // the body stands still this long at the start [s]
  double knot_interval_s = 0.8;   // B-spline knot spacing [s]; smaller = more agile
  double speed_scale = 1.0;       // multiplies the world's mean speed and yaw rate

  std::string Validate() const;
};

struct TrajectoryReport {
  int attempts = 0;             // generation attempts used
  int collision_samples = 0;    // samples closer than half the clearance (0 when all good)
  double max_speed = 0.0;       // [m/s]
  double mean_speed = 0.0;      // [m/s]
  double max_angular_rate = 0.0;  // [rad/s]
  double min_view_depth = 0.0;  // [m] smallest depth along the optical axis seen
};

// Generates a trajectory through `world` (random walk in its free space, or along its route),
// deterministic from `seed`. Checks clearance and view depth on samples and retries with
// derived seeds; `report` (optional) says how it went.
Trajectory GenerateTrajectory(const World& world, const TrajectoryOptions& options, uint64_t seed,
                              TrajectoryReport* report = nullptr);

// Options of a path that revisits another one (later sessions of a multi-session dataset: the
// robot comes back to where the mapping session went and looks at what it saw, the way EuRoC's
// MH_02 repeats MH_01). All offsets are smooth AR(1) processes per knot, x_k+1 = a x_k + n.
struct RevisitOptions {
  double position_offset_m = 0.6;    // stationary std of the horizontal offset [m]
  double height_offset_m = 0.25;     // stationary std of the vertical offset [m]
  double yaw_offset_rad = 0.25;      // stationary std of the yaw offset [rad]
  double correlation = 0.85;         // AR(1) coefficient a per knot (0 .. 1)
  double min_speed_ratio = 0.7;      // speed relative to the reference, drawn per knot
  double max_speed_ratio = 1.3;

  std::string Validate() const;
};

// A trajectory of options.duration_s that follows `reference` (another session's trajectory in
// the same world): it starts at a random point of the reference's moving part, walks along the
// reference's control points forwards or backwards (bouncing at its ends) at a randomly varying
// speed, with smooth position and yaw offsets that keep clear of the world's geometry. The
// reference's yaw is kept, so the camera looks at what the reference looked at from nearby.
// Deterministic from `seed`; retries like GenerateTrajectory.
Trajectory GenerateRevisitTrajectory(const World& world, const Trajectory& reference,
                                     const TrajectoryOptions& options,
                                     const RevisitOptions& revisit, uint64_t seed,
                                     TrajectoryReport* report = nullptr);

}  // namespace sim
}  // namespace vilma
