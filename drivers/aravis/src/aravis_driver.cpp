#include "vilma/drivers/aravis/aravis_driver.h"

#include <systemd/sd-daemon.h>
#include <time.h>

#include <algorithm>
#include <cstdio>
#include <cstdlib>
#include <cmath>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <memory>
#include <ostream>
#include <sstream>
#include <stdexcept>
#include <thread>

#include "vilma/drivers/aravis/aravis_camera.h"
#include "vilma/drivers/aravis/frame_timing.h"
#include "vilma/drivers/driver_status.h"
#include "vilma/drivers/lcm_convert.h"

namespace vilma::aravis {
namespace {

int64_t ClockNs(clockid_t clock) {
  timespec ts{};
  clock_gettime(clock, &ts);
  return static_cast<int64_t>(ts.tv_sec) * 1000000000 + ts.tv_nsec;
}
int64_t SteadyNs() { return ClockNs(CLOCK_MONOTONIC); }
int64_t RealtimeNs() { return ClockNs(CLOCK_REALTIME); }

constexpr const char kProgram[] = "vilma-aravis";

// Stream counters summed over every connection (a reopened camera's stream starts at 0).
class StreamCounterTotals {
 public:
  void Update(const std::vector<std::pair<std::string, uint64_t>>& current) { current_ = current; }
  // The connection ended: its counts become part of the totals.
  void EndConnection() {
    for (const auto& [name, value] : current_) done_[name] += value;
    current_.clear();
  }
  // "completed_buffers=60 failures=0 ..." for the log.
  std::string Text() const {
    std::map<std::string, uint64_t> total = done_;
    for (const auto& [name, value] : current_) total[name] += value;
    std::string text;
    for (const auto& [name, value] : total) {
      if (value == 0) continue;
      text += (text.empty() ? "" : " ") + (name.rfind("n_", 0) == 0 ? name.substr(2) : name) +
              "=" + std::to_string(value);
    }
    return text;
  }
  void Report(DriverStatus* status) const {
    std::map<std::string, uint64_t> total = done_;
    for (const auto& [name, value] : current_) total[name] += value;
    for (const auto& [name, value] : total) {
      // "n_missing_packets" -> "stream_missing_packets"
      const std::string key = name.rfind("n_", 0) == 0 ? name.substr(2) : name;
      status->SetCounter("stream_" + key, static_cast<int64_t>(value));
    }
  }

