#include "vilma/drivers/replay.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <condition_variable>
#include <cstdio>
#include <cstdlib>
#include <iostream>
#include <limits>
#include <lcm/lcm-cpp.hpp>
#include <mutex>
#include <sstream>
#include <thread>

#include "vilma/core/error.h"
#include "vilma/core/time.h"
#include "vilma/drivers/lcm_convert.h"
#include "vilma/drivers/lcm_log.h"
#include "vilma/drivers/lcm_url.h"

namespace vilma {

using SteadyClock = std::chrono::steady_clock;

// ---------------------------------------------------------------------------------------------
// Options

std::string ReplayOptions::CameraChannel(int index) const {
  const std::string base =
      (index < static_cast<int>(camera_channels.size()) && !camera_channels[index].empty())
          ? camera_channels[index]
          : "CAM" + std::to_string(index);
  return ChannelName(base, channel_suffix);
}

std::string ReplayOptions::ImuChannel() const { return ChannelName(imu_channel, channel_suffix); }

std::string ReplayOptions::Validate() const {
  if (dataset.empty()) return "no DATASET folder given";
  if (!(rate > 0.0) || !std::isfinite(rate)) return "--rate must be a positive number";
  if (!(fast_max_mb_per_s >= 0.0) || !std::isfinite(fast_max_mb_per_s)) {
    return "--max-mbps must be >= 0 (0 = unlimited)";
  }
  if (!(start_s >= 0.0) || !std::isfinite(start_s)) return "--start must be >= 0 seconds";
  if (end_s >= 0.0 && end_s < start_s) return "--end must not be before --start";
  if (prefetch < 0 || prefetch > 256) return "--prefetch must be in [0, 256]";
  for (const ReplayFault& fault : faults) {
    const std::string error = fault.Validate();
    if (!error.empty()) return "--fault '" + fault.ToString() + "': " + error;
  }
  std::vector<std::string> names = {ImuChannel()};
  for (size_t i = 0; i < std::max<size_t>(camera_channels.size(), 2); ++i) {
    names.push_back(CameraChannel(static_cast<int>(i)));
  }
  for (const std::string& name : names) {
    const std::string error = ValidateChannelName(name);
    if (!error.empty()) return error;
  }
  std::vector<std::string> sorted = names;
  std::sort(sorted.begin(), sorted.end());
  if (std::adjacent_find(sorted.begin(), sorted.end()) != sorted.end()) {
    return "two streams share one channel name";
  }
  return "";
}

std::string ReplayUsage() {
  return R"(Usage: vilma-replay DATASET [options]

Publishes an ASL/EuRoC dataset folder (mav0/cam*/, mav0/imu0/) on LCM: images as GRAY8
vilma.image_t on CAM0, CAM1, ..., IMU samples as vilma.imu_t on IMU, merged in timestamp order
(IMU first on equal stamps), in real time or faster.

Options:
  --rate R            real-time factor (default 1; 2 = twice as fast)
  --fast              ignore timestamps: send as fast as --max-mbps allows
  --max-mbps M        byte-rate cap of --fast [MB/s] (default 100; 0 = unlimited, which
                      overruns UDP receivers: see docs/lcm.md)
  --start S           begin S seconds after the dataset's first stamp (default 0)
  --end S             stop S seconds after the dataset's first stamp (default: the end)
  --lcm-url URL       LCM provider (default $LCM_DEFAULT_URL, else
                      udpm://239.255.76.67:7667?ttl=0)
  --to-log FILE       write an lcm-logger-format log (event time = message utime) instead
                      of publishing; replay it with lcm-logplayer
  --channel-camN NAME channel of camera N (default CAMN), e.g. --channel-cam0 LEFT
  --channel-imu NAME  channel of the IMU (default IMU)
  --channels A,B,..   channels of cam0, cam1, ... in one option
  --channel-suffix S  appended to every channel name (e.g. _REPLAY)
  --prefetch N        images decoded ahead on a worker thread (default 4; 0 = inline)
  --fault SPEC        inject a sensor fault (repeatable; docs/reliability.md), START and
                      DURATION in seconds from the dataset's first stamp:
                        camera-drop:START:DURATION       no images (a silent camera)
                        imu-gap:START:DURATION           no IMU samples
                        time-jump:START:DURATION:OFFSET  stamps + OFFSET s in the window,
                                                         then back (a jump and its return)
                        duplicate:START:DURATION         every message sent twice
                        camera-half-rate:START:DURATION  every second image dropped
  --quiet             print errors only
  --help              this text

Exit status: 0 on success, 1 on a bad dataset or output, 2 on bad options, 3 when some
messages could not be sent.
)";
}

namespace {

bool ParseDouble(const std::string& text, double* value) {
  char* end = nullptr;
  *value = std::strtod(text.c_str(), &end);
  return !text.empty() && end != nullptr && *end == '\0' && std::isfinite(*value);
}

std::vector<std::string> SplitComma(const std::string& text) {
  std::vector<std::string> parts;
  std::stringstream ss(text);
  std::string part;
  while (std::getline(ss, part, ',')) parts.push_back(part);
  return parts;
}

}  // namespace

std::string ParseReplayCommandLine(int argc, const char* const* argv, ReplayOptions* options,
                                   bool* help) {
  *help = false;
  std::vector<std::string> positional;
  for (int i = 1; i < argc; ++i) {
    std::string arg = argv[i];
    std::string value;
    bool has_inline_value = false;
    if (arg.rfind("--", 0) == 0) {
      const size_t eq = arg.find('=');
      if (eq != std::string::npos) {
        value = arg.substr(eq + 1);
        arg = arg.substr(0, eq);
        has_inline_value = true;
      }
    }
    // Fetches the option's value (inline "--x=v" or the next argument).
    auto next = [&](std::string* out) -> bool {
      if (has_inline_value) {
        *out = value;
        return true;
      }
      if (i + 1 >= argc) return false;
      *out = argv[++i];
      return true;
    };
    auto number = [&](double* out) -> std::string {
      std::string text;
      if (!next(&text)) return arg + " needs a value";
      if (!ParseDouble(text, out)) return arg + ": '" + text + "' is not a number";
      return "";
    };
    std::string error;
    std::string text;
    if (arg == "--help" || arg == "-h") {
      *help = true;
      return "";
    } else if (arg == "--fast") {
      options->fast = true;
    } else if (arg == "--quiet") {
      options->verbose = false;
    } else if (arg == "--rate") {
      error = number(&options->rate);
    } else if (arg == "--max-mbps") {
      error = number(&options->fast_max_mb_per_s);
    } else if (arg == "--start") {
      error = number(&options->start_s);
    } else if (arg == "--end") {
      error = number(&options->end_s);
    } else if (arg == "--prefetch") {
      double n = 0;
      error = number(&n);
      if (error.empty() && (n != std::floor(n))) error = "--prefetch needs an integer";
      options->prefetch = static_cast<int>(n);
    } else if (arg == "--fault") {
      ReplayFault fault;
      if (!next(&text)) {
        error = arg + " needs a value";
      } else {
        error = ParseReplayFault(text, &fault);
        if (error.empty()) options->faults.push_back(fault);
      }
    } else if (arg == "--lcm-url") {
      if (!next(&options->lcm_url)) error = arg + " needs a value";
    } else if (arg == "--to-log") {
      if (!next(&options->to_log)) error = arg + " needs a value";
    } else if (arg == "--channel-imu") {
      if (!next(&options->imu_channel)) error = arg + " needs a value";
    } else if (arg == "--channel-suffix") {
      if (!next(&options->channel_suffix)) error = arg + " needs a value";
    } else if (arg == "--channels") {
      if (!next(&text)) {
        error = arg + " needs a value";
      } else {
        options->camera_channels = SplitComma(text);
      }
    } else if (arg.rfind("--channel-cam", 0) == 0) {
      const std::string digits = arg.substr(13);
      const bool ok = !digits.empty() && digits.size() <= 2 &&
                      std::all_of(digits.begin(), digits.end(), ::isdigit);
      if (!ok) {
        error = "unknown option " + arg;
      } else if (!next(&text)) {
        error = arg + " needs a value";
      } else {
        const size_t index = std::stoul(digits);
        if (options->camera_channels.size() <= index) options->camera_channels.resize(index + 1);
        options->camera_channels[index] = text;
      }
    } else if (arg.rfind("-", 0) == 0 && arg != "-") {
      error = "unknown option " + arg;
    } else {
      positional.push_back(arg);
    }
    if (!error.empty()) return error;
  }
  if (positional.size() > 1) return "more than one DATASET given";
  if (positional.size() == 1) options->dataset = positional[0];
  return options->Validate();
}

// ---------------------------------------------------------------------------------------------
// Sinks

namespace {

class LcmSink : public MessageSink {
 public:
  explicit LcmSink(const std::string& url) : lcm_(url) {
    if (!lcm_.good()) {
      throw InputError(FormatInputError("--lcm-url", url, "a URL LCM can open"));
    }
  }
  bool Send(const std::string& channel, const void* data, int size, int64_t) override {
    return lcm_.publish(channel, data, static_cast<unsigned int>(size)) == 0;
  }

