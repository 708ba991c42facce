// From a V4L2 buffer stamp to the robot's clock (docs/drivers.md, "vilma-v4l2", Timestamps).
//
// The kernel stamps a buffer on CLOCK_MONOTONIC (V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC) at the
// start of exposure (V4L2_BUF_FLAG_TSTAMP_SRC_SOE; uvcvideo with hardware timestamps, from the
// camera's own clock) or at the end of the frame (TSTAMP_SRC_EOF: the last byte received). vilma
// publishes the middle of the exposure (image_t: "capture time (mid-exposure)"):
//
//   SOE:  t_mid = t_buffer + exposure / 2
//   EOF:  t_mid = t_buffer - readout - exposure / 2
//
// with `readout` the time from the end of exposure to the end of the frame's transfer, which
// the kernel does not know (option readout_us, 0 by default). A buffer whose stamp is not
// monotonic (TIMESTAMP_UNKNOWN or COPY), zero, or later than its dequeue is stamped with the
// dequeue time taken as an EOF stamp instead, and counted (fallbacks).
//
// Which instant a stamp is: the flags say SOE or EOF, but uvcvideo sets SOE on every buffer
// while, with its hardware timestamps off (module parameter hwtimestamps=0, the default since
// Linux 4.3), it stamps the arrival of the frame's first USB packet: the start of readout,
// i.e. the end of exposure. The capture tells the stamper so (SetDeviceStampPoint), and the
// option stamp_source overrides both:
//
//   end of exposure:  t_mid = t_buffer - exposure / 2
//
// The robot's clock is CLOCK_REALTIME (LCM utime): t_robot = t_mid + (REALTIME - MONOTONIC),
// the offset measured with MeasureRealtimeMinusMonotonicNs (core/clock_sync.h) at the first
// frame and again every offset_refresh_s (0.1 s). NTP slews REALTIME slowly (<= 500 ppm), which the
// refresh follows; a change of the offset by more than realtime_step_ms between two
// measurements is a step of the realtime clock (ntpdate, a GPS fix, a manual `date`): counted
// (steps), and the new offset used from then on.
#pragma once

#include <cstdint>
#include <functional>
#include <string>

namespace vilma::v4l2 {

// The instant a buffer stamp marks.
enum class StampPoint {
  kFromFlags,        // V4L2_BUF_FLAG_TSTAMP_SRC_SOE / _EOF as the buffer says
  kStartOfExposure,  // SOE
  kEndOfExposure,    // start of readout / first packet (uvcvideo without hardware stamps)
  kEndOfFrame,       // EOF: the last line arrived
};
// "auto", "start_of_exposure", "end_of_exposure", "end_of_frame" <-> StampPoint (auto =
// kFromFlags); false for other text.
bool ParseStampPoint(const std::string& text, StampPoint* point);
std::string StampPointName(StampPoint point);

struct TimestampOptions {
  // true: publish mid-exposure (above); false: the buffer stamp as the kernel gave it.
  bool mid_exposure = true;
  // What the buffer stamps mark; kFromFlags ("auto"): the flags, corrected for uvcvideo.
  StampPoint stamp_source = StampPoint::kFromFlags;
  // End of exposure -> end of frame transfer [us], used with EOF stamps and the fallback.
  double readout_us = 0.0;
  // Re-measure REALTIME - MONOTONIC this often [s] (0 = every frame). A measurement costs
  // ~50 vDSO clock reads (about a microsecond); a realtime step shows in the stamps at the
  // next measurement, so at most this late.
  double offset_refresh_s = 0.1;
  // A change of REALTIME - MONOTONIC larger than this between two measurements is a clock
  // step [ms].
  double realtime_step_ms = 1.0;

  // "" or "field: expectation".
  std::string Validate() const;
};

struct StampedFrame {
  int64_t mid_monotonic_ns = 0;  // the published instant on CLOCK_MONOTONIC [ns]
  int64_t robot_ns = 0;          // the same on CLOCK_REALTIME (robot clock) [ns]
  // When the frame was complete on CLOCK_MONOTONIC [ns]: an EOF stamp (or the dequeue time
  // on fallback), else the SOE stamp + exposure + readout. Latency is counted from here.
  int64_t end_of_frame_monotonic_ns = 0;
  bool fallback = false;  // stamped with the dequeue time
};

class FrameTimestamper {
 public:
  // `measure_realtime_minus_monotonic_ns` is MeasureRealtimeMinusMonotonicNs in the driver,
  // a simulated clock in tests.
  FrameTimestamper(const TimestampOptions& options,
                   std::function<int64_t()> measure_realtime_minus_monotonic_ns);

  // `buffer_flags` and `buffer_ns` (timeval as ns) of a dequeued v4l2_buffer,
  // `dequeue_monotonic_ns` the CLOCK_MONOTONIC time of the dequeue, `exposure_ns` the
  // exposure time (0 if unknown).
  StampedFrame Stamp(uint32_t buffer_flags, int64_t buffer_ns, int64_t dequeue_monotonic_ns,
                     int64_t exposure_ns);

  // What this device's stamps mark when stamp_source is auto (kFromFlags: trust the flags).
  void SetDeviceStampPoint(StampPoint point) { device_point_ = point; }
  // The stamp point used for a buffer with these flags.
  StampPoint EffectivePoint(uint32_t buffer_flags) const;

  int64_t fallbacks() const { return fallbacks_; }
  int64_t steps() const { return steps_; }
  int64_t offset_ns() const { return offset_ns_; }

 private:
  TimestampOptions options_;
  std::function<int64_t()> measure_;
  StampPoint device_point_ = StampPoint::kFromFlags;
  bool have_offset_ = false;
  int64_t offset_ns_ = 0;
  int64_t offset_measured_at_ns_ = 0;  // monotonic
  int64_t fallbacks_ = 0;
  int64_t steps_ = 0;
};

}  // namespace vilma::v4l2
