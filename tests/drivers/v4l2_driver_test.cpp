// The vilma-v4l2 program: message building, its command line, and the executable end to end
// over LCM on loopback with the fake camera (--fake), and with a real /dev/video0 where there
// is one (skipped here otherwise).
#include <catch2/catch.hpp>

#include "test_skip.h"

#ifdef VILMA_HAVE_DRIVER_V4L2
#include <algorithm>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <vector>
#include <vilma/status_t.hpp>

#include "integration/process_util.h"
#include "vilma/drivers/lcm_convert.h"
#include "vilma/drivers/v4l2/fake_v4l2_io.h"
#include "vilma/drivers/v4l2/v4l2_driver.h"

namespace vilma::v4l2 {
namespace {

const std::string kProgram = std::string(VILMA_BINARY_DIR) + "/bin/vilma-v4l2";

TEST_CASE("v4l2 published seq numbers stay continuous across stream restarts", "[v4l2]") {
  PublishedSequence seq;
  CHECK(seq.Next(0) == 0);
  CHECK(seq.Next(1) == 1);
  CHECK(seq.Next(4) == 4);  // frames 2, 3 lost: a gap on the bus too
  CHECK(seq.Next(0) == 5);  // a new stream after a reconnect
  CHECK(seq.Next(1) == 6);
  PublishedSequence late;
  CHECK(late.Next(17) == 0);  // a stream that starts at another number still starts at 0
  CHECK(late.Next(18) == 1);
}

TEST_CASE("v4l2 frames become GRAY8 or GRAY16 image_t with exposure and utime", "[v4l2]") {
  cv::Mat gray16(4, 6, CV_16UC1, cv::Scalar(40000));
  CapturedFrame frame;
  frame.image = &gray16;
  frame.robot_ns = 1700000000123456789LL;
  frame.exposure_us = 2500;
  image_t msg;
  REQUIRE(FrameToMessage(frame, 9, 2, &msg).empty());
  CHECK(msg.pixel_format == image_t::GRAY16);
  CHECK(msg.utime == 1700000000123457LL);
  CHECK(msg.seq == 9);
  CHECK(msg.camera_id == 2);
  CHECK(msg.exposure_us == 2500);
  CHECK(msg.row_stride == 12);
  cv::Mat gray8(4, 6, CV_8UC1, cv::Scalar(7));
  frame.image = &gray8;
  REQUIRE(FrameToMessage(frame, 10, 0, &msg).empty());
  CHECK(msg.pixel_format == image_t::GRAY8);
  CHECK(msg.size == 24);
}

// Collects CAM0 images and status reports from the bus.
class BusRecorder {
 public:
  explicit BusRecorder(const std::string& url) : lcm_(url) {
    lcm_.subscribe("CAM0", &BusRecorder::OnImage, this);
    lcm_.subscribe("VILMA_STATUS_CAM0", &BusRecorder::OnStatus, this);
  }
  bool good() { return lcm_.good(); }
  // Handles messages until `process` has exited and the bus was quiet for 0.5 s.
  void Drain(test::ChildProcess* process, double timeout_s) {
    const auto deadline =
        std::chrono::steady_clock::now() + std::chrono::duration<double>(timeout_s);
    int quiet = 0;
    while (std::chrono::steady_clock::now() < deadline) {
      const int handled = lcm_.handleTimeout(100);
      quiet = (handled > 0) ? 0 : quiet + 1;
      if (!process->running() && quiet >= 5) break;
    }
  }

  std::vector<image_t> images;
  std::vector<int64_t> receive_utime;
  std::vector<status_t> reports;

