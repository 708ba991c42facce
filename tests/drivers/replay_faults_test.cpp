// Sensor faults injected by vilma-replay --fault (replay_faults.h): which messages are dropped,
// duplicated or re-stamped, through the whole replay into a recording sink.
#include "vilma/drivers/replay_faults.h"

#include <unistd.h>

#include <catch2/catch.hpp>
#include <filesystem>
#include <map>

#include "vilma/core/time.h"
#include "vilma/drivers/lcm_convert.h"
#include "vilma/drivers/replay.h"

namespace vilma {
namespace {

namespace fs = std::filesystem;

struct Sent {
  std::string channel;
  int64_t utime = 0;  // the stamp the message carries [us]
  int64_t seq = 0;
};

class RecordingSink : public MessageSink {
 public:
  bool Send(const std::string& channel, const void* data, int size, int64_t utime) override {
    Sent s;
    s.channel = channel;
    REQUIRE(PeekUtimeAndSeq(static_cast<const uint8_t*>(data), size, &s.utime, &s.seq));
    CHECK(s.utime == utime);
    sent.push_back(s);
    return true;
  }
  std::vector<Sent> sent;
};

// 1 s of a camera at 20 Hz (frames at 0, 50, ..., 950 ms) and an IMU at 100 Hz.
struct Dataset {
  static constexpr int64_t kT0 = 5000000000000LL;  // [ns]
  std::string root = "/tmp/vilma_replay_faults_" + std::to_string(::getpid());
  Dataset() {
    fs::remove_all(root);
    AslDatasetWriter writer(root, 1);
    for (int k = 0; k < 20; ++k) writer.AddImage(0, kT0 + k * 50000000LL, cv::Mat(4, 4, CV_8UC1, cv::Scalar(k)));
    for (int i = 0; i < 100; ++i) {
      ImuSample s;
      s.t_ns = kT0 + i * 10000000LL;
      writer.AddImu(s);
    }
    writer.Finish();
  }
  ~Dataset() { fs::remove_all(root); }
};

std::vector<Sent> Replay(const std::vector<std::string>& faults, ReplaySummary* summary = nullptr) {
  static Dataset data;
  ReplayOptions options;
  options.dataset = data.root;
  options.fast = true;
  options.fast_max_mb_per_s = 0;
  options.verbose = false;
  for (const std::string& text : faults) {
    ReplayFault f;
    REQUIRE(ParseReplayFault(text, &f) == "");
    options.faults.push_back(f);
  }
  REQUIRE(options.Validate() == "");
  RecordingSink sink;
  const ReplaySummary s = RunReplay(AslDataset::Open(data.root), options, &sink);
  if (summary != nullptr) *summary = s;
  return sink.sent;
}

// Stamps [ms after kT0] of one channel.
std::vector<int64_t> StampsMs(const std::vector<Sent>& sent, const std::string& channel) {
  std::vector<int64_t> out;
  for (const Sent& s : sent) {
    if (s.channel == channel) out.push_back((s.utime * 1000 - Dataset::kT0) / 1000000);
  }
  return out;
}

TEST_CASE("replay fault: camera-drop silences every camera in the window only", "[replay]") {
  ReplaySummary summary;
  const std::vector<Sent> sent = Replay({"camera-drop:0.2:0.3"}, &summary);
  const std::vector<int64_t> cam = StampsMs(sent, "CAM0");
  // Frames at 200, 250, ..., 450 ms dropped (window [200, 500) ms).
  CHECK(cam == std::vector<int64_t>{0, 50, 100, 150, 500, 550, 600, 650, 700, 750, 800, 850, 900, 950});
  CHECK(StampsMs(sent, "IMU").size() == 100);
  CHECK(summary.fault_dropped == 6);
  // The dropped frames keep their seq numbers: the gap is visible as on a lossy bus.
  int64_t last_seq = -1;
  for (const Sent& s : sent) {
    if (s.channel != "CAM0") continue;
    CHECK(s.seq == (s.utime * 1000 - Dataset::kT0) / 50000000LL);
    CHECK(s.seq > last_seq);
    last_seq = s.seq;
  }
}

TEST_CASE("replay fault: imu-gap drops IMU samples in the window only", "[replay]") {
  const std::vector<Sent> sent = Replay({"imu-gap:0.5:0.25"});
  const std::vector<int64_t> imu = StampsMs(sent, "IMU");
  CHECK(imu.size() == 100 - 25);  // 500, 510, ..., 740 ms
  for (int64_t t : imu) CHECK((t < 500 || t >= 750));
  CHECK(StampsMs(sent, "CAM0").size() == 20);
}

TEST_CASE("replay fault: time-jump shifts the stamps in the window, then they return", "[replay]") {
  for (double offset_s : {2.0, -0.3}) {
    CAPTURE(offset_s);
    ReplaySummary summary;
    const std::string text = "time-jump:0.3:0.2:" + std::to_string(offset_s);
    const std::vector<Sent> sent = Replay({text}, &summary);
    const int64_t offset_ms = static_cast<int64_t>(offset_s * 1000);
    REQUIRE(sent.size() == 120);
    // Send order is the dataset's order; only the carried stamps change.
    int64_t k_imu = 0;
    for (const Sent& s : sent) {
      if (s.channel != "IMU") continue;
      const int64_t t_ms = 10 * k_imu++;
      const bool in_window = t_ms >= 300 && t_ms < 500;
      CHECK((s.utime * 1000 - Dataset::kT0) / 1000000 == t_ms + (in_window ? offset_ms : 0));
    }
    CHECK(summary.fault_shifted == 20 + 4);  // IMU 300..490 ms, frames 300..450 ms
  }
}

TEST_CASE("replay fault: duplicate sends each message of the window twice, same seq", "[replay]") {
  ReplaySummary summary;
  const std::vector<Sent> sent = Replay({"duplicate:0.1:0.1"}, &summary);
  CHECK(sent.size() == 120 + 10 + 2);  // IMU 100..190 ms, frames 100 and 150 ms
  CHECK(summary.fault_duplicated == 12);
  std::map<std::pair<std::string, int64_t>, int> copies;
  for (const Sent& s : sent) ++copies[{s.channel, s.seq}];
  CHECK(copies[{"CAM0", 2}] == 2);
  CHECK(copies[{"CAM0", 3}] == 2);
  CHECK(copies[{"CAM0", 4}] == 1);
  CHECK(copies[{"IMU", 10}] == 2);
  CHECK(copies[{"IMU", 20}] == 1);
}

TEST_CASE("replay fault: camera-half-rate drops every second frame in the window", "[replay]") {
  const std::vector<Sent> sent = Replay({"camera-half-rate:0.5:10"});
  CHECK(StampsMs(sent, "CAM0") ==
        std::vector<int64_t>{0, 50, 100, 150, 200, 250, 300, 350, 400, 450, 500, 600, 700, 800, 900});
  CHECK(StampsMs(sent, "IMU").size() == 100);
}

TEST_CASE("replay faults compose: a drop wins over a duplicate", "[replay]") {
  const std::vector<Sent> sent = Replay({"duplicate:0:1", "camera-drop:0:0.5"});
  CHECK(StampsMs(sent, "CAM0").size() == 2 * 10);
  CHECK(StampsMs(sent, "IMU").size() == 2 * 100);
}

TEST_CASE("ParseReplayFault reads the five forms and names what is wrong", "[replay]") {
  ReplayFault f;
  REQUIRE(ParseReplayFault("time-jump:10:1.5:-2", &f) == "");
  CHECK(f.kind == ReplayFaultKind::kTimeJump);
  CHECK(f.start_s == 10.0);
  CHECK(f.duration_s == 1.5);
  CHECK(f.offset_s == -2.0);
  CHECK(f.ToString() == "time-jump:10:1.5:-2");
  REQUIRE(ParseReplayFault("camera-half-rate:3:4", &f) == "");
  CHECK(f.kind == ReplayFaultKind::kCameraHalfRate);
  CHECK(f.ToString() == "camera-half-rate:3:4");
  CHECK_THAT(ParseReplayFault("camera-drop:1", &f), Catch::Contains("expected camera-drop:START:DURATION"));
  CHECK_THAT(ParseReplayFault("imu-gap:1:2:3", &f), Catch::Contains("expected"));
  CHECK_THAT(ParseReplayFault("power-cut:1:2", &f), Catch::Contains("expected"));
  CHECK_THAT(ParseReplayFault("imu-gap:x:2", &f), Catch::Contains("'x' is not a number"));
  CHECK_THAT(ParseReplayFault("imu-gap:1:0", &f), Catch::Contains("DURATION must be in (0, 86400]"));
  CHECK_THAT(ParseReplayFault("imu-gap:-1:1", &f), Catch::Contains("START must be in [0, 86400]"));
  CHECK_THAT(ParseReplayFault("imu-gap:1:nan", &f), Catch::Contains("not a number"));
  CHECK_THAT(ParseReplayFault("time-jump:1:1:0", &f), Catch::Contains("OFFSET must be non-zero"));
  CHECK_THAT(ParseReplayFault("time-jump:1:1:1e7", &f), Catch::Contains("|OFFSET| <= 1e6"));

  ReplayOptions options;
  bool help = false;
  const char* argv[] = {"vilma-replay", "DATA", "--fault", "imu-gap:1:0.5", "--fault=duplicate:2:1"};
  REQUIRE(ParseReplayCommandLine(5, argv, &options, &help) == "");
  REQUIRE(options.faults.size() == 2);
  CHECK(options.faults[1].kind == ReplayFaultKind::kDuplicate);
  ReplayOptions bad;
  const char* argv_bad[] = {"vilma-replay", "DATA", "--fault", "imu-gap:1"};
  CHECK_THAT(ParseReplayCommandLine(4, argv_bad, &bad, &help), Catch::Contains("--fault 'imu-gap:1'"));
}

}  // namespace
}  // namespace vilma
