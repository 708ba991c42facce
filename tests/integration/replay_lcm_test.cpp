// vilma-replay as a real process over LCM on loopback (udpm, ttl=0):
//  (a)+(c) an in-test subscriber receives every message of 2 s of EuRoC (two 752x480 cameras
//          at 20 Hz + IMU at 200 Hz, in real time) in order, with the dataset's exact stamps and
//          pixels, with the recv_buf_size of docs/lcm.md: no loss;
//  (b)     what lcm-logger records of a replay equals what `vilma-replay --to-log` writes.
#include <catch2/catch.hpp>
#include <algorithm>
#include <atomic>
#include <cstdio>
#include <lcm/lcm-cpp.hpp>
#include <mutex>
#include <thread>

#include "integration/process_util.h"
#include "vilma/core/asl_dataset.h"
#include "vilma/core/time.h"
#include "vilma/drivers/lcm_convert.h"
#include "vilma/drivers/lcm_log.h"
#include "test_skip.h"

namespace vilma {
namespace {

const std::string kReplay = std::string(VILMA_BINARY_DIR) + "/bin/vilma-replay";
const std::string kDataset = std::string(VILMA_SHARED_DATA_DIR) + "/euroc_V1_01_micro";

struct Received {
  std::string channel;
  std::vector<uint8_t> data;
};

// Subscribes to all channels of `url` on a thread of its own, keeping every message.
class Subscriber {
 public:
  explicit Subscriber(const std::string& url) : lcm_(url) {
    REQUIRE(lcm_.good());
    lcm_.subscribeFunction(".*", &Subscriber::OnMessage, this);
    thread_ = std::thread([this] {
      while (!stop_) lcm_.handleTimeout(20);
    });
  }
  ~Subscriber() {
    stop_ = true;
    thread_.join();
  }
  size_t count() {
    std::lock_guard<std::mutex> lock(mutex_);
    return messages_.size();
  }
  std::vector<Received> messages() {
    std::lock_guard<std::mutex> lock(mutex_);
    return messages_;
  }
  lcm::LCM& lcm() { return lcm_; }

