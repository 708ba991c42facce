#include "vilma/drivers/usb_imu/usb_imu_driver.h"

#include <systemd/sd-daemon.h>

#include <chrono>
#include <cstdio>
#include <ctime>
#include <iomanip>
#include <iostream>
#include <lcm/lcm-cpp.hpp>
#include <sstream>
#include <thread>

#include "vilma/core/arg_cursor.h"
#include "vilma/core/error.h"
#include "vilma/drivers/driver_status.h"
#include "vilma/drivers/lcm_convert.h"
#include "vilma/drivers/lcm_url.h"
#include "vilma/drivers/usb_imu/imu_stream.h"
#include "vilma/drivers/usb_imu/mip_device.h"
#include "vilma/drivers/usb_imu/mip_protocol.h"
#include "vilma/drivers/usb_imu/usb_imu_run_summary.h"

namespace vilma::usb_imu {

std::unique_ptr<ByteTransport> MakeTransport(const UsbImuOptions& o) {
  if (o.transport == "usb") {
    UsbDeviceSelector selector;
    selector.vendor_id = static_cast<uint16_t>(o.usb_vendor_id);
    selector.product_ids.clear();
    for (int id : o.usb_product_ids) selector.product_ids.push_back(static_cast<uint16_t>(id));
    selector.serial = o.usb_serial;
    return std::make_unique<UsbTransport>(selector);
  }
  if (o.transport == "replay") return std::make_unique<ReplayTransport>(o.replay_file);
  return std::make_unique<SerialTransport>(o.serial_device, o.baud);
}

namespace {

constexpr const char kProgram[] = "vilma-usb-imu";

int64_t RealtimeNs() {
  timespec t{};
  clock_gettime(CLOCK_REALTIME, &t);
  return static_cast<int64_t>(t.tv_sec) * 1000000000 + t.tv_nsec;
}

int64_t SteadyNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

class Driver {
 public:
  Driver(const UsbImuOptions& options, const std::atomic<bool>* stop, lcm::LCM* lcm,
         DriverStatus* status)
      : o_(options),
        stop_(stop),
        lcm_(lcm),
        status_(status),
        channel_(options.DataChannel()),
        transport_(MakeTransport(options)),
        stream_(ParsedTimeSource(options), options.clock_sync, options.rate_hz,
                static_cast<int64_t>(options.transport_latency_us * 1e3)) {
    ParseMipFamily(o_.family, &config_.family);
    ParseLowpassMode(o_.lowpass, &config_.lowpass);
    config_.rate_hz = o_.rate_hz;
    config_.lowpass_cutoff_hz = o_.lowpass_cutoff_hz;
    config_.command_timeout_ms = o_.command_timeout_ms;
    config_.command_retries = o_.command_retries;
    start_steady_ns_ = SteadyNs();
  }

  // Opens and configures; throws TransportError / MipCommandError.
  void OpenAndConfigure() {
    transport_->Open();
    framer_.Clear();
    if (o_.configure) {
      MipDevice device(transport_.get(), &framer_);
      const MipConfigResult r = device.Configure(config_);
      first_packets_ = device.TakeLeftovers();
      first_packets_arrival_ns_ = RealtimeNs();
      stream_.set_expected_rate_hz(r.rate_hz);
      status_->SetMetric("configured_rate_hz", r.rate_hz);
      status_->SetMetric("base_rate_hz", r.base_rate_hz);
      configured_ = "base rate " + std::to_string(r.base_rate_hz) + " Hz / " +
                    std::to_string(r.decimation) + " = " + FormatHz(r.rate_hz);
    } else {
      configured_ = "not configured (stream as it comes)";
    }
  }

