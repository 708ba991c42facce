// Helpers for integration tests that start real processes (the built executables, lcm-logger,
// lcm-spy) and talk LCM on loopback.
#pragma once

#include <fcntl.h>
#include <signal.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <chrono>
#include <cstdlib>
#include <fstream>
#include <sstream>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

namespace vilma {
namespace test {

// A child process in its own process group (so that wrappers such as xvfb-run are stopped with
// all their children), stdout and stderr to `output_path`. Killed (SIGKILL) on destruction if
// still running, so a failing test leaves no process behind.
class ChildProcess {
 public:
  ChildProcess(const std::vector<std::string>& argv, const std::string& output_path,
               const std::vector<std::string>& env = {}) {
    pid_ = ::fork();
    if (pid_ < 0) throw std::runtime_error("fork failed");
    if (pid_ == 0) {
      ::setpgid(0, 0);
      const int fd = ::open(output_path.c_str(), O_WRONLY | O_CREAT | O_TRUNC, 0644);
      if (fd >= 0) {
        ::dup2(fd, 1);
        ::dup2(fd, 2);
        ::close(fd);
      }
      for (const std::string& kv : env) ::putenv(const_cast<char*>(kv.c_str()));
      std::vector<char*> args;
      for (const std::string& a : argv) args.push_back(const_cast<char*>(a.c_str()));
      args.push_back(nullptr);
      ::execvp(args[0], args.data());
      ::_exit(127);
    }
    ::setpgid(pid_, pid_);  // also from the parent: no race with Signal()
  }
  ~ChildProcess() {
    if (running()) {
      Signal(SIGKILL);
      Wait(5.0);
    }
  }
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  bool running() {
    if (exited_) return false;
    int status = 0;
    if (::waitpid(pid_, &status, WNOHANG) == pid_) {
      exited_ = true;
      status_ = WIFEXITED(status) ? WEXITSTATUS(status) : 128 + WTERMSIG(status);
    }
    return !exited_;
  }
  // Signals the whole process group.
  void Signal(int sig) {
    if (!exited_) ::kill(-pid_, sig);
  }
  // Exit status (128 + signal if killed), or -1 if still running after `timeout_s`.
  int Wait(double timeout_s) {
    const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    while (running()) {
      if (std::chrono::steady_clock::now() > deadline) return -1;
      std::this_thread::sleep_for(std::chrono::milliseconds(10));
    }
    return status_;
  }
  pid_t pid() const { return pid_; }

 private:
  pid_t pid_ = -1;
  bool exited_ = false;
  int status_ = -1;
};

inline std::string ReadTextFile(const std::string& path) {
  std::ifstream in(path);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// Polls `path` until it contains `needle` or `timeout_s` passes.
inline bool WaitForOutput(const std::string& path, const std::string& needle, double timeout_s) {
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
  while (std::chrono::steady_clock::now() < deadline) {
    if (ReadTextFile(path).find(needle) != std::string::npos) return true;
    std::this_thread::sleep_for(std::chrono::milliseconds(50));
  }
  return false;
}

inline bool FileExists(const std::string& path) {
  struct stat st;
  return ::stat(path.c_str(), &st) == 0;
}

inline long long FileSize(const std::string& path) {
  struct stat st;
  return ::stat(path.c_str(), &st) == 0 ? static_cast<long long>(st.st_size) : -1;
}

// True if `program` is an executable on $PATH (or an executable path).
inline bool HaveProgram(const std::string& program) {
  if (program.find('/') != std::string::npos) return ::access(program.c_str(), X_OK) == 0;
  const char* path = std::getenv("PATH");
  std::stringstream ss(path ? path : "/usr/bin:/bin");
  std::string dir;
  while (std::getline(ss, dir, ':')) {
    if (!dir.empty() && ::access((dir + "/" + program).c_str(), X_OK) == 0) return true;
  }
  return false;
}

// An LCM URL on loopback (ttl=0) with a port of its own per test and per process, so that
// tests running in parallel (ctest -j) or twice on one host do not hear each other.
inline std::string UniqueLcmUrl(bool large_messages = true) {
  static int counter = 0;
  const int port = 20000 + static_cast<int>((::getpid() * 31 + 17 * counter++) % 30000);
  std::string url = "udpm://239.255.76.67:" + std::to_string(port) + "?ttl=0";
  if (large_messages) url += "&recv_buf_size=8388608";  // docs/lcm.md
  return url;
}

// A scratch folder for this test process under /tmp.
inline std::string ScratchDir() {
  const std::string dir = "/tmp/vilma_integration_" + std::to_string(::getpid());
  ::mkdir(dir.c_str(), 0755);
  return dir;
}

}  // namespace test
}  // namespace vilma
