// Shared set-up of the `vilma eval` command tests (eval_command_test.cpp,
// eval_command_alignment_test.cpp): trajectories with known errors, temporary files, running the
// command in process or through the shell.
#pragma once

#include "vilma/console/eval_command.h"

#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vector>

namespace vilma::console::eval_test {

constexpr double kPi = 3.14159265358979323846;

// Generated files live outside the repository ($VILMA_TEST_TMPDIR or /tmp); per-process folder so
// that parallel ctest runs do not collide.
inline std::string TestDir() {
  const char* base = std::getenv("VILMA_TEST_TMPDIR");
  std::string dir = base != nullptr ? base : "/tmp";
  dir += "/vilma_eval_command_test_" + std::to_string(::getpid());
  ::mkdir(dir.c_str(), 0755);
  return dir;
}

// Ground truth: a horizontal figure-eight, 60 s at 20 Hz with heading along the path, ~70 m.
inline Trajectory MakeGroundTruth() {
  Trajectory t;
  for (int i = 0; i < 1200; ++i) {
    const double s = 0.05 * i;
    const double w = 2.0 * kPi / 30.0;
    const Eigen::Vector3d p(6.0 * std::sin(w * s), 3.0 * std::sin(2.0 * w * s), 1.5);
    const Eigen::Vector3d v(6.0 * w * std::cos(w * s), 6.0 * w * std::cos(2.0 * w * s), 0.0);
    const Eigen::Quaterniond q(Eigen::AngleAxisd(std::atan2(v.y(), v.x()),
                                                 Eigen::Vector3d::UnitZ()));
    t.Add(1403715273262142976 + int64_t{i} * 50000000, Transformation(q, p));
  }
  return t;
}

// Estimate: the gt in a world rotated by 30 deg yaw and shifted, a deterministic 5 cm wobble in
// x, stamps 1 ms late (within --max-dt).
inline Trajectory MakeEstimate(const Trajectory& gt) {
  Trajectory est;
  const Transformation T_E_G(
      Eigen::Quaterniond(Eigen::AngleAxisd(kPi / 6.0, Eigen::Vector3d::UnitZ())),
      Eigen::Vector3d(10.0, -3.0, 0.5));
  for (std::size_t i = 0; i < gt.size(); ++i) {
    Transformation T = gt.T_W_B[i];
    // +-5 cm alternating along gt x: mean zero, so no alignment can remove it.
    const double wobble = (i % 2 == 0 ? 0.05 : -0.05);
    T = Transformation(T.rotation(), T.translation() + Eigen::Vector3d(wobble, 0.0, 0.0));
    est.Add(gt.t_ns[i] + 1000000, T_E_G * T);
  }
  return est;
}

// Removes its folder when done, so repeated runs leave nothing behind.
struct Files {
  std::string dir, gt, est;
  Files() = default;
  Files(const Files&) = delete;
  Files& operator=(const Files&) = delete;
  ~Files() {
    std::error_code ignored;
    if (!dir.empty()) std::filesystem::remove_all(dir, ignored);
  }
};

inline void WriteInputs(Files& f) {
  f.dir = TestDir();
  f.gt = f.dir + "/gt.csv";
  f.est = f.dir + "/est.txt";
  const Trajectory gt = MakeGroundTruth();
  WriteTrajectoryFile(f.gt, gt, TrajectoryFormat::kEuroc);
  WriteTrajectoryFile(f.est, MakeEstimate(gt), TrajectoryFormat::kTum);
}

inline std::string Slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// Output and exit status of a shell command.
inline int Run(const std::string& command, std::string* output) {
  FILE* pipe = ::popen(command.c_str(), "r");
  if (pipe == nullptr) return -1;
  char buf[4096];
  std::size_t n = 0;
  output->clear();
  while ((n = std::fread(buf, 1, sizeof(buf), pipe)) > 0) output->append(buf, n);
  const int status = ::pclose(pipe);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

struct Result {
  int code;
  std::string out, err;
};

inline Result Eval(const std::vector<std::string>& args) {
  std::ostringstream out, err;
  const int code = RunEvalCommand(args, out, err);
  return {code, out.str(), err.str()};
}

}  // namespace vilma::console::eval_test