 private:
  lcm::LCM lcm_;
};

}  // namespace

std::unique_ptr<MessageSink> MakeLcmSink(const std::string& lcm_url) {
  return std::make_unique<LcmSink>(lcm_url);
}

LogSink::LogSink(const std::string& path) : writer_(std::make_unique<LcmLogWriter>(path)) {}
LogSink::~LogSink() = default;

bool LogSink::Send(const std::string& channel, const void* data, int size, int64_t utime) {
  writer_->Write(channel, data, size, utime);
  return true;
}

void LogSink::Finish() { writer_->Close(); }

// ---------------------------------------------------------------------------------------------
// Replay

namespace {

// Decodes the images of the replay in order on a worker thread, `capacity` ahead of the
// consumer. The bounded buffer keeps memory flat however long the dataset is. (A mutex and a
// condition variable are fine here: one hand-over per image at <= a few hundred Hz.)
class ImagePrefetcher {
 public:
  ImagePrefetcher(std::vector<std::string> paths, int capacity)
      : paths_(std::move(paths)), slots_(static_cast<size_t>(capacity)) {
    worker_ = std::thread([this] { Work(); });
  }
  ~ImagePrefetcher() {
    {
      std::lock_guard<std::mutex> lock(mutex_);
      quit_ = true;
    }
    cv_.notify_all();
    worker_.join();
  }

