#include "vilma/drivers/v4l2/v4l2_driver.h"

#include <chrono>
#include <cstdio>
#include <iostream>
#include <lcm/lcm-cpp.hpp>
#include <memory>

#include "vilma/core/arg_cursor.h"
#include "vilma/core/clock_sync.h"
#include "vilma/core/error.h"
#include "vilma/core/time.h"
#include "vilma/drivers/driver_status.h"
#include "vilma/drivers/lcm_convert.h"
#include "vilma/drivers/lcm_url.h"
#include "vilma/drivers/v4l2/device_list.h"
#include "vilma/drivers/v4l2/fake_v4l2_io.h"
#include "vilma/drivers/v4l2/v4l2_options.h"

#ifdef VILMA_HAVE_SYSTEMD
#include <systemd/sd-daemon.h>
#endif

namespace vilma::v4l2 {
namespace {

constexpr const char kProgram[] = "vilma-v4l2";

void Notify(const char* state) {
#ifdef VILMA_HAVE_SYSTEMD
  sd_notify(0, state);  // a no-op outside systemd (no $NOTIFY_SOCKET)
#else
  (void)state;
#endif
}

int64_t SteadyNowNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

}  // namespace

int64_t PublishedSequence::Next(int64_t kernel_sequence) {
  if (last_kernel_ >= 0 && kernel_sequence <= last_kernel_) {
    // A new stream: continue right after the last published number.
    offset_ = last_published_ + 1 - kernel_sequence;
  } else if (last_kernel_ < 0) {
    offset_ = -kernel_sequence;  // the first frame is seq 0
  }
  last_kernel_ = kernel_sequence;
  last_published_ = kernel_sequence + offset_;
  return last_published_;
}

std::string FrameToMessage(const CapturedFrame& frame, int64_t seq, int32_t camera_id,
                           image_t* msg) {
  const int32_t format = frame.image->type() == CV_16UC1 ? static_cast<int32_t>(image_t::GRAY16)
                                                         : static_cast<int32_t>(image_t::GRAY8);
  const std::string error =
      MakeImageMessage(*frame.image, format, frame.robot_ns, seq, camera_id, msg);
  msg->exposure_us = static_cast<int32_t>(std::min<int64_t>(frame.exposure_us, INT32_MAX));
  return error;
}

int V4l2Main(const std::vector<std::string>& args, const std::atomic<bool>* stop) {
  V4l2DriverOptions options;
  try {
    bool help = false;
    options = ParseV4l2CommandLine(args, &help);
    if (help) {
      std::cout << V4l2Usage();
      return kExitOk;
    }
  } catch (const UsageError& e) {
    std::cerr << kProgram << ": " << e.what() << "\n(see " << kProgram << " --help)\n";
    return kExitUsage;
  } catch (const InputError& e) {  // the options file
    std::cerr << kProgram << ": " << e.what() << "\n";
    return kExitUsage;
  }
  if (options.print_config) {
    std::cout << V4l2OptionsYaml(options);
    return kExitOk;
  }

  std::unique_ptr<V4l2Io> io;
  FakeV4l2Io* fake = nullptr;
  if (options.fake) {
    auto fake_io = std::make_unique<FakeV4l2Io>();
    fake = fake_io.get();
    io = std::move(fake_io);
  } else {
    io = std::make_unique<SystemV4l2Io>();
  }
  if (options.list) {
    int capture_nodes = 0;
    std::cout << ListDevices(io.get(), &capture_nodes);
    return capture_nodes > 0 ? kExitOk : kExitRuntime;
  }

  const std::string url = ResolveLcmUrl(options.lcm_url);
  lcm::LCM lcm(url);
  if (!lcm.good()) {
    std::cerr << kProgram << ": " << FormatInputError("--lcm-url", url, "a URL LCM can open")
              << "\n";
    return kExitRuntime;
  }
  DriverStatus status(kProgram);
  StatusPublisher status_publisher(&status, &lcm, options.StatusChannel(), options.status_period_s);
  auto log = [](const std::string& message) {
    std::cerr << kProgram << ": " << message << std::endl;
  };
  V4l2Capture capture(
      io.get(), options.capture, &status, [] { return MeasureRealtimeMinusMonotonicNs(); }, log);
  try {
    capture.Open();
  } catch (const InputError& e) {
    std::cerr << kProgram << ": " << e.what() << "\n";
    status.SetState(status_t::ERROR, e.what());
    status_publisher.PublishNow();
    return kExitRuntime;
  }
  status_publisher.Start();
  Notify("READY=1");
  if (fake != nullptr && options.fake_unplug_after > 0) {
    fake->UnplugAfterFrames(options.fake_unplug_after, options.fake_unplug_s);
  }
  std::cerr << kProgram << ": publishing " << options.DataChannel() << " (status on "
            << options.StatusChannel() << ")"
            << (capture.by_id_link().empty() ? "" : ", camera " + capture.by_id_link())
            << std::endl;

  const std::string channel = options.DataChannel();
  PublishedSequence sequence;
  image_t msg;
  std::vector<uint8_t> buffer;
  capture.Run(stop, options.seconds, [&](const CapturedFrame& frame) {
    const std::string error =
        FrameToMessage(frame, sequence.Next(frame.sequence), options.camera_id, &msg);
    if (!error.empty()) {
      status.Increment(kStatusMalformed);
      return;
    }
    buffer.resize(static_cast<std::size_t>(msg.getEncodedSize()));
    msg.encode(buffer.data(), 0, static_cast<int>(buffer.size()));
    if (lcm.publish(channel, buffer.data(), static_cast<unsigned>(buffer.size())) != 0) {
      status.Increment(kStatusPublishErrors);
      return;
    }
    const int64_t published_ns = SteadyNowNs();
    // Latency: the frame complete (end of frame, frame_timestamper.h) to the message on the
    // bus, both CLOCK_MONOTONIC (= steady_clock on Linux).
    status.RecordPublished(published_ns, (published_ns - frame.end_of_frame_monotonic_ns) * 1e-6);
  });
  Notify("STOPPING=1");
  status.SetState(status_t::STOPPING, "stopping");
  capture.Close();
  status_publisher.Stop();
  const status_t report = status.Build(SteadyNowNs(), WallClockUtime());
  std::cerr << kProgram << ": stopped:";
  for (int i = 0; i < report.num_counters; ++i) {
    std::cerr << " " << report.counter_names[static_cast<std::size_t>(i)] << "="
              << report.counter_values[static_cast<std::size_t>(i)];
  }
  auto metric = [&report](const char* name) {
    for (int i = 0; i < report.num_metrics; ++i) {
      if (report.metric_names[static_cast<std::size_t>(i)] == name) {
        return report.metric_values[static_cast<std::size_t>(i)];
      }
    }
    return 0.0;
  };
  char latency[128];
  std::snprintf(latency, sizeof(latency), "; latency to publish p50 %.2f ms, p99 %.2f ms",
                metric(kStatusLatencyP50Ms), metric(kStatusLatencyP99Ms));
  std::cerr << latency << std::endl;
  return kExitOk;
}

}  // namespace vilma::v4l2
