// Per-channel message statistics of an LCM bus (the logic of `vilma-lcm-rates`): counts,
// bytes, rates, and lost messages detected from gaps in the `seq` field of vilma.image_t and
// vilma.imu_t (both start with utime, seq after the type hash).
#pragma once

#include <chrono>
#include <cstdint>
#include <map>
#include <string>

namespace vilma {

struct ChannelStats {
  int64_t messages = 0;
  int64_t bytes = 0;
  int64_t lost = 0;           // sum of seq gaps (messages that never arrived)
  int64_t out_of_order = 0;   // seq <= previous seq (duplicates, reordering, publisher restart)
  int64_t last_seq = -1;      // -1 until a sequenced message arrived
  bool sequenced = false;     // the channel carries image_t / imu_t
  double first_s = 0.0, last_s = 0.0;   // arrival times [s, monitor clock]
  int64_t window_messages = 0, window_bytes = 0;  // since the last periodic report
};

class LcmRateMonitor {
 public:
  // Records one message received at `t_s` [s] (any monotonic clock).
  void OnMessage(const std::string& channel, const void* data, int size, double t_s);

  // One line per channel with the rate since the previous call (messages/s, MB/s), then
  // resets the window. `window_s` is the window length [s].
  std::string PeriodicReport(double window_s);
  // The monitor is vilma-lcm-rates' result (core/report.h's shape; ChannelStats is its state):
  // "C channels, N messages, B MB, L lost, O out of order".
  std::string BriefReport() const;
  // The final table: channel, messages, MB, msg/s, MB/s, lost, out of order; then a TOTAL
  // line "TOTAL messages=N bytes=B lost=L out_of_order=O duration_s=D" for scripts.
  std::string FullReport() const;

  int64_t total_messages() const;
  int64_t total_bytes() const;
  int64_t total_lost() const;
  const std::map<std::string, ChannelStats>& channels() const { return channels_; }

 private:
  std::map<std::string, ChannelStats> channels_;
};

}  // namespace vilma
