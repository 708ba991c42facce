#include "vilma/drivers/usb_imu/imu_stream.h"

#include <cmath>

namespace vilma::usb_imu {

bool ParseTimeSource(const std::string& text, TimeSource* source) {
  if (text == "host_sync") {
    *source = TimeSource::kHostSync;
  } else if (text == "device") {
    *source = TimeSource::kDevice;
  } else {
    return false;
  }
  return true;
}

const char* TimeSourceName(TimeSource source) {
  return source == TimeSource::kHostSync ? "host_sync" : "device";
}

ImuStream::ImuStream(TimeSource source, const ClockSyncOptions& clock_sync,
                     double expected_rate_hz, int64_t transport_latency_ns)
    : source_(source),
      clock_(clock_sync),
      expected_rate_hz_(expected_rate_hz),
      latency_ns_(transport_latency_ns) {}

void ImuStream::Reset() {
  clock_.Reset();
  have_last_ = false;
  anchored_ = false;
  // last_published_ns_ stays: stamps must keep increasing across a reconnect.
}

bool ImuStream::Process(const MipImuSample& sample, int64_t host_arrival_ns, ImuSample* out) {
  ++counters_.samples;
  if (!(sample.has_accel && sample.has_gyro && sample.has_timestamp)) {
    ++counters_.incomplete;
    return false;
  }
  constexpr int64_t kJumpNs = 1000000000;  // a gap > 1 s is a device clock jump, not drops
  bool jumped = false;
  if (have_last_) {
    const int64_t gap_ns = sample.device_ns - last_device_ns_;
    if (gap_ns <= 0 || gap_ns > kJumpNs) {
      jumped = true;
      ++counters_.device_time_jumps;
    } else if (expected_rate_hz_ > 0.0) {
      // Missing samples between two received ones: round(gap / period) - 1.
      const double periods = static_cast<double>(gap_ns) * expected_rate_hz_ * 1e-9;
      const auto missing = static_cast<int64_t>(std::llround(periods)) - 1;
      if (missing > 0) counters_.dropped += missing;
    }
  }
  have_last_ = true;
  last_device_ns_ = sample.device_ns;

  const int64_t arrival_ns = host_arrival_ns - latency_ns_;
  int64_t t_ns = 0;
  if (source_ == TimeSource::kHostSync) {
    clock_.AddObservation(sample.device_ns, arrival_ns);
    if (!clock_.IsValid()) {  // the first pairs: the offset is still a single arrival's
      ++counters_.warmup;
      return false;
    }
    t_ns = clock_.DeviceToHostNs(sample.device_ns);
  } else {
    if (!anchored_ || jumped) {
      device_offset_ns_ = arrival_ns - sample.device_ns;
      anchored_ = true;
    }
    t_ns = sample.device_ns + device_offset_ns_;
  }
  if (have_published_ && t_ns <= last_published_ns_) {
    ++counters_.non_monotonic;
    return false;
  }
  out->t_ns = t_ns;
  for (int i = 0; i < 3; ++i) {
    out->a_I[i] = sample.accel_g[i] * kStandardGravity;
    out->omega_I[i] = sample.gyro_rad_s[i];
  }
  last_published_ns_ = t_ns;
  have_published_ = true;
  ++counters_.published;
  return true;
}

}  // namespace vilma::usb_imu