  int Run() {
    // The driver's own counters, present (0) in every report from the first one on.
    for (const char* name : {"device_lost", "reconnect_attempts", "other_packets"}) {
      status_->SetCounter(name, 0);
    }
    MaybeUpdateStatus(true);
    std::cerr << kProgram << ": " << transport_->Describe() << ", family " << o_.family
              << ", time " << o_.time_source << " -> " << channel_ << " (status "
              << o_.StatusChannel() << ")\n";
    try {
      OpenAndConfigure();
    } catch (const std::exception& e) {
      status_->SetState(status_t::ERROR, e.what());
      std::cerr << kProgram << ": " << e.what() << "\n";
      return 1;
    }
    std::cerr << kProgram << ": streaming, " << configured_ << "\n";
    status_->SetState(status_t::OK, "streaming from " + transport_->Describe());
    sd_notify(0, "READY=1");
    last_sample_steady_ns_ = SteadyNs();
    HandleFirstPackets();
    uint8_t buffer[4096];  // many tty packets per read (the USB transport takes one USB packet)
    while (!Stopping()) {
      std::size_t n = 0;
      try {
        n = transport_->Read(buffer, sizeof(buffer), 100);
      } catch (const TransportError& e) {
        if (!Reconnect(e.what())) break;
        continue;
      }
      const int64_t arrival_ns = RealtimeNs();
      if (n > 0) {
        HandleBytes(buffer, n, arrival_ns);
      } else if (transport_->AtEnd()) {
        HandlePackets(framer_.Flush(), arrival_ns);
        break;
      }
      MaybeUpdateStatus(false);
    }
    MaybeUpdateStatus(true);
    sd_notify(0, "STOPPING=1");
    std::cout << Summary().FullReport(kProgram);
    return 0;
  }

 private:
  static TimeSource ParsedTimeSource(const UsbImuOptions& o) {
    TimeSource s = TimeSource::kHostSync;
    ParseTimeSource(o.time_source, &s);
    return s;
  }

  static std::string FormatHz(double hz) {
    std::ostringstream out;
    out << hz << " Hz";
    return out.str();
  }

  bool Stopping() const {
    if (stop_->load()) return true;
    return o_.seconds > 0.0 &&
           static_cast<double>(SteadyNs() - start_steady_ns_) * 1e-9 >= o_.seconds;
  }

  // Device gone: close, reopen and reconfigure with backoff until it works or we stop.
  bool Reconnect(const std::string& why) {
    status_->Increment("device_lost");
    status_->SetState(status_t::DEGRADED, "device lost (" + why + "), reconnecting");
    std::cerr << kProgram << ": " << why << "; reconnecting\n";
    transport_->Close();
    double backoff_s = 0.1;
    while (!Stopping()) {
      // Sleep in small steps so that a stop request is served at once.
      const int64_t until = SteadyNs() + static_cast<int64_t>(backoff_s * 1e9);
      while (SteadyNs() < until && !Stopping()) {
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
      }
      if (Stopping()) break;
      status_->Increment("reconnect_attempts");
      try {
        OpenAndConfigure();
        stream_.Reset();
        status_->Increment(kStatusReconnects);
        status_->SetState(status_t::OK, "streaming from " + transport_->Describe() +
                                            " (reconnected)");
        std::cerr << kProgram << ": reconnected, " << configured_ << "\n";
        last_sample_steady_ns_ = SteadyNs();
        HandleFirstPackets();
        return true;
      } catch (const std::exception& e) {
        transport_->Close();
        status_->SetState(status_t::DEGRADED, std::string("reconnecting: ") + e.what());
      }
      backoff_s = std::min(2.0 * backoff_s, o_.reconnect_max_backoff_s);
    }
    return false;
  }

  // The samples that came in the same read as the last configuration reply (their arrival:
  // when the configuration returned, a little late, which the clock filter tolerates).
  void HandleFirstPackets() {
    std::vector<MipPacket> packets;
    packets.swap(first_packets_);
    HandlePackets(packets, first_packets_arrival_ns_);
  }

  void HandleBytes(const uint8_t* data, std::size_t n, int64_t arrival_ns) {
    HandlePackets(framer_.Push(data, n), arrival_ns);
  }

