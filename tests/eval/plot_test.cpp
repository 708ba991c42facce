#include "vilma/eval/plot.h"

#include <catch2/catch.hpp>
#include <unistd.h>

#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "vilma/core/error.h"

namespace vilma {
namespace {

// Sets an environment variable for the scope of the test, restoring the old value after.
struct ScopedEnv {
  std::string name;
  bool had = false;
  std::string old;
  ScopedEnv(const std::string& n, const std::string& value) : name(n) {
    const char* v = std::getenv(n.c_str());
    had = v != nullptr;
    if (had) old = v;
    ::setenv(n.c_str(), value.c_str(), 1);
  }
  ~ScopedEnv() {
    if (had) {
      ::setenv(name.c_str(), old.c_str(), 1);
    } else {
      ::unsetenv(name.c_str());
    }
  }
};

EvalResult TwoPoses(bool by_index) {
  EvalResult r;
  r.association.by_index = by_index;
  r.association.gt_index = {0, 1};
  r.association.est_index = {0, 1};
  r.t_ns = {5000000000, 5250000000};
  r.T_G_B_gt = {Transformation(), Transformation(Eigen::Quaterniond::Identity(),
                                                 Eigen::Vector3d(1, 2, 3))};
  r.T_G_B_est = {Transformation(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.5, 0, 0)),
                 Transformation(Eigen::Quaterniond::Identity(), Eigen::Vector3d(1, 2, 4))};
  r.ate.translation_errors_m = {0.5, 1.0};
  r.ate.rotation_errors_deg = {0.0, 2.5};
  return r;
}

TEST_CASE("the plot CSV: one row per matched pose, time from the first", "[eval]") {
  std::ostringstream out;
  WritePlotCsv(out, TwoPoses(false));
  CHECK(out.str() ==
        "t_s,gt_x,gt_y,gt_z,est_x,est_y,est_z,translation_error_m,rotation_error_deg\n"
        "0.000000000,0.000000000,0.000000000,0.000000000,0.500000000,0.000000000,0.000000000,"
        "0.500000000,0.000000000\n"
        "0.250000000,1.000000000,2.000000000,3.000000000,1.000000000,2.000000000,4.000000000,"
        "1.000000000,2.500000000\n");
  std::ostringstream by_index;
  WritePlotCsv(by_index, TwoPoses(true));
  CHECK_THAT(by_index.str(), Catch::Contains("\n1.000000000,1.000000000,2.000000000"));
}

TEST_CASE("the plot script's folder: VILMA_SCRIPTS_DIR, else beside the executable", "[eval]") {
  {
    const ScopedEnv env("VILMA_SCRIPTS_DIR", "/opt/x/scripts");
    CHECK(PlotScriptsDir() == "/opt/x/scripts");
  }
  const ScopedEnv env("VILMA_SCRIPTS_DIR", "");
  const std::string exe_dir = std::filesystem::read_symlink("/proc/self/exe").parent_path();
  CHECK(PlotScriptsDir() == exe_dir + "/../share/vilma/scripts");
}

TEST_CASE("plot errors: no script, no interpreter", "[eval]") {
  TrajectoryEvalSummary s;
  s.result = TwoPoses(false);
  const std::string empty_dir =
      (std::filesystem::temp_directory_path() / ("vilma_plot_test_" + std::to_string(::getpid())))
          .string();
  std::filesystem::create_directories(empty_dir);
  {
    const ScopedEnv env("VILMA_SCRIPTS_DIR", empty_dir);
    CHECK_THROWS_WITH(RenderTrajectoryPlot(s, empty_dir + "/p.png"),
                      empty_dir + "/plot_trajectory.py: expected the plot script, installed "
                                  "with the programs (share/vilma/scripts beside bin/), or set "
                                  "VILMA_SCRIPTS_DIR to the folder holding plot_trajectory.py");
  }
  {
    // A script that is there, an interpreter that is not.
    std::ofstream(empty_dir + "/plot_trajectory.py") << "raise SystemExit(3)\n";
    const ScopedEnv scripts("VILMA_SCRIPTS_DIR", empty_dir);
    const ScopedEnv python("VILMA_PYTHON", empty_dir + "/no-python");
    CHECK_THROWS_WITH(RenderTrajectoryPlot(s, empty_dir + "/p.png"),
                      empty_dir + "/p.png: --plot: expected python3 with matplotlib (tried " +
                          empty_dir + "/no-python (not found)); install python3-matplotlib or set "
                                      "VILMA_PYTHON");
  }
  std::filesystem::remove_all(empty_dir);
}

}  // namespace
}  // namespace vilma
