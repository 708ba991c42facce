// vilma-v4l2's capture loop (drivers/v4l2/src/v4l2_capture.cpp) against the fake camera:
// frames and their pictures, sequence-gap drops, malformed buffers, unplug/replug (also under
// another /dev/videoN), stalls, timestamp fallbacks and the errors of a first open.
#include <catch2/catch.hpp>

#include "test_skip.h"

#ifdef VILMA_HAVE_DRIVER_V4L2
#include <linux/videodev2.h>
#include <unistd.h>

#include <cerrno>
#include <thread>
#include <vector>

#include "vilma/core/clock_sync.h"
#include "vilma/core/error.h"
#include "vilma/drivers/v4l2/fake_v4l2_io.h"
#include "vilma/drivers/v4l2/v4l2_capture.h"

namespace vilma::v4l2 {
namespace {

const char kById[] = "/dev/v4l/by-id/usb-vilma_Fake_Camera_0001-video-index0";

struct Frame {
  int64_t sequence;
  int64_t robot_ns;
  int64_t buffer_ns;
  double error;  // max |pixel - FakeFramePattern(sequence)|
  int type;
};

// Runs the capture for `seconds` and records every frame.
struct Recorder {
  std::vector<Frame> frames;
  std::vector<std::string> log;
  int sleep_ms = 0;  // a slow consumer