 private:
  std::map<std::string, uint64_t> done_;
  std::vector<std::pair<std::string, uint64_t>> current_;
};

// Opens, configures and starts the camera; throws std::runtime_error.
std::unique_ptr<AravisCamera> OpenCamera(const AravisOptions& options) {
  const std::vector<CameraInfo> cameras = DiscoverCameras(options.fake);
  CameraInfo info;
  const std::string error = FindCamera(cameras, options.device, &info);
  if (!error.empty()) throw std::runtime_error(error);
  auto camera = std::make_unique<AravisCamera>(info, options);
  camera->Start();
  return camera;
}

}  // namespace

std::string ListCameras(const AravisOptions& options, std::string* error) {
  const std::vector<CameraInfo> cameras = DiscoverCameras(options.fake);
  std::ostringstream out;
  out << cameras.size() << " camera(s)\n";
  for (const CameraInfo& c : cameras) {
    out << "  " << c.id << "  vendor '" << c.vendor << "' model '" << c.model << "' serial '"
        << c.serial << "' protocol " << c.protocol << " physical id '" << c.physical_id << "'";
    if (!c.address.empty()) out << " address " << c.address;
    out << "\n";
  }
  CameraInfo info;
  *error = FindCamera(cameras, options.device, &info);
  if (error->empty()) out << DescribeCamera(info);
  return out.str();
}

AravisRunSummary RunAravisDriver(const AravisOptions& options, lcm::LCM* lcm,
                                 const std::atomic<bool>* stop, std::ostream* log) {
  AravisRunSummary summary;
  DriverStatus status(kProgram);
  StatusPublisher status_publisher(&status, lcm, options.StatusChannel(), options.status_period_s);
  status_publisher.Start();
  const std::string channel = options.DataChannel();
  const char* notify_socket = std::getenv("NOTIFY_SOCKET");
  const bool notify = notify_socket != nullptr && notify_socket[0] != '\0';
  uint64_t watchdog_usec = 0;
  if (notify && sd_watchdog_enabled(0, &watchdog_usec) <= 0) watchdog_usec = 0;

  FrameStampOptions stamp_options;
  stamp_options.use_device_clock = options.timestamp_source == "device";
  stamp_options.stamp_is_exposure_start = options.timestamp_event == "exposure_start";
  stamp_options.time_offset_ns = std::llround(options.time_offset_us * 1e3);
  stamp_options.transport_latency_ns = std::llround(options.transport_latency_us * 1e3);
  FrameStamper stamper(stamp_options, options.clock_sync);
  ConvertOptions convert;
  convert.keep_16bit = options.keep_16bit;
  convert.keep_bayer = options.keep_bayer;

  std::unique_ptr<AravisCamera> camera;
  try {
    camera = OpenCamera(options);
  } catch (const std::exception& e) {
    summary.error = e.what();
    status.SetState(status_t::ERROR, summary.error);
    status_publisher.Stop();
    return summary;
  }
  FrameIdTracker ids(camera->frame_ids_wrap_16bit());
  *log << kProgram << ": streaming " << camera->info().id << " (" << camera->info().vendor << " "
       << camera->info().model << "), " << camera->width() << "x" << camera->height() << " "
       << camera->pixel_format() << " at " << camera->frame_rate_hz() << " Hz on " << channel
       << ", status on " << options.StatusChannel() << std::endl;
  status.SetState(status_t::OK, "streaming " + camera->info().id);
  if (notify) sd_notify(0, "READY=1");

  const bool software_trigger = options.trigger && options.trigger_source == "Software";
  const int64_t trigger_period_ns =
      software_trigger ? std::llround(1e9 / options.frame_rate_hz) : 0;
  const int64_t start_ns = SteadyNs();
  const int64_t end_ns =
      options.seconds > 0.0 ? start_ns + std::llround(options.seconds * 1e9) : INT64_MAX;
  const int64_t frame_timeout_ns = std::llround(options.frame_timeout_s * 1e9);
  const bool auto_exposure = options.exposure_auto != "off";
  double exposure_us = camera->ReadExposureUs();
  int64_t exposure_read_ns = SteadyNs();
  int64_t last_frame_ns = SteadyNs();
  int64_t next_trigger_ns = SteadyNs();
  int64_t next_counters_ns = 0;
  int64_t next_reconnect_ns = 0;
  int64_t last_watchdog_ns = 0;
  bool fault_done = false;
  StreamCounterTotals stream_totals;
  CameraFrame frame;
  image_t msg;
  cv::Mat image;

  auto lose_camera = [&](const std::string& why) {
    *log << kProgram << ": camera lost (" << why << "), reconnecting every "
         << options.reconnect_interval_s << " s" << std::endl;
    stream_totals.Update(camera->StreamCounters());
    stream_totals.EndConnection();
    camera.reset();
    status.SetState(status_t::DEGRADED, "camera lost (" + why + "), reconnecting");
    next_reconnect_ns = SteadyNs() + std::llround(options.reconnect_interval_s * 1e9);
  };

  while (!stop->load() && SteadyNs() < end_ns &&
         (options.frames == 0 || summary.published < options.frames)) {
    const int64_t now_ns = SteadyNs();
    if (watchdog_usec > 0 && now_ns - last_watchdog_ns > static_cast<int64_t>(watchdog_usec) * 250) {
      sd_notify(0, "WATCHDOG=1");
      last_watchdog_ns = now_ns;
    }
    if (camera == nullptr) {
      if (now_ns < next_reconnect_ns) {
        std::this_thread::sleep_for(std::chrono::milliseconds(20));
        continue;
      }
      try {
        camera = OpenCamera(options);
      } catch (const std::exception& e) {
        status.SetState(status_t::DEGRADED, std::string("camera lost, reopening: ") + e.what());
        next_reconnect_ns = now_ns + std::llround(options.reconnect_interval_s * 1e9);
        continue;
      }
      ++summary.reconnects;
      status.Increment(kStatusReconnects);
      ids.Reconnected();
      stamper.Reconnected();
      last_frame_ns = SteadyNs();
      exposure_us = camera->ReadExposureUs();
      *log << kProgram << ": camera " << camera->info().id << " back" << std::endl;
      status.SetState(status_t::OK, "streaming " + camera->info().id + " (reconnected)");
      continue;
    }
    if (software_trigger && now_ns >= next_trigger_ns) {
      try {
        camera->SoftwareTrigger();
      } catch (const std::exception& e) {
        lose_camera(e.what());
        continue;
      }
      next_trigger_ns += trigger_period_ns;
      if (next_trigger_ns < now_ns) next_trigger_ns = now_ns + trigger_period_ns;  // fell behind
    }
    if (now_ns >= next_counters_ns) {
      stream_totals.Update(camera->StreamCounters());
      stream_totals.Report(&status);
      const ClockSyncStats sync = stamper.clock_sync().stats();
      status.SetCounter(kStatusTimestampResets, sync.resets);
      status.SetCounter("clock_outliers", sync.outliers);
      status.SetCounter("frames_without_device_stamp", stamper.frames_without_device_stamp());
      status.SetMetric("clock_offset_ms", static_cast<double>(sync.offset_ns) * 1e-6);
      status.SetMetric("clock_skew_ppm", sync.skew_ppm);
      status.SetMetric("exposure_us", exposure_us);
      next_counters_ns = now_ns + 250000000;
    }
    if (camera->control_lost()) {
      lose_camera("control lost");
      continue;
    }
    // Short waits keep the loop responsive to stop requests and software triggers.
    const uint64_t wait_us = software_trigger
        ? static_cast<uint64_t>(std::clamp<int64_t>((next_trigger_ns - now_ns) / 1000, 1000, 100000))
        : 100000;
    if (!camera->Pop(wait_us, &frame)) {
      if (!options.trigger && SteadyNs() - last_frame_ns > frame_timeout_ns) {
        lose_camera("no frame for " + std::to_string(options.frame_timeout_s) + " s");
      }
      continue;
    }
    last_frame_ns = SteadyNs();
    if (!frame.ok) {
      // Incomplete buffer (missing packets after resends, timeout, size mismatch, ...): not
      // published, but it arrived, so its id still counts in the sequence: `dropped` stays
      // the frames that never arrived, and image_t.seq skips this one.
      if (frame.frame_id != 0) {
        const FrameIdTracker::Step step = ids.Next(frame.frame_id);
        summary.dropped += step.dropped;
        status.Increment(kStatusDropped, step.dropped);
      }
      ++summary.failed_buffers;
      status.Increment("failed_buffers");
      status.Increment("buffer_" + frame.status);
      camera->Requeue(&frame);
      continue;
    }
    if (!frame.format_known) {
      status.Increment(kStatusMalformed);
      camera->Requeue(&frame);
      continue;
    }
    const FrameIdTracker::Step step = ids.Next(frame.frame_id);
    if (step.dropped > 0) {
      summary.dropped += step.dropped;
      status.Increment(kStatusDropped, step.dropped);
    }
    if (step.restarted) status.Increment("frame_id_restarts");
    if (auto_exposure && last_frame_ns - exposure_read_ns > 1000000000) {
      exposure_us = camera->ReadExposureUs();  // one register read a second
      exposure_read_ns = last_frame_ns;
    }
    const int64_t t_ns =
        stamper.Stamp(frame.device_ns, frame.host_arrival_ns, std::llround(exposure_us * 1e3));
    const std::string convert_error = ConvertFrame(frame.raw, convert, &image);
    const int64_t host_arrival_ns = frame.host_arrival_ns;
    camera->Requeue(&frame);  // the pixels are copied: give the buffer back to the stream now
    if (!convert_error.empty()) {
      status.Increment(kStatusMalformed);
      continue;
    }
    const std::string msg_error =
        MakeImageMessage(image, OutputPixelFormat(frame.raw.format, convert), t_ns, step.seq,
                         options.camera_id, &msg);
    if (!msg_error.empty()) {
      status.Increment(kStatusMalformed);
      continue;
    }
    msg.exposure_us = static_cast<int32_t>(std::lround(exposure_us));
    if (lcm->publish(channel, &msg) != 0) {
      status.Increment(kStatusPublishErrors);
      continue;
    }
    ++summary.published;
    status.RecordPublished(SteadyNs(), static_cast<double>(RealtimeNs() - host_arrival_ns) * 1e-6);
    if (options.fault_lose_camera_after > 0 && !fault_done &&
        summary.published >= options.fault_lose_camera_after) {
      fault_done = true;
      lose_camera("fault injection: --fault-lose-camera-after");
    }
  }
  if (notify) sd_notify(0, "STOPPING=1");
  if (camera != nullptr) {
    camera->Stop();
    stream_totals.Update(camera->StreamCounters());
  }
  stream_totals.Report(&status);
  status.SetCounter(kStatusTimestampResets, stamper.clock_sync().stats().resets);
  status_publisher.Stop();
  const status_t last = status.Build(SteadyNs(), 0);
  for (int i = 0; i < last.num_metrics; ++i) {
    if (last.metric_names[i] == kStatusLatencyP50Ms) summary.latency_p50_ms = last.metric_values[i];
    if (last.metric_names[i] == kStatusLatencyP99Ms) summary.latency_p99_ms = last.metric_values[i];
  }
  summary.stream = stream_totals.Text();
  *log << summary.FullReport(kProgram) << std::flush;
  return summary;
}

std::string AravisRunSummary::BriefReport() const {
  std::string text = std::to_string(published) + " frames published, " + std::to_string(dropped) +
                     " dropped, " + std::to_string(failed_buffers) + " incomplete, " +
                     std::to_string(reconnects) + " reconnects";
  return error.empty() ? text : text + "; error: " + error;
}

std::string AravisRunSummary::FullReport(const std::string& program) const {
  char latency[96];
  std::snprintf(latency, sizeof(latency), "latency to publish p50 %.2f ms, p99 %.2f ms",
                latency_p50_ms, latency_p99_ms);
  return program + ": stopped: " + BriefReport() + "; " + latency +
         " (arrival -> LCM publish, last 512 frames)\n" + program + ": stream: " +
         (stream.empty() ? std::string("-") : stream) + "\n";
}

}  // namespace vilma::aravis
