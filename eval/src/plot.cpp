#include "vilma/eval/plot.h"

#include <fcntl.h>
#include <spawn.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <vector>

#include "vilma/core/error.h"

extern char** environ;

namespace vilma {
namespace {

std::string Fixed(double v, int decimals) {
  char buf[48];
  std::snprintf(buf, sizeof(buf), "%.*f", decimals, v);
  return buf;
}

bool FileExists(const std::string& path) {
  struct stat st;
  return ::stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode);
}

// Runs argv (argv[0] looked up in PATH) and returns its exit status, -1 if it could not be
// started, -2 if it died from a signal. With quiet, its stdout and stderr go to /dev/null.
int RunProcess(const std::vector<std::string>& args, bool quiet) {
  std::vector<char*> argv;
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  if (quiet) {
    posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, "/dev/null", O_WRONLY, 0);
    posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, "/dev/null", O_WRONLY, 0);
  }
  pid_t pid = 0;
  const int spawned = posix_spawnp(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (spawned != 0) return -1;
  int status = 0;
  while (waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) return -1;
  }
  if (WIFEXITED(status)) {
    const int code = WEXITSTATUS(status);
    return code == 127 ? -1 : code;  // 127: the shell-style "command not found"
  }
  return -2;
}

}  // namespace

void WritePlotCsv(std::ostream& out, const EvalResult& result) {
  out << "t_s,gt_x,gt_y,gt_z,est_x,est_y,est_z,translation_error_m,rotation_error_deg\n";
  char line[320];
  const bool by_index = result.association.by_index;
  for (std::size_t k = 0; k < result.t_ns.size(); ++k) {
    const double t = by_index ? static_cast<double>(k)
                              : static_cast<double>(result.t_ns[k] - result.t_ns.front()) * 1e-9;
    const Eigen::Vector3d& g = result.T_G_B_gt[k].translation();
    const Eigen::Vector3d& e = result.T_G_B_est[k].translation();
    std::snprintf(line, sizeof(line), "%.9f,%.9f,%.9f,%.9f,%.9f,%.9f,%.9f,%.9f,%.9f\n", t, g.x(),
                  g.y(), g.z(), e.x(), e.y(), e.z(), result.ate.translation_errors_m[k],
                  result.ate.rotation_errors_deg[k]);
    out << line;
  }
}

std::string PlotScriptsDir() {
  const char* env = std::getenv("VILMA_SCRIPTS_DIR");
  if (env != nullptr && env[0] != '\0') return env;
  char exe[4096];
  const ssize_t n = ::readlink("/proc/self/exe", exe, sizeof(exe) - 1);
  if (n <= 0) return "share/vilma/scripts";
  exe[n] = '\0';
  std::string dir(exe);
  dir = dir.substr(0, dir.find_last_of('/'));  // .../bin
  return dir + "/../share/vilma/scripts";
}

void RenderTrajectoryPlot(const TrajectoryEvalSummary& summary, const std::string& png_path) {
  const EvalResult& result = summary.result;
  const std::string script = PlotScriptsDir() + "/plot_trajectory.py";
  if (!FileExists(script)) {
    throw InputError(FormatInputError(
        script, "",
        "expected the plot script, installed with the programs (share/vilma/scripts beside "
        "bin/), or set VILMA_SCRIPTS_DIR to the folder holding plot_trajectory.py"));
  }
  const char* tmpdir = std::getenv("TMPDIR");
  std::string tmp_path = (tmpdir != nullptr && tmpdir[0] != '\0')
                             ? std::string(tmpdir) + "/vilma_eval_plot_XXXXXX"
                             : std::string("/tmp/vilma_eval_plot_XXXXXX");
  std::vector<char> tmp_buf(tmp_path.begin(), tmp_path.end());
  tmp_buf.push_back('\0');
  const int fd = ::mkstemp(tmp_buf.data());
  if (fd < 0) throw InputError(FormatInputError(tmp_path, "", "expected a writable temp file"));
  ::close(fd);
  tmp_path = tmp_buf.data();
  {
    std::ofstream csv(tmp_path);
    WritePlotCsv(csv, result);
    if (!csv) {
      std::remove(tmp_path.c_str());
      throw InputError(FormatInputError(tmp_path, "", "expected a writable temp file"));
    }
  }
  std::ostringstream title;
  title << "align " << AlignmentTypeName(result.alignment.type) << ", ATE rmse "
        << Fixed(result.ate.translation_m.rmse, 3) << " m / "
        << Fixed(result.ate.rotation_deg.rmse, 2) << " deg, " << result.association.size()
        << " poses";

  std::vector<std::string> pythons;
  const char* env_python = std::getenv("VILMA_PYTHON");
  if (env_python != nullptr && env_python[0] != '\0') {
    pythons.push_back(env_python);
  } else {
    pythons = {"python3", "/usr/bin/python3"};
  }
  // Probe quietly for an interpreter that imports matplotlib, then run the script with it (its
  // own errors then reach the user's stderr).
  std::string tried;
  std::string python;
  for (const auto& candidate : pythons) {
    const int probe = RunProcess({candidate, "-c", "import matplotlib"}, true);
    if (!tried.empty()) tried += ", ";
    tried += candidate + (probe == -1 ? " (not found)" : " (no matplotlib)");
    if (probe == 0) {
      python = candidate;
      break;
    }
  }
  if (python.empty()) {
    std::remove(tmp_path.c_str());
    throw InputError(FormatInputError(
        png_path, "--plot",
        "expected python3 with matplotlib (tried " + tried +
            "); install python3-matplotlib or set VILMA_PYTHON"));
  }
  const int status = RunProcess(
      {python, script, "--input", tmp_path, "--output", png_path, "--title", title.str()}, false);
  std::remove(tmp_path.c_str());
  if (status != 0) {
    throw InputError(FormatInputError(png_path, "--plot",
                                      "expected " + script + " to succeed, it exited with " +
                                          std::to_string(status)));
  }
}

}  // namespace vilma