  V4l2Capture::FrameCallback Callback() {
    return [this](const CapturedFrame& f) {
      cv::Mat expected = FakeFramePattern(f.sequence, f.image->cols, f.image->rows);
      cv::Mat image8 = *f.image;
      if (f.image->type() == CV_16UC1) f.image->convertTo(image8, CV_8UC1, 1.0 / 256.0);
      frames.push_back({f.sequence, f.robot_ns, f.buffer_monotonic_ns,
                        cv::norm(image8, expected, cv::NORM_INF), f.image->type()});
      if (sleep_ms > 0) std::this_thread::sleep_for(std::chrono::milliseconds(sleep_ms));
    };
  }
  V4l2Capture::LogFunction Log() {
    return [this](const std::string& m) { log.push_back(m); };
  }
};

CaptureOptions Options(uint32_t fourcc, double fps) {
  CaptureOptions o;
  o.format.fourccs = {fourcc};
  o.format.width = 320;
  o.format.height = 240;
  o.format.fps = fps;
  o.reconnect_initial_s = 0.02;
  o.reconnect_max_s = 0.1;
  // 16 buffers = 0.27 s at 60 fps: a loaded machine (CI runs tests in parallel) does not make
  // the fake lose frames in tests that count them exactly.
  o.buffers = 16;
  return o;
}

int64_t Measure() { return MeasureRealtimeMinusMonotonicNs(4); }

TEST_CASE("v4l2 frames arrive at the camera's rate with its pictures and mid-exposure stamps",
          "[v4l2]") {
  FakeV4l2Io fake;
  DriverStatus status("test");
  Recorder rec;
  CaptureOptions options = Options(V4L2_PIX_FMT_GREY, 60);
  options.controls.exposure_us = 4000;
  V4l2Capture capture(&fake, options, &status, Measure, rec.Log());
  capture.Open();
  CHECK(capture.node() == "/dev/video0");
  CHECK(capture.by_id_link() == kById);
  CHECK(status.state() == status_t::OK);
  capture.Run(nullptr, 1.0, rec.Callback());
  // 60 fps for 1 s (the first frame is due one interval after STREAMON).
  REQUIRE(rec.frames.size() >= 57);
  CHECK(rec.frames.size() <= 61);
  for (std::size_t i = 0; i < rec.frames.size(); ++i) {
    CHECK(rec.frames[i].sequence == static_cast<int64_t>(i));
    CHECK(rec.frames[i].error == 0.0);
    if (i > 0) {
      // SOE stamps exactly 1/60 s apart; mid-exposure adds 2 ms to each.
      CHECK(std::llabs(rec.frames[i].buffer_ns - rec.frames[i - 1].buffer_ns - 16666666) <= 1000);
      const int64_t step = rec.frames[i].robot_ns - rec.frames[i - 1].robot_ns;
      CHECK(std::llabs(step - 16666666) < 200000);  // + offset refreshes (< 0.2 ms)
    }
  }
  // robot time = SOE + exposure / 2 on CLOCK_REALTIME.
  const int64_t offset = MeasureRealtimeMinusMonotonicNs();
  CHECK(std::llabs(rec.frames[0].robot_ns - (rec.frames[0].buffer_ns + 2000000 + offset)) <
        1000000);
  CHECK(status.Counter(kStatusDropped) == 0);
  CHECK(status.Counter(kStatusMalformed) == 0);
  CHECK(status.Counter(kCounterFramesDequeued) == static_cast<int64_t>(rec.frames.size()));
  CHECK(status.Metric("exposure_us") == 4000.0);
  CHECK(fake.ControlValue(V4L2_CID_EXPOSURE_ABSOLUTE) == 40);
  capture.Close();
  CHECK(capture.node().empty());
}

TEST_CASE("v4l2 uvcvideo's host stamps are taken as the end of exposure", "[v4l2]") {
  // The same mid-exposure instant whether the camera stamps the start of exposure or, as
  // uvcvideo without hardware timestamps does, the first packet under an SOE flag.
  for (const bool hardware_stamps : {true, false}) {
    CAPTURE(hardware_stamps);
    FakeCameraSpec spec;
    spec.driver = "uvcvideo";
    spec.uvc_hw_timestamps = hardware_stamps;
    FakeV4l2Io fake(spec);
    DriverStatus status("test");
    Recorder rec;
    CaptureOptions options = Options(V4L2_PIX_FMT_GREY, 60);
    options.controls.exposure_us = 8000;
    options.timestamps.offset_refresh_s = 0.0;
    int64_t offset = 0;
    V4l2Capture capture(
        &fake, options, &status, [&offset] { return offset = MeasureRealtimeMinusMonotonicNs(4); },
        rec.Log());
    capture.Open();
    capture.Run(nullptr, 0.3, rec.Callback());
    REQUIRE(rec.frames.size() >= 5);
    // Frame k completes (ends its exposure: the fake reads out instantly) at ready_k; its
    // SOE stamp is ready_k - 8 ms, its first packet ready_k. Mid-exposure: ready_k - 4 ms.
    const Frame& f = rec.frames.back();
    const int64_t ready_ns = hardware_stamps ? f.buffer_ns + 8000000 : f.buffer_ns;
    CHECK(std::llabs(f.robot_ns - offset - (ready_ns - 4000000)) < 100000);
  }
}

TEST_CASE("v4l2 every pixel format reaches the callback as the camera's picture", "[v4l2]") {
  struct Case {
    uint32_t fourcc;
    bool keep_16_bit;
    int type;
    double tolerance;
  };
  for (const Case& c :
       {Case{V4L2_PIX_FMT_Y16, false, CV_8UC1, 0.0}, Case{V4L2_PIX_FMT_Y16, true, CV_16UC1, 1.0},
        Case{V4L2_PIX_FMT_YUYV, false, CV_8UC1, 0.0},
        Case{V4L2_PIX_FMT_MJPEG, false, CV_8UC1, 12.0}}) {
    CAPTURE(FourccName(c.fourcc), c.keep_16_bit);
    FakeV4l2Io fake;
    DriverStatus status("test");
    Recorder rec;
    CaptureOptions options = Options(c.fourcc, 30);
    options.format.width = 640;
    options.format.height = 480;
    options.keep_16_bit = c.keep_16_bit;
    V4l2Capture capture(&fake, options, &status, Measure, rec.Log());
    capture.Open();
    capture.Run(nullptr, 0.25, rec.Callback());
    REQUIRE(rec.frames.size() >= 5);
    for (const Frame& f : rec.frames) {
      CHECK(f.type == c.type);
      CHECK(f.error <= c.tolerance);
    }
    CHECK(status.Counter(kStatusMalformed) == 0);
  }
}

TEST_CASE("v4l2 a multi-planar-only device (MIPI receivers) streams the same frames", "[v4l2]") {
  for (const uint32_t fourcc : {V4L2_PIX_FMT_GREY, V4L2_PIX_FMT_YUYV, V4L2_PIX_FMT_MJPEG}) {
    CAPTURE(FourccName(fourcc));
    FakeCameraSpec spec;
    spec.multiplanar = true;
    FakeV4l2Io fake(spec);
    // The single-planar API is refused, as such a driver does.
    const int fd = fake.Open("/dev/video0");
    v4l2_fmtdesc desc{};
    desc.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
    CHECK(fake.Ioctl(fd, VIDIOC_ENUM_FMT, &desc) == -EINVAL);
    fake.Close(fd);

    DriverStatus status("test");
    Recorder rec;
    CaptureOptions options = Options(fourcc, 30);
    options.format.width = 640;
    options.format.height = 480;
    V4l2Capture capture(&fake, options, &status, Measure, rec.Log());
    capture.Open();
    CHECK(capture.format().fourcc == fourcc);
    CHECK(capture.format().width == 640);
    CHECK(capture.format().bytes_per_line == (fourcc == V4L2_PIX_FMT_MJPEG  ? 0
                                              : fourcc == V4L2_PIX_FMT_YUYV ? 1280
                                                                            : 640));
    capture.Run(nullptr, 0.3, rec.Callback());
    REQUIRE(rec.frames.size() >= 5);
    for (std::size_t i = 0; i < rec.frames.size(); ++i) {
      CHECK(rec.frames[i].sequence == static_cast<int64_t>(i));
      CHECK(rec.frames[i].error <= (fourcc == V4L2_PIX_FMT_MJPEG ? 12.0 : 0.0));
    }
    CHECK(status.Counter(kStatusMalformed) == 0);
  }
}

TEST_CASE("v4l2 sequence gaps are counted as dropped, error buffers as malformed", "[v4l2]") {
  FakeV4l2Io fake;
  fake.DropSequences({5, 6, 7, 20});
  fake.CorruptSequences({10, 11});
  DriverStatus status("test");
  Recorder rec;
  V4l2Capture capture(&fake, Options(V4L2_PIX_FMT_GREY, 60), &status, Measure, rec.Log());
  capture.Open();
  capture.Run(nullptr, 0.5, rec.Callback());
  REQUIRE(rec.frames.size() >= 22);
  CHECK(status.Counter(kStatusDropped) == 4);
  CHECK(status.Counter(kStatusMalformed) == 2);
  for (const Frame& f : rec.frames) {
    CHECK(f.sequence != 5);
    CHECK(f.sequence != 10);  // not published
    CHECK(f.error == 0.0);
  }
}

TEST_CASE("v4l2 a slow consumer: frames the kernel had no buffer for show up as drops", "[v4l2]") {
  FakeV4l2Io fake;
  DriverStatus status("test");
  Recorder rec;
  rec.sleep_ms = 40;  // 25 Hz of work at 60 fps
  CaptureOptions options = Options(V4L2_PIX_FMT_GREY, 60);
  options.buffers = 2;
  V4l2Capture capture(&fake, options, &status, Measure, rec.Log());
  capture.Open();
  capture.Run(nullptr, 1.0, rec.Callback());
  const FakeCameraStats stats = fake.stats();
  REQUIRE(stats.frames_lost_no_buffer > 10);
  // Every lost frame before the last dequeued one is seen as a gap.
  const int64_t last = rec.frames.back().sequence;
  CHECK(status.Counter(kStatusDropped) == last + 1 - static_cast<int64_t>(rec.frames.size()));
  CHECK(status.Counter(kStatusDropped) <= stats.frames_lost_no_buffer);
  // The fake also lost frames after the last dequeue (up to the ring plus the frames due
  // during the consumer's last 40 ms and the final poll): not gaps yet.
  CHECK(status.Counter(kStatusDropped) >= stats.frames_lost_no_buffer - 10);
}

TEST_CASE("v4l2 unplug and replug: the stream comes back, counted", "[v4l2]") {
  FakeV4l2Io fake;
  DriverStatus status("test");
  Recorder rec;
  V4l2Capture capture(&fake, Options(V4L2_PIX_FMT_GREY, 60), &status, Measure, rec.Log());
  capture.Open();
  fake.UnplugAfterFrames(20, 0.3);
  std::atomic<bool> stop{false};
  std::atomic<bool> degraded_seen{false};
  std::atomic<bool> watching{true};
  std::thread watcher([&] {
    while (watching) {
      if (status.state() == status_t::DEGRADED) degraded_seen = true;
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
  });
  capture.Run(&stop, 1.5, rec.Callback());
  watching = false;
  watcher.join();
  CHECK(degraded_seen);
  CHECK(status.state() == status_t::OK);
  CHECK(status.Counter(kCounterDeviceLost) == 1);
  CHECK(status.Counter(kStatusReconnects) == 1);
  CHECK(status.Counter(kStatusDropped) == 0);  // the new stream restarts at 0: no false drops
  CHECK(fake.stats().unplugs == 1);
  // Before: 19 frames; after: the rest of 1.5 s minus ~0.3-0.4 s down.
  int restarts = 0;
  for (std::size_t i = 1; i < rec.frames.size(); ++i) {
    if (rec.frames[i].sequence < rec.frames[i - 1].sequence) ++restarts;
  }
  CHECK(restarts == 1);
  CHECK(rec.frames.size() >= 60);
  bool logged = false;
  for (const std::string& line : rec.log)
    logged = logged || line.find("reconnected") != std::string::npos;
  CHECK(logged);
}

TEST_CASE("v4l2 a camera that comes back as another /dev/videoN is found by its by-id link",
          "[v4l2]") {
  FakeV4l2Io fake;
  DriverStatus status("test");
  Recorder rec;
  CaptureOptions options = Options(V4L2_PIX_FMT_GREY, 60);
  options.device = "/dev/video0";
  options.controls.exposure_us = 3000;
  V4l2Capture capture(&fake, options, &status, Measure, rec.Log());
  capture.Open();
  fake.UnplugAfterFrames(10, 0.2, "/dev/video2");
  capture.Run(nullptr, 1.0, rec.Callback());
  CHECK(fake.CurrentNode() == "/dev/video2");
  CHECK(capture.node() == "/dev/video2");
  CHECK(status.Counter(kStatusReconnects) == 1);
  CHECK(rec.frames.size() >= 30);
  // The replugged camera started from its defaults: the controls were set again.
  CHECK(fake.ControlValue(V4L2_CID_EXPOSURE_AUTO) == V4L2_EXPOSURE_MANUAL);
  CHECK(fake.ControlValue(V4L2_CID_EXPOSURE_ABSOLUTE) == 30);
}

TEST_CASE("v4l2 a long outage backs off and is recovered, a stall restarts the stream", "[v4l2]") {
  FakeV4l2Io fake;
  DriverStatus status("test");
  Recorder rec;
  V4l2Capture capture(&fake, Options(V4L2_PIX_FMT_GREY, 60), &status, Measure, rec.Log());
  capture.Open();
  fake.Unplug(0.8);
  const int64_t opens_before = fake.stats().opens;
  capture.Run(nullptr, 1.2, rec.Callback());
  CHECK(status.Counter(kStatusReconnects) == 1);
  // 0.02 s doubling to 0.1 s over 0.8 s: about 10 attempts, not hundreds.
  CHECK(fake.stats().opens - opens_before == 1);  // only the successful one opens a node
  CHECK(rec.frames.size() >= 10);

  // No frame for frame_timeout_s: the stream is restarted (counted), then frames flow again.
  FakeV4l2Io stalled;
  DriverStatus stalled_status("test");
  Recorder stalled_rec;
  CaptureOptions options = Options(V4L2_PIX_FMT_GREY, 60);
  options.frame_timeout_s = 0.2;
  V4l2Capture stalled_capture(&stalled, options, &stalled_status, Measure, stalled_rec.Log());
  stalled_capture.Open();
  stalled.SetDeliveryDelayNs(int64_t{3600} * 1000000000);
  stalled_capture.Run(nullptr, 0.5, stalled_rec.Callback());
  CHECK(stalled_status.Counter(kCounterStreamRestarts) >= 1);
  CHECK(stalled_status.Counter(kCounterDeviceLost) == 0);
}

TEST_CASE("v4l2 a step of the realtime clock moves the stamps and is counted", "[v4l2]") {
  FakeV4l2Io fake;
  DriverStatus status("test");
  Recorder rec;
  CaptureOptions options = Options(V4L2_PIX_FMT_GREY, 60);
  options.timestamps.offset_refresh_s = 0.0;  // every frame
  std::atomic<int> measurements{0};
  // REALTIME - MONOTONIC as measured, stepped by +3 s from the 20th measurement on (ntpdate).
  auto measure = [&measurements] {
    return MeasureRealtimeMinusMonotonicNs(4) + (++measurements > 20 ? 3000000000LL : 0);
  };
  V4l2Capture capture(&fake, options, &status, measure, rec.Log());
  capture.Open();
  capture.Run(nullptr, 0.6, rec.Callback());
  REQUIRE(rec.frames.size() >= 25);
  CHECK(status.Counter(kStatusTimestampResets) == 1);
  const int64_t jump = rec.frames[20].robot_ns - rec.frames[19].robot_ns;
  CHECK(std::llabs(jump - 3000000000LL - 16666666) < 1000000);
}

TEST_CASE("v4l2 buffers without monotonic stamps are stamped at dequeue, counted", "[v4l2]") {
  FakeCameraSpec spec;
  spec.timestamp_flags = V4L2_BUF_FLAG_TIMESTAMP_COPY;
  FakeV4l2Io fake(spec);
  DriverStatus status("test");
  Recorder rec;
  V4l2Capture capture(&fake, Options(V4L2_PIX_FMT_GREY, 60), &status, Measure, rec.Log());
  capture.Open();
  capture.Run(nullptr, 0.3, rec.Callback());
  REQUIRE(!rec.frames.empty());
  CHECK(status.Counter(kCounterTimestampFallbacks) == static_cast<int64_t>(rec.frames.size()));
}

TEST_CASE("v4l2 a first open that cannot work is an error naming the device and what it offers",
          "[v4l2]") {
  FakeV4l2Io fake;
  DriverStatus status("test");
  auto open_error = [&](const CaptureOptions& options) -> std::string {
    V4l2Capture capture(&fake, options, &status, Measure, nullptr);
    try {
      capture.Open();
    } catch (const InputError& e) {
      return e.what();
    }
    return "";
  };
  CaptureOptions options = Options(V4L2_PIX_FMT_GREY, 30);
  options.device = "/dev/video7";
  CHECK(open_error(options).find("/dev/video7: an existing V4L2 device") != std::string::npos);
  options.device = "/dev/video1";  // the metadata node
  CHECK(open_error(options).find("not a video capture node") != std::string::npos);
  options = Options(V4L2_PIX_FMT_YUYV, 30);
  options.format.width = 1280;
  options.format.height = 720;
  options.format.require_size = true;
  CHECK(open_error(options).find("asked for 1280x720, the device set 640x480 (YUYV sizes: "
                                 "640x480, 320x240)") != std::string::npos);
  options = Options(V4L2_PIX_FMT_GREY, 30);
  options.controls.gain = 1000;
  CHECK(open_error(options).find("gain=1000 is out of range 0..100") != std::string::npos);
  // Nothing stays open after a failed open.
  options = Options(V4L2_PIX_FMT_GREY, 30);
  CHECK(open_error(options).empty());

  options.buffers = 1;
  CHECK_THROWS_AS(V4l2Capture(&fake, options, &status, Measure, nullptr), InputError);
}

TEST_CASE("v4l2 the kernel wrapper: a device that is not V4L2, poll and open errors", "[v4l2]") {
  SystemV4l2Io io;
  // /dev/null opens but answers no V4L2 ioctl (ENOTTY): the capture says so.
  DriverStatus status("test");
  CaptureOptions options;
  options.device = "/dev/null";
  V4l2Capture capture(&io, options, &status, Measure, nullptr);
  try {
    capture.Open();
    FAIL("/dev/null opened as a camera");
  } catch (const InputError& e) {
    CHECK(std::string(e.what()).find("/dev/null: VIDIOC_QUERYCAP failed") != std::string::npos);
  }
  CHECK(io.Open("/nonexistent/video0") == -ENOENT);
  CHECK(io.ResolveNode("/nonexistent/video0").empty());
  CHECK(io.ResolveNode("/dev/null") == "/dev/null");
  const int fd = io.Open("/dev/null");
  REQUIRE(fd >= 0);
  v4l2_capability cap{};
  CHECK(io.Ioctl(fd, VIDIOC_QUERYCAP, &cap) == -ENOTTY);
  CHECK(io.Map(fd, 4096, 0) == nullptr);  // /dev/null has no mmap (ENODEV)
  io.Close(fd);
  // Poll: a pipe with data is ready, an empty one times out, a hung-up one is an error.
  int pipe_fds[2];
  REQUIRE(::pipe(pipe_fds) == 0);
  CHECK(io.Poll(pipe_fds[0], 0) == 0);
  REQUIRE(::write(pipe_fds[1], "x", 1) == 1);
  CHECK(io.Poll(pipe_fds[0], 0) == 1);
  char byte = 0;
  REQUIRE(::read(pipe_fds[0], &byte, 1) == 1);
  ::close(pipe_fds[1]);
  CHECK(io.Poll(pipe_fds[0], 0) == -ENODEV);  // POLLHUP
  ::close(pipe_fds[0]);
  // Nodes are listed by number; here there may be none.
  const std::vector<std::string> nodes = io.ListDeviceNodes();
  for (std::size_t i = 1; i < nodes.size(); ++i) CHECK(nodes[i - 1] != nodes[i]);
  const int64_t t0 = io.MonotonicNowNs();
  CHECK(io.MonotonicNowNs() >= t0);
}

}  // namespace
}  // namespace vilma::v4l2

#else
TEST_CASE("vilma-v4l2 capture loop", "[v4l2]") {
  VILMA_SKIP("vilma-v4l2 is not built here (<linux/videodev2.h> missing)");
}
#endif
