#include "vilma/mapstore/stream/mission_post_processor.h"

#include <fcntl.h>
#include <signal.h>
#include <sys/wait.h>
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <sstream>
#include <stdexcept>
#include <thread>
#include <vector>

#include "vilma/core/atomic_file.h"

namespace vilma::mapstore {
namespace {

namespace fs = std::filesystem;
constexpr const char kSuffix[] = ".processed";

bool EndsWith(const std::string& s, const std::string& suffix) {
  return s.size() >= suffix.size() && s.compare(s.size() - suffix.size(), suffix.size(), suffix) == 0;
}

std::string Seconds(double s) {
  std::ostringstream out;
  out.precision(3);
  out << s << " s";
  return out.str();
}

}  // namespace

std::string PostProcessOptions::Validate() const {
  if (script.empty()) return "";
  if (!fs::is_regular_file(script)) return "script: expected an existing console script file";
  if (::access(vilma_program.c_str(), X_OK) != 0) {
    return "vilma_program: expected the vilma executable (" + vilma_program + ")";
  }
  if (!(timeout_s > 0.0)) return "timeout_s: expected > 0";
  return "";
}

MissionPostProcessor::MissionPostProcessor(std::string root, PostProcessOptions options,
                                           Logger log)
    : root_(std::move(root)), options_(std::move(options)), log_(std::move(log)) {
  const std::string problem = options_.Validate();
  if (!problem.empty()) throw std::invalid_argument("post_process." + problem);
}

MissionPostProcessor::~MissionPostProcessor() { Stop(); }

void MissionPostProcessor::Scan() {
  if (!enabled()) return;
  std::error_code error;
  std::vector<std::string> names;
  for (const auto& entry : fs::directory_iterator(root_, error)) {
    const std::string name = entry.path().filename().string();
    if (!entry.is_directory(error) || name.empty() || name[0] == '.' || EndsWith(name, kSuffix)) {
      continue;
    }
    if (!fs::is_regular_file(entry.path() / "manifest.yaml", error)) continue;
    const std::string base = root_ + "/" + name + kSuffix;
    if (fs::exists(base + ".done", error) || fs::exists(base + ".failed", error)) continue;
    if (name == running_name_ || std::find(queue_.begin(), queue_.end(), name) != queue_.end()) {
      continue;
    }
    names.push_back(name);
  }
  std::sort(names.begin(), names.end());
  for (const std::string& name : names) queue_.push_back(name);
  counters_.queued = queue_.size();
}

void MissionPostProcessor::Start(const std::string& name, Clock::time_point now) {
  const std::string map = root_ + "/" + name;
  const std::string out = map + kSuffix;
  const std::string log_path = out + ".log";
  std::vector<std::string> args = {options_.vilma_program, "console", "--script", options_.script,
                                   "--var", "map=" + map, "--var", "out=" + out,
                                   "--var", "name=" + name, "--no-history"};
  const pid_t pid = ::fork();
  if (pid < 0) {
    log_("post-processing " + name + ": cannot fork; retried later");
    queue_.push_front(name);
    return;
  }
  if (pid == 0) {
    ::setpgid(0, 0);
    const int fd = ::open(log_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
    if (fd >= 0) {
      ::dup2(fd, 1);
      ::dup2(fd, 2);
      ::close(fd);
    }
    const int devnull = ::open("/dev/null", O_RDONLY);
    if (devnull >= 0) ::dup2(devnull, 0);
    std::vector<char*> argv;
    for (std::string& a : args) argv.push_back(a.data());
    argv.push_back(nullptr);
    ::execv(argv[0], argv.data());
    ::_exit(127);
  }
  running_name_ = name;
  running_pid_ = pid;
  started_ = now;
  terminated_ = false;
  counters_.running = 1;
  log_("post-processing " + name + ": started (" + options_.script + " -> " + out + ", log " +
       log_path + ")");
}

void MissionPostProcessor::Finish(int status, Clock::time_point now) {
  const double seconds = std::chrono::duration<double>(now - started_).count();
  const std::string base = root_ + "/" + running_name_ + kSuffix;
  std::string result;
  bool ok = false;
  if (terminated_) {
    result = "timeout after " + Seconds(seconds);
  } else if (WIFEXITED(status)) {
    ok = WEXITSTATUS(status) == 0;
    result = "exit " + std::to_string(WEXITSTATUS(status)) + " after " + Seconds(seconds);
  } else if (WIFSIGNALED(status)) {
    result = "signal " + std::to_string(WTERMSIG(status)) + " after " + Seconds(seconds);
  }
  try {
    WriteFileAtomically(base + (ok ? ".done" : ".failed"), result + "\n");
  } catch (const std::exception& e) {
    log_("post-processing " + running_name_ + ": cannot write its marker: " + e.what());
  }
  ++(ok ? counters_.succeeded : counters_.failed);
  log_("post-processing " + running_name_ + ": " + (ok ? "ok, " : "FAILED, ") + result +
       (ok ? " -> " + base : "; see " + base + ".log"));
  running_name_.clear();
  running_pid_ = -1;
  counters_.running = 0;
}

void MissionPostProcessor::Poll(Clock::time_point now) {
  if (!enabled()) return;
  if (running_pid_ > 0) {
    int status = 0;
    const pid_t done = ::waitpid(running_pid_, &status, WNOHANG);
    if (done == running_pid_) {
      Finish(status, now);
    } else if (std::chrono::duration<double>(now - started_).count() > options_.timeout_s) {
      // SIGTERM first, SIGKILL 5 s later.
      if (!terminated_) {
        terminated_ = true;
        ::kill(-running_pid_, SIGTERM);
      } else if (std::chrono::duration<double>(now - started_).count() >
                 options_.timeout_s + 5.0) {
        ::kill(-running_pid_, SIGKILL);
      }
    }
  }
  if (running_pid_ < 0 && !queue_.empty()) {
    const std::string name = queue_.front();
    queue_.pop_front();
    Start(name, now);
  }
  counters_.queued = queue_.size();
}

void MissionPostProcessor::Stop() {
  if (running_pid_ <= 0) return;
  ::kill(-running_pid_, SIGTERM);
  for (int i = 0; i < 50; ++i) {
    if (::waitpid(running_pid_, nullptr, WNOHANG) == running_pid_) {
      running_pid_ = -1;
      break;
    }
    std::this_thread::sleep_for(std::chrono::milliseconds(100));
  }
  if (running_pid_ > 0) {
    ::kill(-running_pid_, SIGKILL);
    ::waitpid(running_pid_, nullptr, 0);
  }
  log_("post-processing " + running_name_ + ": stopped (it runs again at the next start)");
  running_pid_ = -1;
  running_name_.clear();
  counters_.running = 0;
}

}  // namespace vilma::mapstore
