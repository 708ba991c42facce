#include "vilma/drivers/replay.h"

#include <unistd.h>

#include <catch2/catch.hpp>
#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>

#include "vilma/core/time.h"
#include "vilma/drivers/lcm_convert.h"
#include "vilma/drivers/lcm_log.h"

namespace vilma {
namespace {

namespace fs = std::filesystem;

// Records what a replay sends.
class RecordingSink : public MessageSink {
 public:
  struct Sent {
    std::string channel;
    std::vector<uint8_t> data;
    int64_t utime;
    std::chrono::steady_clock::time_point when;
  };
  bool Send(const std::string& channel, const void* data, int size, int64_t utime) override {
    const auto* p = static_cast<const uint8_t*>(data);
    sent.push_back({channel, std::vector<uint8_t>(p, p + size), utime,
                    std::chrono::steady_clock::now()});
    return true;
  }
  std::vector<Sent> sent;
};

// A small synthetic ASL dataset: 2 cameras at 20 Hz (16x8 images whose pixels encode camera
// and frame), IMU at 200 Hz; camera stamps coincide with IMU stamps (ties).
struct SyntheticDataset {
  std::string root;
  static constexpr int64_t kT0 = 1000000000000LL;  // [ns]
  SyntheticDataset() {
    root = "/tmp/vilma_replay_test_" + std::to_string(::getpid());
    fs::remove_all(root);
    AslDatasetWriter writer(root, 2);
    for (int k = 0; k < 10; ++k) {  // 0.45 s of frames
      for (int c = 0; c < 2; ++c) {
        cv::Mat image(8, 16, CV_8UC1, cv::Scalar(10 * k + c));
        writer.AddImage(c, kT0 + k * 50000000LL, image);
      }
    }
    for (int i = 0; i < 100; ++i) {  // 0.495 s of IMU
      ImuSample s;
      s.t_ns = kT0 + i * 5000000LL;
      s.a_I = Eigen::Vector3d(0, 0, 0.5 * i);  // exact in the CSV text
      writer.AddImu(s);
    }
    writer.Finish();
  }
  ~SyntheticDataset() { fs::remove_all(root); }
};

ReplayOptions FastOptions(const std::string& dataset) {
  ReplayOptions o;
  o.dataset = dataset;
  o.fast = true;
  o.fast_max_mb_per_s = 0;
  o.verbose = false;
  return o;
}

TEST_CASE("Replay merges streams in time order, IMU first on ties, seq per stream", "[replay]") {
  SyntheticDataset data;
  const AslDataset dataset = AslDataset::Open(data.root);
  for (int prefetch : {0, 3}) {
    CAPTURE(prefetch);
    ReplayOptions options = FastOptions(data.root);
    options.prefetch = prefetch;
    RecordingSink sink;
    const ReplaySummary summary = RunReplay(dataset, options, &sink);
    REQUIRE(sink.sent.size() == 120);
    CHECK(summary.messages == 120);
    CHECK(summary.channels.size() == 3);
    CHECK(summary.data_s == Approx(0.495));

    std::map<std::string, int64_t> next_seq;
    int64_t last_utime = 0;
    std::string last_channel;
    for (const auto& s : sink.sent) {
      CHECK(s.utime >= last_utime);
      if (s.utime == last_utime && s.utime % 50000 == 0) {
        // Ties: IMU, then CAM0, then CAM1.
        const std::string order = last_channel + "<" + s.channel;
        CHECK((order == "IMU<CAM0" || order == "CAM0<CAM1"));
      }
      int64_t utime = 0, seq = 0;
      REQUIRE(PeekUtimeAndSeq(s.data.data(), static_cast<int>(s.data.size()), &utime, &seq));
      CHECK(utime == s.utime);
      CHECK(seq == next_seq[s.channel]++);
      if (s.channel == "IMU") {
        imu_t msg;
        ImuSample sample;
        REQUIRE(DecodeImuMessage(s.data.data(), static_cast<int>(s.data.size()), &msg, &sample)
                    .empty());
        CHECK(sample.a_I.z() == 0.5 * seq);
        CHECK(msg.utime == NsToUtime(SyntheticDataset::kT0 + seq * 5000000LL));
      } else {
        image_t msg;
        REQUIRE(DecodeImageMessage(s.data.data(), static_cast<int>(s.data.size()), &msg).empty());
        const int camera = s.channel == "CAM0" ? 0 : 1;
        CHECK(msg.camera_id == camera);
        CHECK(msg.pixel_format == image_t::GRAY8);
        CHECK(msg.width == 16);
        CHECK(msg.height == 8);
        CHECK(msg.data[0] == 10 * seq + camera);
        CHECK(msg.utime == NsToUtime(SyntheticDataset::kT0 + seq * 50000000LL));
      }
      last_utime = s.utime;
      last_channel = s.channel;
    }
    CHECK(next_seq["IMU"] == 100);
    CHECK(next_seq["CAM0"] == 10);
    CHECK(next_seq["CAM1"] == 10);
  }
}

TEST_CASE("Replay --start/--end select a window from the first stamp", "[replay]") {
  SyntheticDataset data;
  const AslDataset dataset = AslDataset::Open(data.root);
  ReplayOptions options = FastOptions(data.root);
  options.start_s = 0.1;
  options.end_s = 0.2;
  RecordingSink sink;
  RunReplay(dataset, options, &sink);
  // IMU at 0.100 ... 0.200 s (21 samples), frames at 0.10, 0.15, 0.20 s on both cameras.
  REQUIRE(sink.sent.size() == 21 + 6);
  CHECK(sink.sent.front().utime == (SyntheticDataset::kT0 + 100000000LL) / 1000);
  CHECK(sink.sent.back().utime == (SyntheticDataset::kT0 + 200000000LL) / 1000);
  CHECK(sink.sent.back().channel == "CAM1");
}

TEST_CASE("Replay paces in real time without drift", "[replay]") {
  SyntheticDataset data;
  const AslDataset dataset = AslDataset::Open(data.root);
  ReplayOptions options = FastOptions(data.root);
  options.fast = false;
  options.rate = 2.0;  // 0.495 s of data in ~0.25 s
  RecordingSink sink;
  const auto start = std::chrono::steady_clock::now();
  const ReplaySummary summary = RunReplay(dataset, options, &sink);
  REQUIRE(sink.sent.size() == 120);
  // Every message is sent no earlier than its deadline, and late by at most a scheduling hiccup.
  double worst_late_s = 0.0;
  for (const auto& s : sink.sent) {
    const double due_s = (s.utime - sink.sent.front().utime) * 1e-6 / options.rate;
    const double sent_s = std::chrono::duration<double>(s.when - start).count();
    CHECK(sent_s >= due_s - 1e-3);
    worst_late_s = std::max(worst_late_s, sent_s - due_s);
  }
  CHECK(worst_late_s < 0.05);
  CHECK(summary.wall_s == Approx(0.2475).margin(0.05));
}

TEST_CASE("Replay --fast with a byte-rate cap", "[replay]") {
  SyntheticDataset data;
  const AslDataset dataset = AslDataset::Open(data.root);
  ReplayOptions options = FastOptions(data.root);
  options.fast_max_mb_per_s = 0.1;  // 100 kB/s: ~13.5 kB of messages take ~0.13 s
  RecordingSink sink;
  const ReplaySummary summary = RunReplay(dataset, options, &sink);
  const double expected_s = static_cast<double>(summary.bytes - sink.sent.back().data.size()) / 1e5;
  CHECK(summary.wall_s >= expected_s - 1e-3);
  CHECK(summary.wall_s < expected_s + 0.05);
}

TEST_CASE("Replay stops when asked", "[replay]") {
  SyntheticDataset data;
  const AslDataset dataset = AslDataset::Open(data.root);
  std::atomic<bool> stop{true};
  RecordingSink sink;
  const ReplaySummary summary = RunReplay(dataset, FastOptions(data.root), &sink, &stop);
  CHECK(summary.interrupted);
  CHECK(sink.sent.empty());
}

TEST_CASE("Replay --to-log writes the messages with utime as event time", "[replay]") {
  SyntheticDataset data;
  const std::string log = data.root + ".lcmlog";
  const std::string channels = "--channels=LEFT,RIGHT";
  const char* argv[] = {"vilma-replay", data.root.c_str(), "--to-log", log.c_str(),
                        channels.c_str(), "--channel-suffix", "_R1", "--quiet"};
  REQUIRE(ReplayMain(8, argv, nullptr) == 0);
  const std::vector<LcmLogEvent> events = ReadLcmLog(log);
  REQUIRE(events.size() == 120);
  std::map<std::string, int> counts;
  for (const LcmLogEvent& e : events) {
    ++counts[e.channel];
    int64_t utime = 0, seq = 0;
    REQUIRE(PeekUtimeAndSeq(e.data.data(), static_cast<int>(e.data.size()), &utime, &seq));
    CHECK(e.timestamp_us == utime);
  }
  CHECK(counts["IMU_R1"] == 100);
  CHECK(counts["LEFT_R1"] == 10);
  CHECK(counts["RIGHT_R1"] == 10);
  fs::remove(log);
}

TEST_CASE("vilma-replay command line", "[replay]") {
  ReplayOptions o;
  bool help = false;
  auto parse = [&](std::vector<const char*> args) {
    o = ReplayOptions();
    args.insert(args.begin(), "vilma-replay");
    return ParseReplayCommandLine(static_cast<int>(args.size()), args.data(), &o, &help);
  };
  CHECK(parse({"data", "--rate", "2.5", "--start=1", "--end", "3", "--lcm-url", "memq://"})
            .empty());
  CHECK(o.dataset == "data");
  CHECK(o.rate == 2.5);
  CHECK(o.start_s == 1.0);
  CHECK(o.end_s == 3.0);
  CHECK(o.lcm_url == "memq://");
  CHECK_FALSE(help);
  CHECK(parse({"data", "--channel-cam1", "RIGHT", "--channel-imu", "ADIS"}).empty());
  CHECK(o.CameraChannel(0) == "CAM0");
  CHECK(o.CameraChannel(1) == "RIGHT");
  CHECK(o.ImuChannel() == "ADIS");
  CHECK(parse({"data", "--fast", "--max-mbps", "0"}).empty());
  CHECK(o.fast);
  CHECK(o.fast_max_mb_per_s == 0.0);
  CHECK(parse({"--help"}).empty());
  CHECK(help);

  CHECK_FALSE(parse({}).empty());                          // no dataset
  CHECK_FALSE(parse({"a", "b"}).empty());                  // two datasets
  CHECK_FALSE(parse({"data", "--rate", "0"}).empty());
  CHECK_FALSE(parse({"data", "--rate", "fast"}).empty());
  CHECK_FALSE(parse({"data", "--rate"}).empty());
  CHECK_FALSE(parse({"data", "--start", "2", "--end", "1"}).empty());
  CHECK_FALSE(parse({"data", "--bogus"}).empty());
  CHECK_FALSE(parse({"data", "--channel-cam0", "cam.*"}).empty());
  CHECK_FALSE(parse({"data", "--channels", "IMU"}).empty());  // clashes with the IMU channel

  const char* bad[] = {"vilma-replay", "/nonexistent/dataset"};
  CHECK(ReplayMain(2, bad, nullptr) == 1);  // input error
  const char* bad_option[] = {"vilma-replay", "/nonexistent/dataset", "--bogus"};
  CHECK(ReplayMain(3, bad_option, nullptr) == 2);  // usage error
}

}  // namespace
}  // namespace vilma