 private:
  void OnImage(const lcm::ReceiveBuffer* rbuf, const std::string&, const image_t* msg) {
    images.push_back(*msg);
    receive_utime.push_back(rbuf->recv_utime);
  }
  void OnStatus(const lcm::ReceiveBuffer*, const std::string&, const status_t* msg) {
    reports.push_back(*msg);
  }
  lcm::LCM lcm_;
};

int64_t CounterOf(const status_t& report, const std::string& name) {
  for (int i = 0; i < report.num_counters; ++i) {
    if (report.counter_names[static_cast<std::size_t>(i)] == name) {
      return report.counter_values[static_cast<std::size_t>(i)];
    }
  }
  return -1;
}

double MetricOf(const status_t& report, const std::string& name) {
  for (int i = 0; i < report.num_metrics; ++i) {
    if (report.metric_names[static_cast<std::size_t>(i)] == name) {
      return report.metric_values[static_cast<std::size_t>(i)];
    }
  }
  return -1.0;
}

TEST_CASE("vilma-v4l2 --help, usage errors, bad config, --list", "[v4l2][program]") {
  if (!test::FileExists(kProgram)) VILMA_SKIP(kProgram << " is not built");
  const std::string dir = test::ScratchDir();
  test::ChildProcess help({kProgram, "--help"}, dir + "/v4l2_help.out");
  CHECK(help.Wait(10) == kExitOk);
  CHECK(test::ReadTextFile(dir + "/v4l2_help.out").find("Usage: vilma-v4l2") != std::string::npos);

  test::ChildProcess usage({kProgram, "--fps", "many"}, dir + "/v4l2_usage.out");
  CHECK(usage.Wait(10) == kExitUsage);
  CHECK(test::ReadTextFile(dir + "/v4l2_usage.out").find("--fps: 'many' is not a number") !=
        std::string::npos);

  const std::string config = dir + "/v4l2_bad.yaml";
  std::ofstream(config) << "device: /dev/video0\nexposure_us: 100\n";
  test::ChildProcess bad({kProgram, "--config", config}, dir + "/v4l2_bad.out");
  CHECK(bad.Wait(10) == kExitUsage);
  CHECK(test::ReadTextFile(dir + "/v4l2_bad.out").find(config + ": exposure_us: no such key") !=
        std::string::npos);

  test::ChildProcess list({kProgram, "--list", "--fake"}, dir + "/v4l2_list.out");
  CHECK(list.Wait(10) == kExitOk);
  CHECK(test::ReadTextFile(dir + "/v4l2_list.out").find("GREY: 640x480, 752x480, 320x240") !=
        std::string::npos);

  // A device that is not there: exit 1 with the path in the message.
  test::ChildProcess absent(
      {kProgram, "--device", "/dev/video-vilma-absent", "--lcm-url", "memq://"},
      dir + "/v4l2_absent.out");
  CHECK(absent.Wait(10) == kExitRuntime);
  CHECK(test::ReadTextFile(dir + "/v4l2_absent.out")
            .find("/dev/video-vilma-absent: an existing V4L2 device") != std::string::npos);
}

TEST_CASE("vilma-v4l2 --fake publishes the camera's frames on LCM at its rate", "[v4l2][program]") {
  if (!test::FileExists(kProgram)) VILMA_SKIP(kProgram << " is not built");
  const std::string url = test::UniqueLcmUrl();
  BusRecorder bus(url);
  REQUIRE(bus.good());
  const std::string out = test::ScratchDir() + "/v4l2_fake.out";
  // The fake's GREY 320x240 at 60 fps, fixed exposure: 2 s.
  test::ChildProcess driver({kProgram, "--fake", "--seconds", "2", "--lcm-url", url, "--size",
                             "320x240", "--fps", "60", "--exposure", "2000", "--buffers", "16"},
                            out);
  bus.Drain(&driver, 15.0);
  REQUIRE(driver.Wait(5) == kExitOk);
  INFO(test::ReadTextFile(out));

  const std::vector<image_t>& images = bus.images;
  REQUIRE(images.size() >= 100);
  CHECK(images.size() <= 121);
  for (std::size_t i = 0; i < images.size(); ++i) {
    const image_t& m = images[i];
    CHECK(m.seq == static_cast<int64_t>(i));  // no loss on the way
    CHECK(m.pixel_format == image_t::GRAY8);
    CHECK(m.width == 320);
    CHECK(m.exposure_us == 2000);
    if (i > 0) CHECK(m.utime > images[i - 1].utime);
    cv::Mat image;
    REQUIRE(MessageToImage(m, &image).empty());
    CHECK(cv::norm(image, FakeFramePattern(m.seq, 320, 240), cv::NORM_INF) == 0.0);
  }
  // The rate from the stamps, within 5 % (here: to 0.1 %).
  const double span_s = (images.back().utime - images.front().utime) * 1e-6;
  const double rate_hz = (static_cast<double>(images.size()) - 1.0) / span_s;
  CHECK(rate_hz == Approx(60.0).epsilon(0.05));
  // utime is mid-exposure on CLOCK_REALTIME: before the message was received, by less than
  // the exposure plus a frame's delivery.
  std::vector<int64_t> age_us;
  for (std::size_t i = 0; i < images.size(); ++i) {
    age_us.push_back(bus.receive_utime[i] - images[i].utime);
  }
  std::sort(age_us.begin(), age_us.end());
  CHECK(age_us.front() > 0);
  CHECK(age_us[age_us.size() / 2] < 50000);  // loose: CI runs tests in parallel

  // Status: OK reports with the counters, the last one STOPPING.
  REQUIRE(bus.reports.size() >= 2);
  const status_t& last = bus.reports.back();
  CHECK(last.node == "vilma-v4l2");
  CHECK(last.state == status_t::STOPPING);
  CHECK(CounterOf(last, "published") == static_cast<int64_t>(images.size()));
  CHECK(CounterOf(last, "dropped") == 0);
  CHECK(CounterOf(last, "reconnects") == 0);
  // The driver's own latency, end of frame -> published: small on an idle machine.
  CHECK(MetricOf(last, "latency_p50_ms") > 0.0);
  CHECK(MetricOf(last, "latency_p50_ms") < 50.0);
  bool ok_seen = false;
  for (const status_t& r : bus.reports) ok_seen = ok_seen || r.state == status_t::OK;
  CHECK(ok_seen);
}

TEST_CASE(
    "vilma-v4l2 --fake: an unplugged camera is recovered, counted on the status channel, "
    "and SIGTERM stops it cleanly",
    "[v4l2][program]") {
  if (!test::FileExists(kProgram)) VILMA_SKIP(kProgram << " is not built");
  const std::string url = test::UniqueLcmUrl();
  BusRecorder bus(url);
  REQUIRE(bus.good());
  const std::string out = test::ScratchDir() + "/v4l2_unplug.out";
  // 60 fps 320x240; unplugged at the 30th frame for 0.5 s; no --seconds: SIGTERM ends it.
  test::ChildProcess driver(
      {kProgram, "--fake", "--size", "320x240", "--fps", "60", "--fake-unplug-after", "30",
       "--lcm-url", url, "--status-period-s", "0.1", "--buffers", "16"},
      out);
  // Until 30 frames have come after the outage (a loaded machine starts the process late).
  auto frames_after_outage = [&bus] {
    const std::vector<image_t>& images = bus.images;
    for (std::size_t i = 1; i < images.size(); ++i) {
      if (images[i].utime - images[i - 1].utime >= 400000) return images.size() - i;
    }
    return std::size_t{0};
  };
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (frames_after_outage() < 30 && std::chrono::steady_clock::now() < deadline &&
         driver.running()) {
    bus.Drain(&driver, 0.1);
  }
  REQUIRE(driver.running());
  driver.Signal(SIGTERM);
  bus.Drain(&driver, 10.0);
  REQUIRE(driver.Wait(5) == kExitOk);
  INFO(test::ReadTextFile(out));

  const std::vector<image_t>& images = bus.images;
  REQUIRE(images.size() >= 59);  // 29 before (the 30th is lost with the camera), 30 after
  int64_t longest_gap_us = 0;
  for (std::size_t i = 1; i < images.size(); ++i) {
    CHECK(images[i].seq == images[i - 1].seq + 1);  // continuous across the new stream
    CHECK(images[i].utime > images[i - 1].utime);
    longest_gap_us = std::max(longest_gap_us, images[i].utime - images[i - 1].utime);
  }
  CHECK(longest_gap_us >= 500000);  // the outage
  CHECK(longest_gap_us < 2000000);
  bool degraded_seen = false;
  for (const status_t& r : bus.reports) {
    degraded_seen = degraded_seen || r.state == status_t::DEGRADED;
  }
  CHECK(degraded_seen);
  REQUIRE(!bus.reports.empty());
  const status_t& last = bus.reports.back();
  CHECK(last.state == status_t::STOPPING);
  CHECK(CounterOf(last, "reconnects") == 1);
  CHECK(CounterOf(last, "device_lost") == 1);
  CHECK(CounterOf(last, "dropped") == 0);
  CHECK(CounterOf(last, "published") == static_cast<int64_t>(images.size()));
}

TEST_CASE("vilma-v4l2 --device /dev/video0 --seconds 2 on a real camera", "[v4l2][program]") {
  if (!test::FileExists("/dev/video0")) {
    // No camera on this machine (CI has none): nothing to run against.
    VILMA_SKIP_OPTIONAL("/dev/video0 is absent: the real-camera test needs a V4L2 camera");
  }
  if (!test::FileExists(kProgram)) VILMA_SKIP(kProgram << " is not built");
  const std::string url = test::UniqueLcmUrl();
  BusRecorder bus(url);
  REQUIRE(bus.good());
  const std::string out = test::ScratchDir() + "/v4l2_real.out";
  test::ChildProcess driver(
      {kProgram, "--device", "/dev/video0", "--seconds", "2", "--lcm-url", url}, out);
  bus.Drain(&driver, 20.0);
  const int status = driver.Wait(5);
  INFO(test::ReadTextFile(out));
  if (status == kExitRuntime &&
      test::ReadTextFile(out).find("not a video capture node") != std::string::npos) {
    VILMA_SKIP_OPTIONAL("/dev/video0 is not a capture node");
  }
  REQUIRE(status == kExitOk);
  REQUIRE(bus.images.size() >= 5);
  for (std::size_t i = 1; i < bus.images.size(); ++i) {
    CHECK(bus.images[i].utime > bus.images[i - 1].utime);
    CHECK(bus.images[i].seq > bus.images[i - 1].seq);
  }
  CHECK(bus.images.front().width > 0);
  REQUIRE(!bus.reports.empty());
  CHECK(CounterOf(bus.reports.back(), "published") == static_cast<int64_t>(bus.images.size()));
}

}  // namespace
}  // namespace vilma::v4l2

#else
TEST_CASE("vilma-v4l2 program", "[v4l2]") {
  VILMA_SKIP("vilma-v4l2 is not built here (<linux/videodev2.h> missing)");
}
#endif
