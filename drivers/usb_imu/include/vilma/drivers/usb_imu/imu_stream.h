// Decoded MIP samples -> vilma IMU samples on the robot's clock: SI units, device timestamps
// mapped to CLOCK_REALTIME through ClockSync (or shifted by a constant), gaps counted as drops,
// stamps kept strictly increasing.
#pragma once

#include <cstdint>
#include <string>

#include "vilma/core/clock_sync.h"
#include "vilma/core/imu.h"
#include "vilma/drivers/usb_imu/mip_protocol.h"

namespace vilma::usb_imu {

enum class TimeSource {
  // Device stamps through ClockSync against the host arrival times (default): the stamps keep
  // the device's sample spacing and sit on the host clock within the filter's error.
  kHostSync,
  // Device stamps plus the offset of the first sample's arrival (re-anchored after a device
  // clock jump): for recorded byte streams replayed at any speed, and for a device whose clock
  // is already disciplined to the host (PPS).
  kDevice,
};
bool ParseTimeSource(const std::string& text, TimeSource* source);  // "host_sync" / "device"
const char* TimeSourceName(TimeSource source);

struct ImuStreamCounters {
  int64_t samples = 0;          // samples given to Process
  int64_t published = 0;        // samples Process returned true for
  int64_t incomplete = 0;       // packets without accel, gyro or timestamp
  int64_t dropped = 0;          // samples missing from the device-time sequence
  int64_t non_monotonic = 0;    // mapped stamps not after the previous one (not published)
  int64_t device_time_jumps = 0;  // device clock went back or jumped ahead (> 1 s)
  int64_t warmup = 0;           // host_sync: not published before ClockSync::IsValid()
};

class ImuStream {
 public:
  // `expected_rate_hz`: the configured stream rate (for drop counting; 0 = do not count).
  // `transport_latency_ns`: the fixed part of the delay (subtracted from arrival stamps).
  ImuStream(TimeSource source, const ClockSyncOptions& clock_sync, double expected_rate_hz,
            int64_t transport_latency_ns);

  // One decoded sample that arrived at `host_arrival_ns` (CLOCK_REALTIME ns). True and *out
  // (t_ns on CLOCK_REALTIME, omega_I [rad/s], a_I [m/s^2]) when it should be published.
  bool Process(const MipImuSample& sample, int64_t host_arrival_ns, ImuSample* out);

  // After a reconnect: the device may have rebooted; forget its clock.
  void Reset();
  void set_expected_rate_hz(double rate_hz) { expected_rate_hz_ = rate_hz; }

  const ImuStreamCounters& counters() const { return counters_; }
  const ClockSync& clock() const { return clock_; }

 private:
  TimeSource source_;
  ClockSync clock_;
  double expected_rate_hz_;
  int64_t latency_ns_;
  bool have_last_ = false;
  int64_t last_device_ns_ = 0;
  int64_t last_published_ns_ = 0;
  bool have_published_ = false;
  int64_t device_offset_ns_ = 0;  // kDevice: host - device of the anchor sample
  bool anchored_ = false;
  ImuStreamCounters counters_;
};

}  // namespace vilma::usb_imu