 private:
  static void OnMessage(const lcm::ReceiveBuffer* rbuf, const std::string& channel,
                        Subscriber* self) {
    const auto* p = static_cast<const uint8_t*>(rbuf->data);
    std::lock_guard<std::mutex> lock(self->mutex_);
    self->messages_.push_back({channel, std::vector<uint8_t>(p, p + rbuf->data_size)});
  }
  lcm::LCM lcm_;
  std::atomic<bool> stop_{false};
  std::mutex mutex_;
  std::vector<Received> messages_;
  std::thread thread_;
};

// What the replay of [first stamp, first stamp + end_s] must send, derived here from the
// dataset independently of the replay code: (channel, t_ns, seq, image path or IMU index).
struct Expected {
  std::string channel;
  int64_t t_ns;
  int64_t seq;
  int stream;  // -1 IMU, else camera
  std::string image_path;
  ImuSample imu;
};

std::vector<Expected> ExpectedMessages(const AslDataset& dataset, double end_s) {
  int64_t t_first = dataset.imu().front().t_ns;
  for (const AslCamera& camera : dataset.cameras()) {
    t_first = std::min(t_first, camera.frames.front().t_ns);
  }
  const int64_t t_end = t_first + SecondsToNs(end_s);
  std::vector<Expected> expected;
  int64_t seq = 0;
  for (const ImuSample& s : dataset.imu()) {
    if (s.t_ns <= t_end) expected.push_back({"IMU", s.t_ns, seq++, -1, "", s});
  }
  for (size_t c = 0; c < dataset.cameras().size(); ++c) {
    seq = 0;
    for (const CameraFrame& f : dataset.cameras()[c].frames) {
      if (f.t_ns <= t_end) {
        expected.push_back({"CAM" + std::to_string(c), f.t_ns, seq++, static_cast<int>(c),
                            f.image_path, ImuSample()});
      }
    }
  }
  std::stable_sort(expected.begin(), expected.end(), [](const Expected& a, const Expected& b) {
    return a.t_ns != b.t_ns ? a.t_ns < b.t_ns : a.stream < b.stream;
  });
  return expected;
}

bool HaveDataset() {
  if (test::FileExists(kDataset + "/mav0/cam0/data.csv")) return true;
  VILMA_SKIP_NOTE(kDataset << " is absent (set VILMA_SHARED_DATA_DIR)");
  return false;
}

TEST_CASE("vilma-replay in real time over LCM loopback: all messages, in order, exact",
          "[integration][replay][lcm]") {
  if (!HaveDataset()) return;
  const std::string url = test::UniqueLcmUrl();
  const std::string out = test::ScratchDir() + "/replay_realtime.out";
  const double end_s = 2.0;  // 2 s: 41 stereo pairs + 401 IMU samples, ~30 MB
  const AslDataset dataset = AslDataset::Open(kDataset);
  const std::vector<Expected> expected = ExpectedMessages(dataset, end_s);

  Subscriber subscriber(url);
  const auto start = std::chrono::steady_clock::now();
  test::ChildProcess replay({kReplay, kDataset, "--end", std::to_string(end_s), "--lcm-url", url},
                            out);
  const int status = replay.Wait(30.0);
  const double wall_s = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  INFO(test::ReadTextFile(out));
  REQUIRE(status == 0);
  CHECK(wall_s >= end_s);  // real time, not faster
  for (int i = 0; i < 100 && subscriber.count() < expected.size(); ++i) {
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  const std::vector<Received> received = subscriber.messages();
  REQUIRE(received.size() == expected.size());  // (c) no loss

  for (size_t i = 0; i < expected.size(); ++i) {
    const Expected& e = expected[i];
    const Received& r = received[i];
    INFO("message " << i << " expected " << e.channel << " seq " << e.seq);
    REQUIRE(r.channel == e.channel);
    if (e.stream < 0) {
      imu_t msg;
      ImuSample sample;
      REQUIRE(DecodeImuMessage(r.data.data(), static_cast<int>(r.data.size()), &msg, &sample)
                  .empty());
      CHECK(msg.utime == NsToUtime(e.t_ns));
      CHECK(msg.seq == e.seq);
      CHECK(sample.omega_I == e.imu.omega_I);
      CHECK(sample.a_I == e.imu.a_I);
    } else {
      image_t msg;
      REQUIRE(DecodeImageMessage(r.data.data(), static_cast<int>(r.data.size()), &msg).empty());
      CHECK(msg.utime == NsToUtime(e.t_ns));
      CHECK(msg.seq == e.seq);
      CHECK(msg.camera_id == e.stream);
      CHECK(msg.pixel_format == image_t::GRAY8);
      cv::Mat image;
      REQUIRE(MessageToImage(msg, &image).empty());
      const cv::Mat truth = AslDataset::LoadImage(e.image_path);
      REQUIRE(image.size() == cv::Size(752, 480));
      CHECK(cv::norm(image, truth, cv::NORM_INF) == 0);
    }
  }
}

TEST_CASE("lcm-logger's recording of vilma-replay equals vilma-replay --to-log",
          "[integration][replay][lcm]") {
  if (!HaveDataset()) return;
  if (!test::HaveProgram("lcm-logger")) {
    VILMA_SKIP("lcm-logger not found (Debian package liblcm-bin)");
  }
  const std::string url = test::UniqueLcmUrl();
  const std::string dir = test::ScratchDir();
  const std::string recorded = dir + "/recorded.lcmlog";
  const std::string written = dir + "/written.lcmlog";
  const std::string end = "1.0";

  test::ChildProcess to_log({kReplay, kDataset, "--end", end, "--to-log", written, "--quiet"},
                            dir + "/to_log.out");
  REQUIRE(to_log.Wait(30.0) == 0);

  test::ChildProcess logger({"lcm-logger", "-f", "-q", "--lcm-url=" + url, recorded},
                            dir + "/logger.out");
  // lcm-logger is ready when a probe message shows up in its file (flushed every 100 ms).
  {
    lcm::LCM probe(url);
    REQUIRE(probe.good());
    const uint8_t byte = 0;
    bool ready = false;
    for (int i = 0; i < 100 && !ready; ++i) {
      probe.publish("PROBE", &byte, 1);
      std::this_thread::sleep_for(std::chrono::milliseconds(50));
      ready = test::FileSize(recorded) > 0;
    }
    REQUIRE(ready);
  }
  test::ChildProcess replay({kReplay, kDataset, "--end", end, "--lcm-url", url, "--quiet"},
                            dir + "/replay.out");
  REQUIRE(replay.Wait(30.0) == 0);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));  // last messages, flush
  logger.Signal(SIGINT);
  REQUIRE(logger.Wait(10.0) == 0);

  std::vector<LcmLogEvent> from_logger;
  for (LcmLogEvent& e : ReadLcmLog(recorded)) {
    if (e.channel != "PROBE") from_logger.push_back(std::move(e));
  }
  const std::vector<LcmLogEvent> from_replay = ReadLcmLog(written);
  REQUIRE(from_replay.size() == 201 + 2 * 21);  // 1 s: 201 IMU, 21 frames per camera
  REQUIRE(from_logger.size() == from_replay.size());
  for (size_t i = 0; i < from_replay.size(); ++i) {
    INFO("event " << i);
    REQUIRE(from_logger[i].channel == from_replay[i].channel);
    REQUIRE(from_logger[i].data == from_replay[i].data);
  }
  // lcm-logger stamps receive times; --to-log stamps message times: both increase, and the
  // receive clock advanced like the message clock (real-time replay).
  const double logger_span = (from_logger.back().timestamp_us - from_logger.front().timestamp_us) * 1e-6;
  const double data_span = (from_replay.back().timestamp_us - from_replay.front().timestamp_us) * 1e-6;
  CHECK(data_span == Approx(1.0).margin(1e-3));
  CHECK(logger_span == Approx(data_span).margin(0.1));
  std::remove(recorded.c_str());  // ~15 MB each
  std::remove(written.c_str());
}

TEST_CASE("vilma-replay rejects a bad dataset path with a clear message", "[integration][replay]") {
  const std::string out = test::ScratchDir() + "/bad.out";
  test::ChildProcess replay({kReplay, "/nonexistent/dataset"}, out);
  CHECK(replay.Wait(10.0) == 1);
  CHECK(test::ReadTextFile(out).find("/nonexistent/dataset") != std::string::npos);
  test::ChildProcess help({kReplay, "--help"}, out);
  CHECK(help.Wait(10.0) == 0);
  CHECK(test::ReadTextFile(out).find("Usage: vilma-replay") != std::string::npos);
}

}  // namespace
}  // namespace vilma
