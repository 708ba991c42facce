#include "vilma/drivers/v4l2/frame_timestamper.h"

#include <linux/videodev2.h>

#include <cmath>
#include <cstdlib>

namespace vilma::v4l2 {

bool ParseStampPoint(const std::string& text, StampPoint* point) {
  for (StampPoint p : {StampPoint::kFromFlags, StampPoint::kStartOfExposure,
                       StampPoint::kEndOfExposure, StampPoint::kEndOfFrame}) {
    if (text == StampPointName(p)) {
      *point = p;
      return true;
    }
  }
  return false;
}

std::string StampPointName(StampPoint point) {
  switch (point) {
    case StampPoint::kStartOfExposure:
      return "start_of_exposure";
    case StampPoint::kEndOfExposure:
      return "end_of_exposure";
    case StampPoint::kEndOfFrame:
      return "end_of_frame";
    default:
      return "auto";
  }
}

StampPoint FrameTimestamper::EffectivePoint(uint32_t buffer_flags) const {
  if (options_.stamp_source != StampPoint::kFromFlags) return options_.stamp_source;
  if (device_point_ != StampPoint::kFromFlags) return device_point_;
  return (buffer_flags & V4L2_BUF_FLAG_TSTAMP_SRC_MASK) == V4L2_BUF_FLAG_TSTAMP_SRC_SOE
             ? StampPoint::kStartOfExposure
             : StampPoint::kEndOfFrame;
}

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
  StampPoint point = EffectivePoint(buffer_flags);
  if (!monotonic || !plausible) {
    frame.fallback = true;
    ++fallbacks_;
    stamp_ns = dequeue_monotonic_ns;
    point = StampPoint::kEndOfFrame;  // the dequeue comes after the frame's end
  }
  // t_mid and the frame's completion from the instant the stamp marks (header comment).
  int64_t mid_ns = stamp_ns;
  switch (point) {
    case StampPoint::kStartOfExposure:
      mid_ns = stamp_ns + exposure_ns / 2;
      frame.end_of_frame_monotonic_ns = stamp_ns + exposure_ns + readout_ns;
      break;
    case StampPoint::kEndOfExposure:
      mid_ns = stamp_ns - exposure_ns / 2;
      frame.end_of_frame_monotonic_ns = stamp_ns + readout_ns;
      break;
    default:  // end of frame
      mid_ns = stamp_ns - readout_ns - exposure_ns / 2;
      frame.end_of_frame_monotonic_ns = stamp_ns;
  }
  frame.mid_monotonic_ns = (options_.mid_exposure || frame.fallback) ? mid_ns : stamp_ns;

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