  void HandlePackets(const std::vector<MipPacket>& packets, int64_t arrival_ns) {
    for (const MipPacket& packet : packets) {
      MipImuSample sample;
      if (!DecodeMipImuSample(packet, &sample, &decode_stats_)) {
        status_->Increment("other_packets");  // replies, other descriptor sets
        continue;
      }
      int64_t sample_arrival_ns = arrival_ns;
      if (o_.transport == "replay" && sample.has_timestamp) sample_arrival_ns = PaceReplay(sample);
      ImuSample imu;
      if (!stream_.Process(sample, sample_arrival_ns, &imu)) continue;
      last_sample_steady_ns_ = SteadyNs();
      const imu_t msg = ImuToMessage(imu, seq_++);
      if (lcm_->publish(channel_, &msg) != 0) {
        status_->Increment(kStatusPublishErrors);
        continue;
      }
      status_->RecordPublished(SteadyNs(), static_cast<double>(RealtimeNs() - imu.t_ns) * 1e-6);
    }
  }

  // A recording replays at the pace of its device stamps (x replay_rate); returns the moment
  // the sample "arrives" (now, after waiting for its turn).
  int64_t PaceReplay(const MipImuSample& sample) {
    if (o_.replay_rate > 0.0) {
      if (!paced_ || sample.device_ns < pace_device0_ns_) {
        paced_ = true;
        pace_device0_ns_ = sample.device_ns;
        pace_steady0_ns_ = SteadyNs();
      }
      const auto due = pace_steady0_ns_ + static_cast<int64_t>(
                                              static_cast<double>(sample.device_ns - pace_device0_ns_) /
                                              o_.replay_rate);
      while (SteadyNs() < due && !Stopping()) {
        std::this_thread::sleep_for(std::chrono::nanoseconds(std::min<int64_t>(due - SteadyNs(), 10000000)));
      }
    }
    return RealtimeNs();
  }

  void MaybeUpdateStatus(bool force) {
    const int64_t now = SteadyNs();
    if (!force && now - last_status_update_ns_ < 100000000) return;
    last_status_update_ns_ = now;
    const MipFramerStats& f = framer_.stats();
    const ImuStreamCounters& c = stream_.counters();
    const ClockSyncStats clock = stream_.clock().stats();
    status_->SetCounter(kStatusDropped, c.dropped);
    status_->SetCounter(kStatusMalformed, f.checksum_errors + f.truncated_packets +
                                              f.malformed_packets +
                                              decode_stats_.bad_field_lengths +
                                              decode_stats_.bad_values);
    status_->SetCounter(kStatusTimestampResets, clock.resets + c.device_time_jumps);
    status_->SetCounter("checksum_errors", f.checksum_errors);
    status_->SetCounter("truncated_packets", f.truncated_packets);
    status_->SetCounter("malformed_packets", f.malformed_packets);
    status_->SetCounter("garbage_bytes", f.garbage_bytes);
    status_->SetCounter("bad_fields", decode_stats_.bad_field_lengths + decode_stats_.bad_values);
    status_->SetCounter("unknown_fields", decode_stats_.unknown_fields);
    status_->SetCounter("incomplete_samples", c.incomplete);
    status_->SetCounter("non_monotonic", c.non_monotonic);
    status_->SetCounter("clock_warmup", c.warmup);
    status_->SetCounter("clock_outliers", clock.outliers);
    status_->SetMetric("clock_offset_ms", static_cast<double>(clock.offset_ns) * 1e-6);
    status_->SetMetric("clock_skew_ppm", clock.skew_ppm);
    if (force) return;
    const double silent_s = static_cast<double>(now - last_sample_steady_ns_) * 1e-9;
    const int32_t state = status_->state();
    if (state == status_t::OK && silent_s > o_.stall_timeout_s) {
      std::ostringstream msg;
      msg << "no IMU samples for " << std::fixed << std::setprecision(1) << silent_s << " s";
      status_->SetState(status_t::DEGRADED, msg.str());
    } else if (state == status_t::DEGRADED && silent_s <= o_.stall_timeout_s &&
               status_->message().rfind("no IMU samples", 0) == 0) {
      status_->SetState(status_t::OK, "streaming from " + transport_->Describe());
    }
  }

