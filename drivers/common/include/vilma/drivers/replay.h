// Replay of an ASL/EuRoC dataset folder as vilma LCM messages (the logic of `vilma-replay`).
//
// All streams (cam0, cam1, ..., imu0) are merged into one sequence ordered by timestamp; on
// equal stamps IMU goes first, then cameras by index, so a consumer that waits for the IMU up
// to a frame's time has it. Images are GRAY8 image_t (camera_id = index of the camera folder),
// IMU samples are imu_t; each stream has its own seq counter starting at 0.
//
// Pacing: message i is sent at  anchor + (t_i - t_first) / rate  on the steady clock, with
// `anchor` taken once at the start: sleeping until absolute deadlines does not accumulate
// drift, and a late message (slow disk) is sent at once and the schedule catches up. With
// `fast` the schedule is instead  anchor + bytes_before_i / fast_max_bytes_per_s  (a byte-rate
// cap; unlimited if 0), because an unpaced publisher of 361 KB images overruns UDP receivers
// (docs/lcm.md, docs/benchmarks.md).
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "vilma/core/asl_dataset.h"
#include "vilma/drivers/replay_faults.h"

namespace vilma {

struct ReplayOptions {
  std::string dataset;       // ASL folder (containing mav0/, or mav0 itself)
  double rate = 1.0;         // real-time factor (> 0); 2 = twice as fast as recorded
  bool fast = false;         // ignore timestamps, send as fast as the byte-rate cap allows
  // Byte-rate cap in fast mode [MB/s, 1 MB = 1e6 bytes]; 0 = unlimited. The default keeps a
  // receiver with recv_buf_size=8 MB loss-free on loopback (docs/benchmarks.md).
  double fast_max_mb_per_s = 100.0;
  double start_s = 0.0;      // first message: seconds after the dataset's first stamp
  double end_s = -1.0;       // last message: seconds after the first stamp; < 0 = to the end
  std::string lcm_url;       // "" = $LCM_DEFAULT_URL or LCM's default (ttl=0)
  std::string to_log;        // if set, write this lcm-logger-format log instead of publishing
  // Channel of camera i: camera_channels[i] if given and not empty, else "CAM<i>".
  std::vector<std::string> camera_channels;
  std::string imu_channel = "IMU";
  std::string channel_suffix;  // appended to every channel name
  int prefetch = 4;  // images decoded ahead on a worker thread; 0 = decode inline
  bool verbose = true;  // print warnings and the summary
  // Injected sensor faults (--fault, replay_faults.h); empty = a faithful replay.
  std::vector<ReplayFault> faults;

  // Empty if valid, else what is wrong.
  std::string Validate() const;
  // Channel name of camera `index` (suffix included).
  std::string CameraChannel(int index) const;
  std::string ImuChannel() const;
};

// Command line of vilma-replay. Returns an error message (empty on success); sets *help when
// --help was given.
std::string ParseReplayCommandLine(int argc, const char* const* argv, ReplayOptions* options,
                                   bool* help);
std::string ReplayUsage();

// Where replayed messages go: an LCM instance or a log file (or a test's recorder).
class MessageSink {
 public:
  virtual ~MessageSink() = default;
  // Returns false if the message could not be sent (counted, replay goes on).
  virtual bool Send(const std::string& channel, const void* data, int size, int64_t utime) = 0;
};

// Publishes on LCM. Throws InputError if the URL cannot be opened.
std::unique_ptr<MessageSink> MakeLcmSink(const std::string& lcm_url);
// Writes an lcm-logger-format log with event timestamp = utime; Finish() renames it into
// place. Throws InputError.
class LcmLogWriter;
class LogSink : public MessageSink {
 public:
  explicit LogSink(const std::string& path);
  ~LogSink() override;
  bool Send(const std::string& channel, const void* data, int size, int64_t utime) override;
  void Finish();

 private:
  std::unique_ptr<LcmLogWriter> writer_;
};

struct ReplayChannelSummary {
  std::string channel;
  int64_t messages = 0;
  int64_t bytes = 0;  // encoded message bytes
};

struct ReplaySummary {
  std::vector<ReplayChannelSummary> channels;
  int64_t messages = 0;
  int64_t bytes = 0;
  int64_t send_failures = 0;
  int64_t fault_dropped = 0;     // messages not sent because of --fault
  int64_t fault_duplicated = 0;  // extra copies sent because of --fault
  int64_t fault_shifted = 0;     // messages sent with a shifted stamp (--fault time-jump)
  double wall_s = 0.0;           // steady-clock duration of the replay [s]
  double data_s = 0.0;           // time span of the replayed stamps [s]
  double max_lateness_ms = 0.0;  // worst delay of a send after its deadline [ms] (paced modes)
  double image_wait_ms = 0.0;    // total time spent waiting for decoded images [ms]
  bool interrupted = false;

  // One line: messages, MB, data span, wall time (core/report.h's shape).
  std::string BriefReport() const;
  // A human-readable table: messages, MB, duration, rates.
  std::string FullReport() const;
};

// Replays `dataset` into `sink`. Stops early when *stop becomes true (SIGINT). Throws
// InputError if an image cannot be read.
ReplaySummary RunReplay(const AslDataset& dataset, const ReplayOptions& options,
                        MessageSink* sink, const std::atomic<bool>* stop = nullptr);

// The whole program behind `vilma-replay` (opens the dataset, the sink, runs, prints);
// returns the process exit status. Never exits itself.
int ReplayMain(int argc, const char* const* argv, const std::atomic<bool>* stop);

}  // namespace vilma