  // The next image in order; throws InputError if it could not be loaded.
  cv::Mat Next() {
    std::unique_lock<std::mutex> lock(mutex_);
    cv_.wait(lock, [this] { return produced_ > consumed_; });
    Slot& slot = slots_[consumed_ % slots_.size()];
    cv::Mat image = std::move(slot.image);
    const std::string error = std::move(slot.error);
    ++consumed_;
    lock.unlock();
    cv_.notify_all();
    if (!error.empty()) throw InputError(error);
    return image;
  }

 private:
  struct Slot {
    cv::Mat image;
    std::string error;
  };

  void Work() {
    for (size_t k = 0; k < paths_.size(); ++k) {
      {
        std::unique_lock<std::mutex> lock(mutex_);
        cv_.wait(lock, [&] { return quit_ || produced_ - consumed_ < slots_.size(); });
        if (quit_) return;
      }
      Slot loaded;
      try {
        loaded.image = AslDataset::LoadImage(paths_[k]);
      } catch (const std::exception& e) {
        loaded.error = e.what();
      }
      {
        std::lock_guard<std::mutex> lock(mutex_);
        slots_[k % slots_.size()] = std::move(loaded);
        ++produced_;
      }
      cv_.notify_all();
    }
  }

  std::vector<std::string> paths_;
  std::vector<Slot> slots_;
  size_t produced_ = 0;
  size_t consumed_ = 0;
  bool quit_ = false;
  std::mutex mutex_;
  std::condition_variable cv_;
  std::thread worker_;
};

double Seconds(SteadyClock::duration d) { return std::chrono::duration<double>(d).count(); }

}  // namespace

ReplaySummary RunReplay(const AslDataset& dataset, const ReplayOptions& options,
                        MessageSink* sink, const std::atomic<bool>* stop) {
  const std::vector<AslCamera>& cameras = dataset.cameras();
  const std::vector<ImuSample>& imu = dataset.imu();

  // The dataset's first stamp over all streams: --start/--end count from it.
  int64_t t_first = std::numeric_limits<int64_t>::max();
  for (const AslCamera& camera : cameras) {
    if (!camera.frames.empty()) t_first = std::min(t_first, camera.frames.front().t_ns);
  }
  if (!imu.empty()) t_first = std::min(t_first, imu.front().t_ns);

  ReplaySummary summary;
  summary.channels.push_back({options.ImuChannel(), 0, 0});
  for (size_t c = 0; c < cameras.size(); ++c) {
    summary.channels.push_back({options.CameraChannel(static_cast<int>(c)), 0, 0});
  }
  if (t_first == std::numeric_limits<int64_t>::max()) return summary;  // nothing to replay

  const int64_t t_begin = t_first + SecondsToNs(options.start_s);
  const int64_t t_end = options.end_s < 0 ? std::numeric_limits<int64_t>::max()
                                          : t_first + SecondsToNs(options.end_s);

  // Merge of all streams by stamp, the IMU before the cameras at equal stamps (asl_dataset.h).
  std::vector<int> all_cameras(cameras.size());
  for (size_t c = 0; c < cameras.size(); ++c) all_cameras[c] = static_cast<int>(c);
  const std::vector<AslEvent> events = ArrivalOrder(dataset, all_cameras, t_begin, t_end);
  if (events.empty()) return summary;
  summary.data_s = NsToSeconds(events.back().t_ns - events.front().t_ns);

  std::vector<std::string> image_paths;
  for (const AslEvent& e : events) {
    if (e.stream >= 0) image_paths.push_back(cameras[e.stream].frames[e.index].image_path);
  }
  std::unique_ptr<ImagePrefetcher> prefetcher;
  if (options.prefetch > 0 && !image_paths.empty()) {
    prefetcher = std::make_unique<ImagePrefetcher>(image_paths, options.prefetch);
  }
  size_t next_image = 0;

  std::vector<int64_t> seq(cameras.size() + 1, 0);  // [0] = IMU, [1 + c] = camera c
  std::vector<uint8_t> buffer;  // encoded message, reused (no allocation once grown)
  image_t image_msg;
  const double bytes_per_s = options.fast_max_mb_per_s * 1e6;
  const SteadyClock::time_point anchor = SteadyClock::now();
  SteadyClock::duration image_wait{0};
  double max_lateness_s = 0.0;

  for (const AslEvent& e : events) {
    if (stop != nullptr && stop->load()) {
      summary.interrupted = true;
      break;
    }
    const size_t slot = static_cast<size_t>(e.stream + 1);
    const ReplayFaultAction fault =
        ReplayFaultActionFor(options.faults, t_first, e.stream, e.t_ns, seq[slot]);
    int64_t utime = 0;
    if (e.stream < 0) {
      ImuSample sample = imu[e.index];
      sample.t_ns += fault.stamp_offset_ns;
      const imu_t msg = ImuToMessage(sample, seq[0]);
      utime = msg.utime;
      buffer.resize(static_cast<size_t>(msg.getEncodedSize()));
      msg.encode(buffer.data(), 0, static_cast<int>(buffer.size()));
    } else {
      // Load (or collect the prefetched image) before the deadline, so that the send itself
      // is on time.
      const SteadyClock::time_point wait_start = SteadyClock::now();
      const cv::Mat image = prefetcher ? prefetcher->Next()
                                       : AslDataset::LoadImage(image_paths[next_image]);
      image_wait += SteadyClock::now() - wait_start;
      ++next_image;
      const std::string error = MakeImageMessage(image, image_t::GRAY8, e.t_ns + fault.stamp_offset_ns,
                                                 seq[slot], e.stream, &image_msg);
      if (!error.empty()) {
        throw InputError(FormatInputError(cameras[e.stream].frames[e.index].image_path, "",
                                          "an 8-bit image (" + error + ")"));
      }
      utime = image_msg.utime;
      buffer.resize(static_cast<size_t>(image_msg.getEncodedSize()));
      image_msg.encode(buffer.data(), 0, static_cast<int>(buffer.size()));
    }

    if (options.to_log.empty()) {
      // Absolute deadlines from one anchor: no drift accumulates.
      double offset_s = 0.0;
      bool paced = true;
      if (!options.fast) {
        offset_s = NsToSeconds(e.t_ns - events.front().t_ns) / options.rate;
      } else if (bytes_per_s > 0.0) {
        offset_s = static_cast<double>(summary.bytes) / bytes_per_s;
      } else {
        paced = false;
      }
      if (paced) {
        const SteadyClock::time_point deadline =
            anchor + std::chrono::duration_cast<SteadyClock::duration>(
                         std::chrono::duration<double>(offset_s));
        const SteadyClock::time_point now = SteadyClock::now();
        if (now < deadline) {
          std::this_thread::sleep_until(deadline);
        } else {
          max_lateness_s = std::max(max_lateness_s, Seconds(now - deadline));
        }
      }
    }

    const std::string& channel = summary.channels[slot].channel;
    if (fault.copies == 0) ++summary.fault_dropped;
    if (fault.copies > 1) summary.fault_duplicated += fault.copies - 1;
    if (fault.copies > 0 && fault.stamp_offset_ns != 0) ++summary.fault_shifted;
    for (int copy = 0; copy < fault.copies; ++copy) {
      if (!sink->Send(channel, buffer.data(), static_cast<int>(buffer.size()), utime)) {
        ++summary.send_failures;
      }
      ++summary.channels[slot].messages;
      summary.channels[slot].bytes += static_cast<int64_t>(buffer.size());
      ++summary.messages;
      summary.bytes += static_cast<int64_t>(buffer.size());
    }
    ++seq[slot];
  }
  summary.wall_s = Seconds(SteadyClock::now() - anchor);
  summary.max_lateness_ms = max_lateness_s * 1e3;
  summary.image_wait_ms = Seconds(image_wait) * 1e3;
  return summary;
}

std::string ReplaySummary::BriefReport() const {
  char line[256];
  std::snprintf(line, sizeof(line),
                "%lld messages, %.2f MB, data span %.3f s, wall time %.3f s, %lld send "
                "failures%s",
                static_cast<long long>(messages), bytes * 1e-6, data_s, wall_s,
                static_cast<long long>(send_failures), interrupted ? ", INTERRUPTED" : "");
  return line;
}

std::string ReplaySummary::FullReport() const {
  std::ostringstream out;
  char line[256];
  std::snprintf(line, sizeof(line), "%-20s %10s %10s %10s %10s\n", "channel", "messages", "MB",
                "msg/s", "MB/s");
  out << line;
  const double wall = wall_s > 0 ? wall_s : 1e-9;
  for (const ReplayChannelSummary& c : channels) {
    std::snprintf(line, sizeof(line), "%-20s %10lld %10.2f %10.1f %10.2f\n", c.channel.c_str(),
                  static_cast<long long>(c.messages), c.bytes * 1e-6, c.messages / wall,
                  c.bytes * 1e-6 / wall);
    out << line;
  }
  std::snprintf(line, sizeof(line), "%-20s %10lld %10.2f %10.1f %10.2f\n", "total",
                static_cast<long long>(messages), bytes * 1e-6, messages / wall,
                bytes * 1e-6 / wall);
  out << line;
  std::snprintf(line, sizeof(line),
                "data span %.3f s, wall time %.3f s (x%.2f real time), max lateness %.2f ms, "
                "waited %.1f ms for images, %lld send failures%s\n",
                data_s, wall_s, wall_s > 0 ? data_s / wall_s : 0.0, max_lateness_ms,
                image_wait_ms, static_cast<long long>(send_failures),
                interrupted ? ", INTERRUPTED" : "");
  out << line;
  if (fault_dropped + fault_duplicated + fault_shifted > 0) {
    std::snprintf(line, sizeof(line),
                  "faults: %lld messages dropped, %lld duplicates sent, %lld stamps shifted\n",
                  static_cast<long long>(fault_dropped), static_cast<long long>(fault_duplicated),
                  static_cast<long long>(fault_shifted));
    out << line;
  }
  return out.str();
}

int ReplayMain(int argc, const char* const* argv, const std::atomic<bool>* stop) {
  ReplayOptions options;
  bool help = false;
  const std::string error = ParseReplayCommandLine(argc, argv, &options, &help);
  if (help) {
    std::cout << ReplayUsage();
    return 0;
  }
  if (!error.empty()) {
    std::cerr << "vilma-replay: " << error << "\n(see vilma-replay --help)\n";
    return 2;
  }
  try {
    const AslDataset dataset = AslDataset::Open(options.dataset);
    if (options.verbose) {
      for (const std::string& warning : dataset.warnings()) {
        std::cerr << "vilma-replay: warning: " << warning << "\n";
      }
    }
    if (dataset.cameras().empty() && dataset.imu().empty()) {
      std::cerr << "vilma-replay: " << options.dataset << ": no camera or IMU data\n";
      return 1;
    }
    ReplaySummary summary;
    if (!options.to_log.empty()) {
      LogSink sink(options.to_log);
      summary = RunReplay(dataset, options, &sink, stop);
      sink.Finish();
    } else {
      const std::string url = ResolveLcmUrl(options.lcm_url);
      std::unique_ptr<MessageSink> sink = MakeLcmSink(url);
      if (options.verbose) std::cout << "vilma-replay: publishing on " << url << "\n";
      summary = RunReplay(dataset, options, sink.get(), stop);
    }
    if (options.verbose) {
      std::cout << "vilma-replay: " << options.dataset
                << (options.to_log.empty() ? "" : " -> " + options.to_log) << "\n"
                << summary.FullReport();
      std::cout.flush();
    }
    return summary.send_failures > 0 ? 3 : 0;
  } catch (const std::exception& e) {
    std::cerr << "vilma-replay: error: " << e.what() << "\n";
    return 1;
  }
}

}  // namespace vilma
