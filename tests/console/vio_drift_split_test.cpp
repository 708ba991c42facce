// scripts/vio_drift_split.py on trajectories with a known kind of drift. On a circle of 10 m
// (0.1 rad/s, 100 s) the estimate integrates the true velocity plus a slowly varying error (a
// sum of two sines, so that no yaw / translation alignment can absorb it) that is either normal
// to the velocity (cross-track), along it (speed / scale), or the true velocity turned by a yaw
// error that the estimate's attitude also carries; the script must give each to its own part.
#include <catch2/catch.hpp>

#include "eval_command_fixture.h"
#include "integration/process_util.h"
#include "test_skip.h"

#include <Eigen/Core>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <regex>
#include <string>

namespace vilma::console {
namespace {

enum class Drift { kCrossTrack, kAlongTrack, kYaw };

// Writes the ground truth (ASL, 200 Hz, 17 columns), the estimate (TUM, 20 Hz) and its state
// log (the 17 columns of `vilma vio --log-state`) into dir. The estimate's position error is
// integrated at 200 Hz: de/dt = c(t) n (n the outward normal: cross-track), c(t) t_hat (the unit
// tangent: along-track) or phi(t) z x v (yaw error phi).
void WriteRun(const std::string& dir, Drift drift) {
  std::ofstream gt(dir + "/gt.csv");
  std::ofstream est(dir + "/est.txt");
  std::ofstream state(dir + "/state.csv");
  gt << "#timestamp,p_x,p_y,p_z,q_w,q_x,q_y,q_z,v_x,v_y,v_z,bw_x,bw_y,bw_z,ba_x,ba_y,ba_z\n";
  est << "# t x y z qx qy qz qw\n";
  state << "t_ns,vx,vy,vz,bgx,bgy,bgz,bax,bay,baz,s_bgx,s_bgy,s_bgz,s_bax,s_bay,s_baz,s_yaw\n";
  constexpr double kPi = 3.14159265358979323846;
  constexpr double kRadius = 10.0;  // [m]
  constexpr double kOmega = 0.1;    // [rad/s]
  constexpr double kDt = 0.005;     // [s]
  Eigen::Vector2d e = Eigen::Vector2d::Zero();
  char line[512];
  for (int k = 0; k <= 20000; ++k) {
    const long long t_ns = 1000000000LL + 5000000LL * k;
    const double t = kDt * k;
    const double theta = kOmega * t;
    const double yaw = theta + 0.5 * kPi;  // heading along the tangent
    const Eigen::Vector2d n(std::cos(theta), std::sin(theta));
    const Eigen::Vector2d tangent(-n.y(), n.x());
    const Eigen::Vector2d p = kRadius * n;
    const Eigen::Vector2d v = kRadius * kOmega * tangent;
    std::snprintf(line, sizeof(line),
                  "%lld,%.9f,%.9f,1,%.12f,0,0,%.12f,%.9f,%.9f,0,0.001,0,0,0.02,0,0\n", t_ns,
                  p.x(), p.y(), std::cos(0.5 * yaw), std::sin(0.5 * yaw), v.x(), v.y());
    gt << line;
    const double c = 0.01 * std::sin(0.05 * t) + 0.005 * std::sin(0.13 * t + 1.0);  // [m/s]
    const double phi = drift == Drift::kYaw ? 0.02 * std::sin(0.07 * t) : 0.0;     // [rad]
    Eigen::Vector2d dv = Eigen::Vector2d::Zero();  // the estimate's velocity error [m/s]
    if (drift == Drift::kCrossTrack) dv = c * n;
    if (drift == Drift::kAlongTrack) dv = c * tangent;
    if (drift == Drift::kYaw) dv = phi * Eigen::Vector2d(-v.y(), v.x());
    if (k % 10 == 0) {
      const double yaw_est = yaw + phi;
      std::snprintf(line, sizeof(line), "%.6f %.9f %.9f 1 0 0 %.12f %.12f\n",
                    static_cast<double>(t_ns) * 1e-9, p.x() + e.x(), p.y() + e.y(),
                    std::sin(0.5 * yaw_est), std::cos(0.5 * yaw_est));
      est << line;
      const Eigen::Vector2d v_est = v + dv;  // the state log's velocity, in M
      std::snprintf(line, sizeof(line),
                    "%lld,%.9f,%.9f,0,0.001,0,0,0.02,0,0,0.001,0.001,0.001,0.01,0.01,0.01,0.01\n",
                    t_ns, v_est.x(), v_est.y());
      state << line;
    }
    e += kDt * dv;
  }
}

// The numbers of the script's first line: "ATE a m: yaw part y, rest r (along-track l,
// cross-track c); vertical z".
struct Split {
  double ate = NAN, yaw = NAN, along = NAN, cross = NAN;
};

Split Parse(const std::string& output) {
  const std::regex re(
      R"(ATE ([0-9.]+) m: yaw part ([0-9.]+), rest [0-9.]+ \(along-track ([0-9.]+), )"
      R"(cross-track ([0-9.]+)\))");
  std::smatch m;
  Split s;
  if (std::regex_search(output, m, re)) {
    s = {std::stod(m[1]), std::stod(m[2]), std::stod(m[3]), std::stod(m[4])};
  }
  return s;
}

// A python3 with numpy: Debian's, else the one on PATH; empty if none.
std::string PythonWithNumpy() {
  std::string ignored;
  for (const std::string python : {"/usr/bin/python3", "python3"}) {
    if (eval_test::Run(python + " -c 'import numpy' 2>/dev/null", &ignored) == 0) return python;
  }
  return "";
}

TEST_CASE("vio_drift_split.py gives a cross-track, an along-track and a yaw drift each its part",
          "[console][scripts]") {
  const std::string python = PythonWithNumpy();
  if (python.empty()) VILMA_SKIP("python3 with numpy not found (Debian package python3-numpy)");
  const std::string script = std::string(VILMA_SOURCE_DIR) + "/scripts/vio_drift_split.py";
  const std::string dir = vilma::test::ScratchDir();
  const std::string files = " " + dir + "/gt.csv " + dir + "/est.txt " + dir + "/state.csv";
  for (const Drift drift : {Drift::kCrossTrack, Drift::kAlongTrack, Drift::kYaw}) {
    WriteRun(dir, drift);
    std::string out;
    const int code = eval_test::Run(python + " " + script + files + " 2>&1", &out);
    INFO(out);
    REQUIRE(code == 0);
    const Split s = Parse(out);
    REQUIRE(std::isfinite(s.ate));
    CHECK(s.ate > 0.05);
    const double own = drift == Drift::kCrossTrack   ? s.cross
                       : drift == Drift::kAlongTrack ? s.along
                                                     : s.yaw;
    CHECK(own > 0.95 * s.ate);
    if (drift != Drift::kCrossTrack) CHECK(s.cross < 0.05 * s.ate);
    if (drift != Drift::kAlongTrack) CHECK(s.along < 0.05 * s.ate);
    if (drift != Drift::kYaw) CHECK(s.yaw < 0.05 * s.ate);
  }
  // A missing file: exit 1, naming it.
  std::string out;
  CHECK(eval_test::Run(python + " " + script + " " + dir + "/missing.csv " + dir + "/est.txt " +
                           dir + "/state.csv 2>&1",
                       &out) == 1);
  CHECK(out.find("missing.csv") != std::string::npos);
}

}  // namespace
}  // namespace vilma::console
