// End-of-run processing of finished missions (maplab's ROVIOLI saves an optimized, loop-closed,
// summarized map at the end of a run; docs/mapstore.md "Post-processing"): vilma-mapstored runs
// a console script (`vilma console --script FILE --var map=<mission folder> --var
// out=<mission folder>.processed --var name=<name>`) on every mission folder under its root,
// one at a time, as a child process — off the receiving path, with its own log.
//
// The raw mission folder is never written: the script saves its result to ${out}. A marker
// `<name>.processed.done` (or `.failed`, with the exit status) is written atomically when the
// child ends; a folder without a marker is (re)processed, so a crash or kill -9 of mapstored or
// of the script during processing loses nothing and repeats the job at the next start.
#pragma once

#include <sys/types.h>

#include <chrono>
#include <deque>
#include <functional>
#include <string>

namespace vilma::mapstore {

struct PostProcessOptions {
  std::string script;         // console script; "" = no post-processing
  std::string vilma_program;  // the `vilma` executable
  double timeout_s = 3600.0;  // a job running longer is stopped (SIGTERM, then SIGKILL) [s]
  std::string Validate() const;  // "" or "field: expectation"
};

struct PostProcessCounters {
  uint64_t queued = 0;     // waiting
  uint64_t running = 0;    // 0 or 1
  uint64_t succeeded = 0;
  uint64_t failed = 0;     // non-zero exit, signal or timeout
};

class MissionPostProcessor {
 public:
  using Clock = std::chrono::steady_clock;
  using Logger = std::function<void(const std::string&)>;

  // Throws std::invalid_argument for invalid options (an enabled script that does not exist,
  // a program that is not executable).
  MissionPostProcessor(std::string root, PostProcessOptions options, Logger log);
  // Stops a running job (no marker: it runs again next time).
  ~MissionPostProcessor();

  bool enabled() const { return !options_.script.empty(); }
  // Queues every map folder under the root that has no marker and is not queued or running
  // (sorted by name). Cheap: one directory listing.
  void Scan();
  // Reaps a finished job (writes its marker, logs the result), stops one past its timeout,
  // starts the next queued one. Call it from the main loop.
  void Poll(Clock::time_point now = Clock::now());
  // Stops the running job without a marker and waits for it.
  void Stop();
  const PostProcessCounters& counters() const { return counters_; }

 private:
  void Start(const std::string& name, Clock::time_point now);
  void Finish(int status, Clock::time_point now);

  std::string root_;
  PostProcessOptions options_;
  Logger log_;
  std::deque<std::string> queue_;
  std::string running_name_;
  pid_t running_pid_ = -1;
  Clock::time_point started_;
  bool terminated_ = false;
  PostProcessCounters counters_;
};

}  // namespace vilma::mapstore
