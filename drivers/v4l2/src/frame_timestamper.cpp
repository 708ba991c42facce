#include "vilma/drivers/v4l2/frame_timestamper.h"

#include <linux/videodev2.h>

#include <cmath>
#include <cstdlib>

namespace vilma::v4l2 {

std::string TimestampOptions::Validate() const {
  if (!(std::isfinite(readout_us) && readout_us >= 0.0 && readout_us <= 1e6)) {
    return "readout_us: expected 0 .. 1000000 [us]";
  }
  if (!(std::isfinite(offset_refresh_s) && offset_refresh_s >= 0.0 && offset_refresh_s <= 3600)) {
    return "offset_refresh_s: expected 0 (every frame) .. 3600 [s]";
  }
  if (!(std::isfinite(realtime_step_ms) && realtime_step_ms > 0.0)) {
    return "realtime_step_ms: expected > 0 [ms]";
  }
  return "";
}

FrameTimestamper::FrameTimestamper(const TimestampOptions& options,
                                   std::function<int64_t()> measure_realtime_minus_monotonic_ns)
    : options_(options), measure_(std::move(measure_realtime_minus_monotonic_ns)) {}

StampedFrame FrameTimestamper::Stamp(uint32_t buffer_flags, int64_t buffer_ns,
                                     int64_t dequeue_monotonic_ns, int64_t exposure_ns) {
  StampedFrame frame;
  const bool monotonic =
      (buffer_flags & V4L2_BUF_FLAG_TIMESTAMP_MASK) == V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC;
  const bool plausible = buffer_ns > 0 && buffer_ns <= dequeue_monotonic_ns;
  const int64_t readout_ns = static_cast<int64_t>(std::llround(options_.readout_us * 1e3));
  int64_t stamp_ns = buffer_ns;
  bool start_of_exposure =
      (buffer_flags & V4L2_BUF_FLAG_TSTAMP_SRC_MASK) == V4L2_BUF_FLAG_TSTAMP_SRC_SOE;
  if (!monotonic || !plausible) {
    frame.fallback = true;
    ++fallbacks_;
    stamp_ns = dequeue_monotonic_ns;
    start_of_exposure = false;  // the dequeue comes after the frame's end
  }
  frame.mid_monotonic_ns = stamp_ns;
  frame.end_of_frame_monotonic_ns =
      start_of_exposure ? stamp_ns + exposure_ns + readout_ns : stamp_ns;
  if (options_.mid_exposure || frame.fallback) {
    frame.mid_monotonic_ns =
        start_of_exposure ? stamp_ns + exposure_ns / 2 : stamp_ns - readout_ns - exposure_ns / 2;
  }

  // REALTIME - MONOTONIC: measured at the first frame, then every offset_refresh_s.
  const int64_t refresh_ns = static_cast<int64_t>(options_.offset_refresh_s * 1e9);
  if (!have_offset_ || dequeue_monotonic_ns - offset_measured_at_ns_ >= refresh_ns) {
    const int64_t measured = measure_();
    const int64_t step_ns = static_cast<int64_t>(options_.realtime_step_ms * 1e6);
    if (have_offset_ && std::llabs(measured - offset_ns_) > step_ns) ++steps_;
    offset_ns_ = measured;
    offset_measured_at_ns_ = dequeue_monotonic_ns;
    have_offset_ = true;
  }
  frame.robot_ns = frame.mid_monotonic_ns + offset_ns_;
  return frame;
}

}  // namespace vilma::v4l2