  UsbImuRunSummary Summary() const {
    const MipFramerStats& f = framer_.stats();
    const ImuStreamCounters& c = stream_.counters();
    const ClockSyncStats clock = stream_.clock().stats();
    UsbImuRunSummary s;
    s.published = status_->Counter(kStatusPublished);
    s.dropped = c.dropped;
    s.packets = f.packets;
    s.checksum_errors = f.checksum_errors;
    s.truncated_packets = f.truncated_packets;
    s.malformed_packets = f.malformed_packets;
    s.garbage_bytes = f.garbage_bytes;
    s.bad_fields = decode_stats_.bad_field_lengths + decode_stats_.bad_values;
    s.incomplete = c.incomplete;
    s.reconnects = status_->Counter(kStatusReconnects);
    s.clock_resets = clock.resets;
    s.skew_ppm = clock.skew_ppm;
    return s;
  }

  const UsbImuOptions o_;
  const std::atomic<bool>* stop_;
  lcm::LCM* lcm_;
  DriverStatus* status_;
  const std::string channel_;
  std::unique_ptr<ByteTransport> transport_;
  MipConfig config_;
  MipFramer framer_;
  MipDecodeStats decode_stats_;
  ImuStream stream_;
  std::string configured_;
  std::vector<MipPacket> first_packets_;
  int64_t first_packets_arrival_ns_ = 0;
  int64_t seq_ = 0;
  int64_t start_steady_ns_ = 0;
  int64_t last_sample_steady_ns_ = 0;
  int64_t last_status_update_ns_ = 0;
  bool paced_ = false;
  int64_t pace_device0_ns_ = 0;
  int64_t pace_steady0_ns_ = 0;
};

int ListDevices(const UsbImuOptions& o) {
  try {
    const std::vector<UsbDeviceInfo> devices =
        ListUsbDevices(static_cast<uint16_t>(o.usb_vendor_id));
    if (devices.empty()) {
      std::cout << "no USB devices" << (o.usb_vendor_id ? " of this vendor id" : "") << "\n";
    }
    for (const UsbDeviceInfo& d : devices) {
      std::cout << std::hex << std::setw(4) << std::setfill('0') << d.vendor_id << ":"
                << std::setw(4) << d.product_id << std::dec << std::setfill(' ') << "  bus "
                << d.bus << " device " << d.address << "  serial '" << d.serial << "'  "
                << d.product << "\n";
    }
    return 0;
  } catch (const std::exception& e) {
    std::cerr << kProgram << ": " << e.what() << "\n";
    return 1;
  }
}

}  // namespace

int UsbImuMain(int argc, const char* const* argv, const std::atomic<bool>* stop) {
  UsbImuCommandLine cl;
  try {
    cl = ParseUsbImuCommandLine(argc, argv);
  } catch (const std::exception& e) {  // UsageError, InputError
    std::cerr << kProgram << ": " << e.what() << "\n(see " << kProgram << " --help)\n";
    return 2;
  }
  if (cl.help) {
    std::cout << UsbImuUsage();
    return 0;
  }
  if (cl.print_config) {
    std::cout << UsbImuOptionsToYaml(cl.options);
    return 0;
  }
  if (cl.list) return ListDevices(cl.options);

  const std::string url = ResolveLcmUrl(cl.options.lcm_url);
  lcm::LCM lcm(url);
  if (!lcm.good()) {
    std::cerr << kProgram << ": cannot open LCM at " << url << "\n";
    return 1;
  }
  DriverStatus status(kProgram);
  StatusPublisher publisher(&status, &lcm, cl.options.StatusChannel(),
                            cl.options.status_period_s);
  publisher.Start();
  int code = 1;
  try {
    Driver driver(cl.options, stop, &lcm, &status);
    code = driver.Run();
  } catch (const std::exception& e) {
    status.SetState(status_t::ERROR, e.what());
    std::cerr << kProgram << ": " << e.what() << "\n";
    code = 1;
  }
  if (code == 0) status.SetState(status_t::STOPPING, "stopped");
  publisher.Stop();
  return code;
}

}  // namespace vilma::usb_imu
