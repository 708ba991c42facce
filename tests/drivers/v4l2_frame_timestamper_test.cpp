// vilma-v4l2: buffer stamps to mid-exposure on the robot's clock
// (drivers/v4l2/src/frame_timestamper.cpp), on a simulated REALTIME - MONOTONIC offset.
#include <catch2/catch.hpp>

#include "test_skip.h"

#ifdef VILMA_HAVE_DRIVER_V4L2
#include <linux/videodev2.h>

#include "vilma/core/clock_sync.h"
#include "vilma/drivers/v4l2/frame_timestamper.h"

namespace vilma::v4l2 {
namespace {

constexpr uint32_t kSoe = V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC | V4L2_BUF_FLAG_TSTAMP_SRC_SOE;
constexpr uint32_t kEof = V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC | V4L2_BUF_FLAG_TSTAMP_SRC_EOF;
constexpr int64_t kMs = 1000000;

TEST_CASE("v4l2 start-of-exposure and end-of-frame stamps become mid-exposure", "[v4l2]") {
  const int64_t offset = 1700000000LL * 1000000000LL;  // REALTIME - MONOTONIC
  TimestampOptions options;
  options.readout_us = 4000;
  FrameTimestamper stamper(options, [&] { return offset; });
  const int64_t t = 5000 * kMs;
  // SOE: + exposure / 2 (10 ms exposure).
  StampedFrame f = stamper.Stamp(kSoe, t, t + 30 * kMs, 10 * kMs);
  CHECK_FALSE(f.fallback);
  CHECK(f.mid_monotonic_ns == t + 5 * kMs);
  CHECK(f.robot_ns == t + 5 * kMs + offset);
  CHECK(f.end_of_frame_monotonic_ns == t + 10 * kMs + 4 * kMs);  // + exposure + readout
  // EOF: - readout - exposure / 2.
  f = stamper.Stamp(kEof, t + 50 * kMs, t + 51 * kMs, 10 * kMs);
  CHECK(f.mid_monotonic_ns == t + 50 * kMs - 4 * kMs - 5 * kMs);
  CHECK(f.end_of_frame_monotonic_ns == t + 50 * kMs);
  // Unknown exposure: the stamp itself (SOE) or minus the readout (EOF).
  CHECK(stamper.Stamp(kSoe, t + 60 * kMs, t + 70 * kMs, 0).mid_monotonic_ns == t + 60 * kMs);
  // mid_exposure off: the kernel's stamp as it is.
  options.mid_exposure = false;
  FrameTimestamper raw(options, [&] { return offset; });
  CHECK(raw.Stamp(kSoe, t, t + kMs, 10 * kMs).mid_monotonic_ns == t);
  CHECK(stamper.fallbacks() == 0);
}

TEST_CASE("v4l2 end-of-exposure stamps (uvcvideo without hardware timestamps)", "[v4l2]") {
  const int64_t t = 7000 * kMs;
  FrameTimestamper stamper(TimestampOptions{}, [] { return int64_t{0}; });
  CHECK(stamper.EffectivePoint(kSoe) == StampPoint::kStartOfExposure);
  CHECK(stamper.EffectivePoint(kEof) == StampPoint::kEndOfFrame);
  // The device says: these SOE-flagged stamps are first-packet arrivals.
  stamper.SetDeviceStampPoint(StampPoint::kEndOfExposure);
  CHECK(stamper.EffectivePoint(kSoe) == StampPoint::kEndOfExposure);
  StampedFrame f = stamper.Stamp(kSoe, t, t + 20 * kMs, 10 * kMs);
  CHECK(f.mid_monotonic_ns == t - 5 * kMs);
  CHECK(f.end_of_frame_monotonic_ns == t);
  // The option wins over the device and the flags.
  TimestampOptions options;
  options.stamp_source = StampPoint::kEndOfFrame;
  options.readout_us = 3000;
  FrameTimestamper forced(options, [] { return int64_t{0}; });
  forced.SetDeviceStampPoint(StampPoint::kEndOfExposure);
  f = forced.Stamp(kSoe, t, t + 20 * kMs, 10 * kMs);
  CHECK(f.mid_monotonic_ns == t - 3 * kMs - 5 * kMs);
  StampPoint point;
  CHECK(ParseStampPoint("end_of_exposure", &point));
  CHECK(point == StampPoint::kEndOfExposure);
  CHECK(ParseStampPoint("auto", &point));
  CHECK(point == StampPoint::kFromFlags);
  CHECK_FALSE(ParseStampPoint("soe", &point));
}

TEST_CASE("v4l2 stamps that are not monotonic or not plausible fall back to the dequeue time",
          "[v4l2]") {
  TimestampOptions options;
  FrameTimestamper stamper(options, [] { return int64_t{1000}; });
  const int64_t dequeue = 9000 * kMs;
  // TIMESTAMP_COPY (output-to-capture devices), TIMESTAMP_UNKNOWN, zero, later than dequeue.
  StampedFrame f = stamper.Stamp(V4L2_BUF_FLAG_TIMESTAMP_COPY, dequeue - 5 * kMs, dequeue, 0);
  CHECK(f.fallback);
  CHECK(f.mid_monotonic_ns == dequeue);
  CHECK(stamper.Stamp(V4L2_BUF_FLAG_TIMESTAMP_UNKNOWN | V4L2_BUF_FLAG_TSTAMP_SRC_SOE, 1, dequeue, 0)
            .fallback);
  CHECK(stamper.Stamp(kSoe, 0, dequeue, 0).fallback);
  CHECK(stamper.Stamp(kSoe, dequeue + kMs, dequeue, 0).fallback);
  // The fallback is an end-of-frame instant: minus half the exposure.
  f = stamper.Stamp(V4L2_BUF_FLAG_TIMESTAMP_COPY, 0, dequeue, 8 * kMs);
  CHECK(f.mid_monotonic_ns == dequeue - 4 * kMs);
  CHECK(f.robot_ns == dequeue - 4 * kMs + 1000);
  CHECK(stamper.fallbacks() == 5);
  CHECK_FALSE(stamper.Stamp(kSoe, dequeue - kMs, dequeue, 0).fallback);
}

TEST_CASE("v4l2 the realtime offset is refreshed, NTP slew is followed, steps are counted",
          "[v4l2]") {
  // A simulated realtime clock: slews at 500 ppm (the most NTP does), steps by +2 s once.
  int64_t monotonic = 100 * 1000 * kMs;
  int64_t step = 0;
  const int64_t base_offset = 1600000000LL * 1000000000LL;
  auto realtime_minus_monotonic = [&] {
    const double slew_ns = 500e-6 * static_cast<double>(monotonic - 100 * 1000 * kMs);
    return base_offset + static_cast<int64_t>(slew_ns) + step;
  };
  TimestampOptions options;
  options.offset_refresh_s = 1.0;  // (the default, 0.1 s, follows a step 10x sooner)
  options.realtime_step_ms = 1.0;
  int measurements = 0;
  FrameTimestamper stamper(options, [&] {
    ++measurements;
    return realtime_minus_monotonic();
  });
  int64_t worst_error_ns = 0;
  for (int frame = 0; frame < 20 * 30; ++frame) {  // 20 s at 30 fps
    monotonic += 33333333;
    if (frame == 300) step = 2000 * kMs;
    const StampedFrame f = stamper.Stamp(kSoe, monotonic - 2 * kMs, monotonic, 0);
    // The published time against the true realtime of the stamp (the offset as it is now).
    const int64_t truth = monotonic - 2 * kMs + realtime_minus_monotonic();
    // A step shows in the stamps at the next refresh, within offset_refresh_s.
    if (frame < 300 || frame >= 330) {
      worst_error_ns = std::max<int64_t>(worst_error_ns, std::llabs(f.robot_ns - truth));
    }
  }
  // Slew between refreshes: 500 ppm x 1 s = 0.5 ms at most.
  CHECK(worst_error_ns <= 510000);
  CHECK(stamper.steps() == 1);
  CHECK(measurements >= 19);
  CHECK(measurements <= 21);
}

TEST_CASE("v4l2 with the real clocks the mapping agrees with CLOCK_REALTIME", "[v4l2]") {
  // A realtime read bracketed by two monotonic reads: the mapped bracket must contain it (up to
  // the offset measurement's own bracket width, a few microseconds).
  auto now = [](clockid_t clock) {
    timespec t{};
    clock_gettime(clock, &t);
    return t.tv_sec * 1000000000LL + t.tv_nsec;
  };
  TimestampOptions raw;
  raw.mid_exposure = false;
  FrameTimestamper exact(raw, [] { return MeasureRealtimeMinusMonotonicNs(); });
  const int64_t mono_before = now(CLOCK_MONOTONIC);
  const int64_t real_ns = now(CLOCK_REALTIME);
  const int64_t mono_after = now(CLOCK_MONOTONIC);
  const int64_t mapped_before = exact.Stamp(kSoe, mono_before, mono_after, 0).robot_ns;
  const int64_t mapped_after = exact.Stamp(kSoe, mono_after, mono_after, 0).robot_ns;
  CHECK(mapped_before <= real_ns + 100000);
  CHECK(mapped_after >= real_ns - 100000);
}

TEST_CASE("v4l2 timestamp options are validated", "[v4l2]") {
  TimestampOptions o;
  CHECK(o.Validate().empty());
  o.readout_us = -1;
  CHECK(o.Validate().rfind("readout_us:", 0) == 0);
  o = TimestampOptions{};
  o.offset_refresh_s = 0;  // every frame
  CHECK(o.Validate().empty());
  o.offset_refresh_s = -1;
  CHECK(o.Validate().rfind("offset_refresh_s:", 0) == 0);
  o = TimestampOptions{};
  o.realtime_step_ms = 0;
  CHECK(o.Validate().rfind("realtime_step_ms:", 0) == 0);
}

}  // namespace
}  // namespace vilma::v4l2

#else
TEST_CASE("vilma-v4l2 timestamps", "[v4l2]") {
  VILMA_SKIP("vilma-v4l2 is not built here (<linux/videodev2.h> missing)");
}
#endif
