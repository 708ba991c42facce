#include "vilma/sim/trajectory.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <stdexcept>

#include "vilma/sim/random.h"

namespace vilma {
namespace sim {

using Eigen::Matrix3d;
using Eigen::Vector3d;

namespace {

// Uniform cubic B-spline basis on u in [0, 1] and its first two derivatives (w.r.t. u).
void Basis(double u, double b[4], double db[4], double ddb[4]) {
  const double u2 = u * u, u3 = u2 * u, m = 1.0 - u;
  b[0] = m * m * m / 6.0;
  b[1] = (3.0 * u3 - 6.0 * u2 + 4.0) / 6.0;
  b[2] = (-3.0 * u3 + 3.0 * u2 + 3.0 * u + 1.0) / 6.0;
  b[3] = u3 / 6.0;
  db[0] = -m * m / 2.0;
  db[1] = (3.0 * u2 - 4.0 * u) / 2.0;
  db[2] = (-3.0 * u2 + 2.0 * u + 1.0) / 2.0;
  db[3] = u2 / 2.0;
  ddb[0] = m;
  ddb[1] = 3.0 * u - 2.0;
  ddb[2] = -3.0 * u + 1.0;
  ddb[3] = u;
}

Matrix3d Rz(double a) { return Eigen::AngleAxisd(a, Vector3d::UnitZ()).toRotationMatrix(); }
Matrix3d Ry(double a) { return Eigen::AngleAxisd(a, Vector3d::UnitY()).toRotationMatrix(); }
Matrix3d Rx(double a) { return Eigen::AngleAxisd(a, Vector3d::UnitX()).toRotationMatrix(); }

}  // namespace

Matrix3d Trajectory::R_L_I() {
  // Columns: body x = L z (up), body y = -L y (right), body z = L x (forward).
  Matrix3d R;
  R << 0, 0, 1,  //
      0, -1, 0,  //
      1, 0, 0;
  return R;
}

Trajectory::Trajectory(double knot_interval_s, std::vector<Vector3d> position_W,
                       std::vector<Vector3d> yaw_pitch_roll)
    : knot_interval_s_(knot_interval_s),
      position_W_(std::move(position_W)),
      yaw_pitch_roll_(std::move(yaw_pitch_roll)) {
  if (!(knot_interval_s_ > 0.0) || position_W_.size() < 4 ||
      position_W_.size() != yaw_pitch_roll_.size()) {
    throw std::invalid_argument("Trajectory: need >= 4 control points of each kind, same count, "
                                "and a positive knot interval");
  }
}

double Trajectory::duration_s() const {
  return position_W_.empty() ? 0.0 : (position_W_.size() - 3) * knot_interval_s_;
}

TrajectoryState Trajectory::Evaluate(double t_s) const {
  TrajectoryState s;
  const double t = std::clamp(t_s, 0.0, duration_s());
  s.t_s = t_s;
  const int num_segments = static_cast<int>(position_W_.size()) - 3;
  int i = std::min(num_segments - 1, static_cast<int>(std::floor(t / knot_interval_s_)));
  i = std::max(i, 0);
  const double u = t / knot_interval_s_ - i;
  double b[4], db[4], ddb[4];
  Basis(u, b, db, ddb);
  const double inv_dt = 1.0 / knot_interval_s_;
  Vector3d p = Vector3d::Zero(), v = Vector3d::Zero(), a = Vector3d::Zero();
  Vector3d e = Vector3d::Zero(), de = Vector3d::Zero();
  for (int j = 0; j < 4; ++j) {
    p += b[j] * position_W_[i + j];
    v += db[j] * position_W_[i + j];
    a += ddb[j] * position_W_[i + j];
    e += b[j] * yaw_pitch_roll_[i + j];
    de += db[j] * yaw_pitch_roll_[i + j];
  }
  v *= inv_dt;
  a *= inv_dt * inv_dt;
  de *= inv_dt;
  const double yaw = e[0], pitch = e[1], roll = e[2];
  const Matrix3d R_z = Rz(yaw), R_zy = R_z * Ry(pitch);
  const Matrix3d R_W_L = R_zy * Rx(roll);
  const Matrix3d R_W_I = R_W_L * R_L_I();
  const Vector3d omega_W = de[0] * Vector3d::UnitZ() + de[1] * R_z.col(1) + de[2] * R_zy.col(0);
  s.T_W_I = Transformation(Eigen::Quaterniond(R_W_I), p);
  s.v_W = v;
  s.a_W = a;
  s.omega_I = R_W_I.transpose() * omega_W;
  return s;
}

Trajectory MakeStaticTrajectory(const Transformation& T_W_I, double duration_s) {
  const Matrix3d R_W_L = T_W_I.rotationMatrix() * Trajectory::R_L_I().transpose();
  const double yaw = std::atan2(R_W_L(1, 0), R_W_L(0, 0));
  const double pitch = std::asin(std::clamp(-R_W_L(2, 0), -1.0, 1.0));
  const double roll = std::atan2(R_W_L(2, 1), R_W_L(2, 2));
  const double dt = 1.0;
  const int n = static_cast<int>(std::ceil(std::max(duration_s, 1.0) / dt)) + 3;
  return Trajectory(dt, std::vector<Vector3d>(n, T_W_I.translation()),
                    std::vector<Vector3d>(n, Vector3d(yaw, pitch, roll)));
}

std::string TrajectoryOptions::Validate() const {
  if (!(duration_s > 0.0) || !std::isfinite(duration_s)) return "duration_s: expected > 0";
  if (!(static_start_s >= 0.0) || static_start_s >= duration_s)
    return "static_start_s: expected 0 <= static_start_s < duration_s";
  if (!(knot_interval_s >= 0.1 && knot_interval_s <= 10.0))
    return "knot_interval_s: expected 0.1 .. 10 s";
  if (!(speed_scale > 0.0 && speed_scale <= 5.0)) return "speed_scale: expected (0, 5]";
  return "";
}

namespace {

Vector3d LookDirection(double yaw, double pitch) {
  return Vector3d(std::cos(yaw) * std::cos(pitch), std::sin(yaw) * std::cos(pitch),
                  -std::sin(pitch));
}

// Picks the yaw change (bounded by max_step) that keeps the view depth within
// [min_depth, max_depth], preferring a wandering target so the view keeps moving.
double ChooseYaw(const World& world, const Vector3d& p, double yaw, double pitch, double max_step,
                 double target_delta, Rng* rng) {
  const MotionHints& m = world.motion;
  double best_yaw = yaw, best_score = std::numeric_limits<double>::infinity();
  for (int k = 0; k < 13; ++k) {
    const double delta = max_step * (k - 6) / 6.0;
    const double cand = yaw + delta;
    // Depth along the axis and a bit to either side (the image is ~80 deg wide).
    double score = 0.0;
    for (double side : {-0.35, 0.0, 0.35}) {
      const double depth = world.RayCast(p, LookDirection(cand + side, pitch));
      if (depth < m.min_view_depth) score += 10.0 * (m.min_view_depth - depth);
      if (depth > m.max_view_depth) score += std::min(10.0, depth - m.max_view_depth);
    }
    score += 0.5 * std::abs(delta - target_delta) / std::max(1e-9, max_step);
    score += 0.01 * rng->Uniform();
    if (score < best_score) {
      best_score = score;
      best_yaw = cand;
    }
  }
  return best_yaw;
}

// Point at arc length s along a closed polyline, and the heading there.
Vector3d RoutePoint(const std::vector<Vector3d>& route, double s, double* heading) {
  double total = 0.0;
  for (size_t i = 0; i < route.size(); ++i) total += (route[(i + 1) % route.size()] - route[i]).norm();
  s = std::fmod(s, total);
  if (s < 0) s += total;
  for (size_t i = 0; i < route.size(); ++i) {
    const Vector3d a = route[i], b = route[(i + 1) % route.size()];
    const double len = (b - a).norm();
    if (s <= len || i + 1 == route.size()) {
      const Vector3d d = (b - a) / std::max(1e-9, len);
      *heading = std::atan2(d.y(), d.x());
      return a + std::min(s, len) * d;
    }
    s -= len;
  }
  *heading = 0.0;
  return route[0];
}

double WrapToPi(double a) {
  while (a > M_PI) a -= 2 * M_PI;
  while (a < -M_PI) a += 2 * M_PI;
  return a;
}

Trajectory GenerateOnce(const World& world, const TrajectoryOptions& options, uint64_t seed) {
  Rng rng(seed);
  const MotionHints& m = world.motion;
  const double dt = options.knot_interval_s;
  const double speed = m.mean_speed * options.speed_scale;
  const double max_yaw_step = 0.8 * m.max_yaw_rate * options.speed_scale * dt;
  const int num_segments = static_cast<int>(std::ceil(options.duration_s / dt)) + 1;
  const int n = num_segments + 3;
  const int n_static = static_cast<int>(std::ceil(options.static_start_s / dt)) + 3;
  std::vector<Vector3d> pos(n), ang(n);
  const bool route_mode = m.route_W.size() >= 2;

  // Start point and yaw.
  Vector3d p;
  double yaw = 0.0, route_s = 0.0, direction = 1.0, lateral = 0.0, look_offset = 0.0;
  double look_target = 0.0;
  if (route_mode) {
    double total = 0.0;
    for (size_t i = 0; i < m.route_W.size(); ++i)
      total += (m.route_W[(i + 1) % m.route_W.size()] - m.route_W[i]).norm();
    route_s = rng.Uniform(0.0, total);
    direction = rng.Uniform() < 0.5 ? 1.0 : -1.0;
    double heading;
    p = RoutePoint(m.route_W, route_s, &heading);
    yaw = heading + (direction < 0 ? M_PI : 0.0);
  } else {
    for (int k = 0; k < 1000; ++k) {
      // Drawn z, y, x ("Draw order" in random.h).
      const double uz = rng.Uniform(), uy = rng.Uniform(), ux = rng.Uniform();
      p = m.free_space.min() +
          (m.free_space.max() - m.free_space.min()).cwiseProduct(Vector3d(ux, uy, uz));
      if (world.IsFree(p, m.clearance * 1.5)) break;
    }
    yaw = rng.Uniform(-M_PI, M_PI);
    // Face something at a comfortable depth at the start.
    for (int k = 0; k < 8; ++k) yaw = ChooseYaw(world, p, yaw, m.mean_pitch, M_PI / 4, 0.0, &rng);
  }
  double pitch = m.mean_pitch, roll = 0.0;
  for (int i = 0; i < n_static && i < n; ++i) {
    pos[i] = p;
    ang[i] = Vector3d(yaw, pitch, roll);
  }
  Vector3d dir_W = LookDirection(yaw, 0.0);
  for (int i = n_static; i < n; ++i) {
    // Ramp the speed up over the first knots after the static start.
    const double ramp = std::min(1.0, (i - n_static + 1) / 3.0);
    const double step = speed * dt * ramp * rng.Uniform(0.6, 1.4);
    Vector3d next = p;
    if (route_mode) {
      route_s += direction * step;
      double heading;
      lateral = std::clamp(0.8 * lateral + rng.Normal(0.0, 0.3), -2.5, 2.5);
      Vector3d on_route = RoutePoint(m.route_W, route_s, &heading);
      if (direction < 0) heading += M_PI;
      const Vector3d left(-std::sin(heading), std::cos(heading), 0.0);
      next = on_route + lateral * left + Vector3d(0, 0, rng.Normal(0.0, 0.1));
      // Look ahead, at the left or the right facades, changing every few seconds.
      if (rng.Uniform() < dt / 4.0) look_target = rng.Uniform(-1.2, 1.2);
      look_offset += std::clamp(look_target - look_offset, -0.5 * max_yaw_step, 0.5 * max_yaw_step);
      const double desired = heading + look_offset;
      const double delta = std::clamp(WrapToPi(desired - yaw), -max_yaw_step, max_yaw_step);
      yaw += delta;
    } else {
      bool found = false;
      for (int k = 0; k < 40 && !found; ++k) {
        // Smooth flight: mostly keep the direction, turn by a random angle, climb a little.
        const double turn = rng.Normal(0.0, k < 20 ? 0.6 : 2.0);
        Vector3d d = Eigen::AngleAxisd(turn, Vector3d::UnitZ()) * dir_W;
        d.z() = 0.7 * d.z() + rng.Normal(0.0, 0.25);
        d.normalize();
        const Vector3d cand = p + step * d;
        bool ok = world.IsFree(cand, m.clearance);
        for (int j = 1; j < 4 && ok; ++j) ok = world.IsFree(p + (j / 4.0) * step * d, m.clearance);
        if (ok) {
          next = cand;
          dir_W = d;
          found = true;
        }
      }
      if (!found) dir_W = -dir_W;  // hover this knot and turn around
      const double target = rng.Normal(0.0, 0.6) * max_yaw_step;
      yaw = ChooseYaw(world, next, yaw, m.mean_pitch, max_yaw_step * ramp, target, &rng);
    }
    p = next;
    pitch = m.mean_pitch + m.roll_pitch_amplitude * rng.Uniform(-1.0, 1.0) * ramp;
    roll = m.roll_pitch_amplitude * rng.Uniform(-1.0, 1.0) * ramp;
    pos[i] = p;
    ang[i] = Vector3d(yaw, pitch, roll);
  }
  return Trajectory(dt, pos, ang);
}

}  // namespace

namespace {

// Checks a trajectory on samples every 50 ms: clearance, speed, rates, view depth.
TrajectoryReport Check(const World& world, const Trajectory& traj) {
  TrajectoryReport r;
  r.min_view_depth = std::numeric_limits<double>::infinity();
  double speed_sum = 0.0;
  int count = 0;
  for (double t = 0.0; t <= traj.duration_s(); t += 0.05, ++count) {
    const TrajectoryState s = traj.Evaluate(t);
    if (!world.IsFree(s.T_W_I.translation(), 0.5 * world.motion.clearance)) ++r.collision_samples;
    r.max_speed = std::max(r.max_speed, s.v_W.norm());
    speed_sum += s.v_W.norm();
    r.max_angular_rate = std::max(r.max_angular_rate, s.omega_I.norm());
    const Vector3d axis_W = s.T_W_I.rotation() * Vector3d::UnitZ();  // camera ~ body z
    r.min_view_depth = std::min(r.min_view_depth, world.RayCast(s.T_W_I.translation(), axis_W));
  }
  r.mean_speed = speed_sum / std::max(1, count);
  return r;
}

// Up to 20 attempts with derived seeds; the first without collision wins, else the one with
// the fewest colliding samples.
template <typename GenerateOnceFn>
Trajectory GenerateBest(const World& world, uint64_t seed, TrajectoryReport* report,
                        const GenerateOnceFn& generate_once) {
  Trajectory best;
  TrajectoryReport best_report;
  best_report.collision_samples = std::numeric_limits<int>::max();
  for (int attempt = 0; attempt < 20; ++attempt) {
    Trajectory traj = generate_once(DeriveSeed(seed, attempt));
    TrajectoryReport r = Check(world, traj);
    r.attempts = attempt + 1;
    if (r.collision_samples < best_report.collision_samples) {
      best = traj;
      best_report = r;
    }
    if (r.collision_samples == 0) break;
  }
  if (report) *report = best_report;
  return best;
}

// Control point at fractional index u (linear interpolation between neighbours).
Vector3d Lerp(const std::vector<Vector3d>& points, double u) {
  const int last = static_cast<int>(points.size()) - 1;
  u = std::clamp(u, 0.0, static_cast<double>(last));
  const int i = std::min(last - 1, static_cast<int>(std::floor(u)));
  const double f = u - i;
  Vector3d result = points[static_cast<std::size_t>(i)];
  result += f * (points[static_cast<std::size_t>(i) + 1] - result);
  return result;
}

// One draw of a revisit's position offset: horizontal sigma on x and y, height sigma on z,
// drawn z, y, x ("Draw order" in random.h).
Vector3d DrawRevisitOffset(const RevisitOptions& revisit, Rng* rng) {
  const double z = rng->Normal(0.0, revisit.height_offset_m);
  const double y = rng->Normal(0.0, revisit.position_offset_m);
  const double x = rng->Normal(0.0, revisit.position_offset_m);
  return Vector3d(x, y, z);
}

Trajectory RevisitOnce(const World& world, const Trajectory& reference,
                       const TrajectoryOptions& options, const RevisitOptions& revisit,
                       uint64_t seed) {
  Rng rng(seed);
  const MotionHints& m = world.motion;
  const double dt = options.knot_interval_s;
  const std::vector<Vector3d>& ref_pos = reference.position_control_points();
  const std::vector<Vector3d>& ref_ang = reference.angle_control_points();
  // Knot spacing may differ from the reference's: walk in reference-index units scaled by the
  // ratio of the intervals so that the reference's speed is kept.
  const double index_per_knot = dt / reference.knot_interval_s();
  // The reference's moving part: its static start repeats the first control point.
  int first_moving = 0;
  while (first_moving + 1 < static_cast<int>(ref_pos.size()) &&
         (ref_pos[first_moving + 1] - ref_pos[0]).norm() < 1e-9 &&
         (ref_ang[first_moving + 1] - ref_ang[0]).norm() < 1e-12) {
    ++first_moving;
  }
  const double lo = first_moving, hi = static_cast<double>(ref_pos.size() - 1);
  if (hi - lo < 1.0) {
    throw std::invalid_argument("GenerateRevisitTrajectory: the reference does not move");
  }
  const int num_segments = static_cast<int>(std::ceil(options.duration_s / dt)) + 1;
  const int n = num_segments + 3;
  const int n_static = static_cast<int>(std::ceil(options.static_start_s / dt)) + 3;
  const double a = revisit.correlation;
  // Innovation std that gives the wanted stationary std: sigma^2 = s^2 / (1 - a^2).
  const double innovation = std::sqrt(std::max(0.0, 1.0 - a * a));
  double u = rng.Uniform(lo, hi);
  double direction = rng.Uniform() < 0.5 ? 1.0 : -1.0;
  Vector3d offset = DrawRevisitOffset(revisit, &rng);
  double yaw_offset = rng.Normal(0.0, revisit.yaw_offset_rad);
  std::vector<Vector3d> pos(n), ang(n);
  // Reference point plus offset, shrinking the offset until the point keeps clear.
  auto place = [&](double index) {
    Vector3d p_W = Lerp(ref_pos, index);
    for (double shrink : {1.0, 0.5, 0.25}) {
      if (world.IsFree(p_W + shrink * offset, m.clearance)) {
        offset *= shrink;
        p_W += offset;
        return p_W;
      }
    }
    offset.setZero();
    return p_W;
  };
  Vector3d p = place(u);
  double yaw = Lerp(ref_ang, u).x() + yaw_offset;
  for (int i = 0; i < n_static && i < n; ++i) {
    pos[i] = p;
    ang[i] = Vector3d(yaw, m.mean_pitch, 0.0);
  }
  for (int i = n_static; i < n; ++i) {
    const double ramp = std::min(1.0, (i - n_static + 1) / 3.0);
    u += direction * ramp * index_per_knot *
         rng.Uniform(revisit.min_speed_ratio, revisit.max_speed_ratio);
    if (u > hi) {  // bounce at the reference's ends
      u = 2.0 * hi - u;
      direction = -1.0;
    } else if (u < lo) {
      u = 2.0 * lo - u;
      direction = 1.0;
    }
    offset = a * offset + innovation * DrawRevisitOffset(revisit, &rng);
    yaw_offset = a * yaw_offset + innovation * rng.Normal(0.0, revisit.yaw_offset_rad);
    p = place(u);
    yaw = Lerp(ref_ang, u).x() + yaw_offset;  // the static start has the full offset too
    const double pitch = m.mean_pitch + m.roll_pitch_amplitude * rng.Uniform(-1.0, 1.0) * ramp;
    const double roll = m.roll_pitch_amplitude * rng.Uniform(-1.0, 1.0) * ramp;
    pos[i] = p;
    ang[i] = Vector3d(yaw, pitch, roll);
  }
  return Trajectory(dt, pos, ang);
}

}  // namespace

std::string RevisitOptions::Validate() const {
  if (!(position_offset_m >= 0.0 && position_offset_m <= 10.0))
    return "position_offset_m: expected 0 .. 10 m";
  if (!(height_offset_m >= 0.0 && height_offset_m <= 10.0))
    return "height_offset_m: expected 0 .. 10 m";
  if (!(yaw_offset_rad >= 0.0 && yaw_offset_rad <= M_PI)) return "yaw_offset_rad: expected 0 .. pi";
  if (!(correlation >= 0.0 && correlation < 1.0)) return "correlation: expected 0 .. < 1";
  if (!(min_speed_ratio > 0.0 && min_speed_ratio <= max_speed_ratio && max_speed_ratio <= 5.0))
    return "min_speed_ratio / max_speed_ratio: expected 0 < min <= max <= 5";
  return "";
}

Trajectory GenerateTrajectory(const World& world, const TrajectoryOptions& options, uint64_t seed,
                              TrajectoryReport* report) {
  const std::string error = options.Validate();
  if (!error.empty()) throw std::invalid_argument("TrajectoryOptions: " + error);
  return GenerateBest(world, seed, report,
                      [&](uint64_t s) { return GenerateOnce(world, options, s); });
}

Trajectory GenerateRevisitTrajectory(const World& world, const Trajectory& reference,
                                     const TrajectoryOptions& options,
                                     const RevisitOptions& revisit, uint64_t seed,
                                     TrajectoryReport* report) {
  std::string error = options.Validate();
  if (!error.empty()) throw std::invalid_argument("TrajectoryOptions: " + error);
  error = revisit.Validate();
  if (!error.empty()) throw std::invalid_argument("RevisitOptions: " + error);
  return GenerateBest(world, seed, report, [&](uint64_t s) {
    return RevisitOnce(world, reference, options, revisit, s);
  });
}

}  // namespace sim
}  // namespace vilma
