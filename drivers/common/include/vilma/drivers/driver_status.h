// Health of a sensor driver (vilma-v4l2, vilma-aravis, vilma-usb-imu), published as a
// vilma.status_t on VILMA_STATUS_<CHANNEL> at about 1 Hz (architecture.md sections 2 and 9).
//
// DriverStatus is a thread-safe set of named int64 counters and double metrics plus a state
// (status_t::STARTING / OK / DEGRADED / ERROR / STOPPING) and a message. The capture thread
// counts; a status thread (StatusPublisher) builds and publishes the report. One mutex guards
// everything: drivers update it a few hundred times per second at most, far from contention.
//
// Every driver reports the standard counters below (always present, 0 until counted) and the
// metrics rate_hz, latency_p50_ms, latency_p99_ms computed from RecordPublished(); it may add
// its own counters and metrics (names: lower case, digits and '_').
#pragma once

#include <atomic>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <mutex>
#include <string>
#include <thread>
#include <utility>
#include <vector>

#include <vilma/status_t.hpp>

namespace lcm {
class LCM;
}

namespace vilma {

// Standard counter names shared by all drivers.
constexpr const char kStatusPublished[] = "published";                // frames / samples sent
constexpr const char kStatusDropped[] = "dropped";                    // gaps in device seq numbers
constexpr const char kStatusMalformed[] = "malformed";                // bad frames / checksum errors
constexpr const char kStatusReconnects[] = "reconnects";              // device lost and reopened
constexpr const char kStatusTimestampResets[] = "timestamp_resets";   // clock jumps (ClockSync)
constexpr const char kStatusPublishErrors[] = "publish_errors";       // lcm publish failed
// Standard metric names.
constexpr const char kStatusRateHz[] = "rate_hz";                 // publish rate over rate window
constexpr const char kStatusLatencyP50Ms[] = "latency_p50_ms";    // capture -> publish [ms]
constexpr const char kStatusLatencyP99Ms[] = "latency_p99_ms";

// "VILMA_STATUS_" + data channel base name, e.g. "CAM0" -> "VILMA_STATUS_CAM0" (the channel
// suffix is applied afterwards, like to every channel: ChannelName in lcm_url.h).
std::string DefaultStatusChannel(const std::string& data_channel_base);

struct DriverStatusOptions {
  // Publishes older than this do not count in rate_hz [s] (a stalled driver shows 0 Hz after it).
  double rate_window_s = 2.0;
  // Number of latest latencies that latency_p50_ms / latency_p99_ms are taken over.
  int latency_window = 512;

  // "" or "field: expectation".
  std::string Validate() const;
};

class DriverStatus {
 public:
  // `node`: the program name written into every report (e.g. "vilma-aravis").
  explicit DriverStatus(std::string node, const DriverStatusOptions& options = {});

  const std::string& node() const { return node_; }

  // Counters: created on first use (at the end of the report's list), never removed.
  void Increment(const std::string& name, int64_t by = 1);
  void SetCounter(const std::string& name, int64_t value);
  int64_t Counter(const std::string& name) const;  // 0 if never set

  // Metrics: last value wins.
  void SetMetric(const std::string& name, double value);
  double Metric(const std::string& name) const;  // 0 if never set (or computed, see Build)

  void SetState(int32_t state, const std::string& message);
  int32_t state() const;
  std::string message() const;

  // One frame/sample published: counts `published`, remembers the publish time
  // `publish_steady_ns` (CLOCK_MONOTONIC / std::chrono::steady_clock [ns]) for rate_hz and
  // the capture-to-publish latency [ms] for the percentiles (negative latency: not recorded).
  void RecordPublished(int64_t publish_steady_ns, double latency_ms);

  // The report at `now_steady_ns` (for the rate window), stamped `utime` [us, wall clock]:
  // state, message, every counter in creation order, then every metric with rate_hz,
  // latency_p50_ms, latency_p99_ms filled from RecordPublished().
  status_t Build(int64_t now_steady_ns, int64_t utime) const;

 private:
  // Index of `name` in names, appended with value 0 if new (caller holds mutex_).
  template <typename T>
  static std::size_t Slot(std::vector<std::pair<std::string, T>>* entries, const std::string& name);

  const std::string node_;
  const DriverStatusOptions options_;
  mutable std::mutex mutex_;
  int32_t state_ = status_t::STARTING;
  std::string message_ = "starting";
  std::vector<std::pair<std::string, int64_t>> counters_;
  std::vector<std::pair<std::string, double>> metrics_;
  std::deque<int64_t> publish_times_ns_;  // within rate_window_s of the latest publish
  std::vector<double> latencies_ms_;      // ring of latency_window entries
  std::size_t latency_next_ = 0;
  std::size_t latency_count_ = 0;
};

// Publishes a DriverStatus on `channel` every `period_s` from its own thread until Stop(),
// which publishes a last report (state STOPPING unless the driver set ERROR). lcm::LCM's
// publish may be called from several threads (LCM guards its transmit path with a mutex).
class StatusPublisher {
 public:
  StatusPublisher(const DriverStatus* status, lcm::LCM* lcm, std::string channel,
                  double period_s = 1.0);
  ~StatusPublisher();
  StatusPublisher(const StatusPublisher&) = delete;
  StatusPublisher& operator=(const StatusPublisher&) = delete;

  void Start();
  // Idempotent; publishes the final report.
  void Stop();
  // Publishes one report now (also what the thread does); false if LCM refused it.
  bool PublishNow() const;
  int64_t published() const { return published_.load(); }

 private:
  void Run();

  const DriverStatus* status_;
  lcm::LCM* lcm_;
  const std::string channel_;
  const double period_s_;
  std::thread thread_;
  std::mutex mutex_;
  std::condition_variable wake_;
  bool stop_ = false;
  bool running_ = false;
  mutable std::atomic<int64_t> published_{0};
};

}  // namespace vilma
