// vilma-estimatord as a process (docs/daemon.md): simulated data through LCM or an LCM log,
// bad input, SIGTERM, the systemd notification protocol and the watchdog.
#include <sys/socket.h>
#include <sys/un.h>

#include <atomic>
#include <catch2/catch.hpp>
#include <chrono>
#include <filesystem>
#include <lcm/lcm-cpp.hpp>
#include <map>
#include <mutex>
#include <random>
#include <thread>

#include <vilma/pose_t.hpp>
#include <vilma/status_t.hpp>

#include "integration/process_util.h"
#include "vilma/core/asl_dataset.h"
#include "vilma/core/time.h"
#include "vilma/eval/evaluate.h"
#include "vilma/drivers/lcm_convert.h"
#include "vilma/drivers/lcm_log.h"
#include "test_skip.h"

namespace vilma {
namespace {

const std::string kBin = std::string(VILMA_BINARY_DIR) + "/bin/";
const std::string kDaemon = kBin + "vilma-estimatord";
const std::string kSim = kBin + "vilma-sim";
const std::string kReplay = kBin + "vilma-replay";

using Clock = std::chrono::steady_clock;

double SecondsSince(Clock::time_point t0) {
  return std::chrono::duration<double>(Clock::now() - t0).count();
}

bool HaveBinaries() {
  for (const std::string& b : {kDaemon, kSim, kReplay}) {
    if (!test::FileExists(b)) {
      VILMA_SKIP_NOTE(b << " not built");
      return false;
    }
  }
  return true;
}

// 15 s of the simulated room (mono camera 752x480 at 20 Hz, IMU 200 Hz) and its LCM log,
// made once per test process.
struct RoomData {
  std::string dir, dataset, log;
};
const RoomData& Room() {
  static RoomData data = [] {
    RoomData d;
    d.dir = test::ScratchDir() + "/estimatord";
    std::filesystem::remove_all(d.dir);
    std::filesystem::create_directories(d.dir);
    d.dataset = d.dir + "/room";
    d.log = d.dir + "/room.lcmlog";
    test::ChildProcess sim({kSim, "room", "--out", d.dataset, "--seconds", "15", "--seed", "3"},
                           d.dir + "/sim.out");
    if (sim.Wait(120.0) != 0) throw std::runtime_error("vilma-sim failed");
    test::ChildProcess replay({kReplay, d.dataset, "--to-log", d.log, "--quiet"}, d.dir + "/replay.out");
    if (replay.Wait(60.0) != 0) throw std::runtime_error("vilma-replay --to-log failed");
    static const std::string dir_to_remove = d.dir;
    std::atexit([] {
      std::filesystem::remove_all(dir_to_remove);
      std::error_code error;  // the scratch folder itself, only if no other test left files
      std::filesystem::remove(std::filesystem::path(dir_to_remove).parent_path(), error);
    });
    return d;
  }();
  return data;
}

Trajectory GroundTruth(const std::string& dataset) {
  const AslDataset d = AslDataset::Open(dataset);
  Trajectory gt;
  for (const GroundTruthState& s : d.ground_truth()) gt.Add(s.t_ns, Transformation(s.q_W_I, s.p_W_I));
  return gt;
}

Transformation PoseOf(const pose_t& msg) {
  const Eigen::Quaterniond q(msg.orientation[0], msg.orientation[1], msg.orientation[2],
                             msg.orientation[3]);
  return Transformation(q, Eigen::Vector3d(msg.position[0], msg.position[1], msg.position[2]));
}

std::map<std::string, int64_t> Counters(const status_t& s) {
  std::map<std::string, int64_t> c;
  for (int i = 0; i < s.num_counters; ++i) c[s.counter_names[i]] = s.counter_values[i];
  return c;
}

std::map<std::string, double> Metrics(const status_t& s) {
  std::map<std::string, double> m;
  for (int i = 0; i < s.num_metrics; ++i) m[s.metric_names[i]] = s.metric_values[i];
  return m;
}

// Collects VILMA_ODOM and VILMA_STATUS on a URL, on a thread of its own.
class Subscriber {
 public:
  explicit Subscriber(const std::string& url) : lcm_(url) {
    REQUIRE(lcm_.good());
    lcm_.subscribe("VILMA_ODOM", &Subscriber::OnOdom, this);
    lcm_.subscribe("VILMA_STATUS", &Subscriber::OnStatus, this);
    thread_ = std::thread([this] {
      while (!stop_) lcm_.handleTimeout(20);
    });
  }
  ~Subscriber() {
    stop_ = true;
    thread_.join();
  }
  std::vector<pose_t> odom() {
    std::lock_guard<std::mutex> lock(mutex_);
    return odom_;
  }
  std::vector<status_t> status() {
    std::lock_guard<std::mutex> lock(mutex_);
    return status_;
  }
  // Waits until a status satisfies `pred`.
  template <typename Pred>
  bool WaitForStatus(Pred pred, double timeout_s) {
    const auto t0 = Clock::now();
    while (SecondsSince(t0) < timeout_s) {
      for (const status_t& s : status()) {
        if (pred(s)) return true;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(20));
    }
    return false;
  }

 private:
  void OnOdom(const lcm::ReceiveBuffer*, const std::string&, const pose_t* msg) {
    std::lock_guard<std::mutex> lock(mutex_);
    odom_.push_back(*msg);
  }
  void OnStatus(const lcm::ReceiveBuffer*, const std::string&, const status_t* msg) {
    std::lock_guard<std::mutex> lock(mutex_);
    status_.push_back(*msg);
  }
  lcm::LCM lcm_;
  std::atomic<bool> stop_{false};
  std::thread thread_;
  std::mutex mutex_;
  std::vector<pose_t> odom_;
  std::vector<status_t> status_;
};

// SIGTERM: the daemon must exit 0 within 1 s.
void StopAndCheck(test::ChildProcess* daemon, const std::string& output_path) {
  REQUIRE(daemon->running());
  const auto t0 = Clock::now();
  daemon->Signal(SIGTERM);
  const int status = daemon->Wait(5.0);
  const double seconds = SecondsSince(t0);
  INFO(test::ReadTextFile(output_path));
  CHECK(status == 0);
  CHECK(seconds < 1.0);
}

// The VILMA_ODOM payloads in an LCM log written by the file:// provider.
std::vector<std::vector<uint8_t>> OdomPayloads(const std::string& path) {
  std::vector<std::vector<uint8_t>> payloads;
  for (const LcmLogEvent& e : ReadLcmLog(path)) {
    if (e.channel == "VILMA_ODOM") payloads.push_back(e.data);
  }
  return payloads;
}

TEST_CASE("vilma-estimatord --input-log: same output on every run, accurate trajectory",
          "[integration][daemon]") {
  if (!HaveBinaries()) return;
  const RoomData& room = Room();
  std::vector<std::vector<uint8_t>> runs[2];
  for (int run = 0; run < 2; ++run) {
    const std::string out = room.dir + "/odom" + std::to_string(run) + ".lcm";
    const std::string text = room.dir + "/log_run" + std::to_string(run) + ".out";
    std::filesystem::remove(out);
    test::ChildProcess daemon({kDaemon, "--rig", room.dataset + "/rig.yaml", "--input-log", room.log,
                               "--lcm-url", "file://" + out + "?mode=w"},
                              text);
    REQUIRE(daemon.Wait(60.0) == 0);
    INFO(test::ReadTextFile(text));
    CHECK(test::ReadTextFile(text).find(" 0 drops") != std::string::npos);
    runs[run] = OdomPayloads(out);
  }
  REQUIRE(runs[0].size() == 301);  // every frame of 15 s at 20 Hz, both ends included
  CHECK(runs[0] == runs[1]);       // bit for bit

  Trajectory est;
  int tracking = 0;
  for (const auto& payload : runs[0]) {
    pose_t msg;
    REQUIRE(msg.decode(payload.data(), 0, static_cast<int>(payload.size())) ==
            static_cast<int>(payload.size()));
    if (msg.status != pose_t::TRACKING) continue;
    ++tracking;
    est.Add(UtimeToNs(msg.utime), PoseOf(msg));
    // Covariance: symmetric with a positive diagonal.
    for (int i = 0; i < 6; ++i) {
      CHECK(msg.covariance[7 * i] > 0.0);
      for (int j = 0; j < 6; ++j) CHECK(msg.covariance[6 * i + j] == Approx(msg.covariance[6 * j + i]).margin(1e-12));
    }
  }
  CHECK(tracking > 280);
  const EvalResult eval = EvaluateTrajectory(GroundTruth(room.dataset), est, EvalOptions());
  INFO("ATE RMSE " << eval.ate.translation_m.rmse << " m");
  WARN("--input-log: ATE RMSE " << eval.ate.translation_m.rmse << " m over " << est.size() << " poses");
  CHECK(eval.ate.translation_m.rmse < 0.3);
}

TEST_CASE("vilma-estimatord live: replay -> daemon -> VILMA_ODOM, SIGTERM", "[integration][daemon]") {
  if (!HaveBinaries()) return;
  const RoomData& room = Room();
  const std::string url = test::UniqueLcmUrl();
  Subscriber subscriber(url);
  const std::string text = room.dir + "/live.out";
  test::ChildProcess daemon({kDaemon, "--rig", room.dataset + "/rig.yaml", "--lcm-url", url}, text);
  // The first status is published when the pipeline is up (after subscribing).
  REQUIRE(subscriber.WaitForStatus([](const status_t&) { return true; }, 10.0));
  // Twice real time: 7.5 s.
  test::ChildProcess replay({kReplay, room.dataset, "--rate", "2", "--lcm-url", url, "--quiet"},
                            room.dir + "/live_replay.out");
  REQUIRE(replay.Wait(60.0) == 0);
  std::this_thread::sleep_for(std::chrono::milliseconds(300));
  StopAndCheck(&daemon, text);

  Trajectory est;
  for (const pose_t& msg : subscriber.odom()) {
    if (msg.status == pose_t::TRACKING) est.Add(UtimeToNs(msg.utime), PoseOf(msg));
  }
  INFO(test::ReadTextFile(text));
  CHECK(subscriber.odom().size() > 250);  // of 301 (a loaded machine may thin a few)
  const EvalResult eval = EvaluateTrajectory(GroundTruth(room.dataset), est, EvalOptions());
  WARN("live: ATE RMSE " << eval.ate.translation_m.rmse << " m over " << est.size() << " poses");
  CHECK(eval.ate.translation_m.rmse < 0.3);
  // The last status says STOPPING and counts what was published.
  const std::vector<status_t> status = subscriber.status();
  REQUIRE(!status.empty());
  CHECK(status.back().state == status_t::STOPPING);
  CHECK(Counters(status.back())["poses_published"] == static_cast<int64_t>(subscriber.odom().size()));
  CHECK(Counters(status.back())["imu_dropped_input_queue"] == 0);
  CHECK(Counters(status.back())["imu_dropped_filter_queue"] == 0);
  // The heap over the malloc arenas (soak diagnostics, docs/reliability.md): present, and
  // plausible for a daemon that holds images and a filter (tens of MB, not zero, not GBs).
  const std::map<std::string, double> metrics = Metrics(status.back());
  REQUIRE(metrics.count("heap_in_use_mb") == 1);
  REQUIRE(metrics.count("heap_free_mb") == 1);
  REQUIRE(metrics.count("heap_mmapped_mb") == 1);
  CHECK(metrics.at("heap_in_use_mb") > 1.0);
  CHECK(metrics.at("heap_in_use_mb") < 2000.0);
  CHECK(metrics.at("heap_free_mb") >= 0.0);
  CHECK(metrics.at("heap_mmapped_mb") <= metrics.at("heap_in_use_mb"));
}

TEST_CASE("vilma-estimatord survives bad input and reports it on VILMA_STATUS",
          "[integration][daemon]") {
  if (!HaveBinaries()) return;
  const RoomData& room = Room();
  const AslDataset dataset = AslDataset::Open(room.dataset);
  const std::string url = test::UniqueLcmUrl();
  // The default config with a faster status.
  std::string config = test::ReadTextFile(std::string(VILMA_SOURCE_DIR) + "/config/daemon.yaml");
  const std::string key = "status_period_s: 1.0";
  REQUIRE(config.find(key) != std::string::npos);
  config.replace(config.find(key), key.size(), "status_period_s: 0.2");
  const std::string config_path = room.dir + "/daemon_fast_status.yaml";
  { std::ofstream(config_path) << config; }

  Subscriber subscriber(url);
  const std::string text = room.dir + "/faults.out";
  test::ChildProcess daemon(
      {kDaemon, "--config", config_path, "--rig", room.dataset + "/rig.yaml", "--lcm-url", url}, text);
  REQUIRE(subscriber.WaitForStatus([](const status_t&) { return true; }, 10.0));

  lcm::LCM lcm(url);
  REQUIRE(lcm.good());
  std::mt19937 rng(42);
  // Random bytes and wrong types.
  for (int i = 0; i < 5; ++i) {
    std::vector<uint8_t> junk(static_cast<std::size_t>(1 + rng() % 2000));
    for (uint8_t& b : junk) b = static_cast<uint8_t>(rng());
    lcm.publish("CAM0", junk.data(), static_cast<unsigned>(junk.size()));
    lcm.publish("IMU", junk.data(), static_cast<unsigned>(junk.size()));
  }
  const imu_t an_imu = ImuToMessage(dataset.imu()[0], 0);
  lcm.publish("CAM0", &an_imu);  // imu_t on an image channel
  pose_t a_pose;
  lcm.publish("IMU", &a_pose);   // pose_t on the IMU channel

  // Real data for 1 s of sensor time, then IMU only for 2.5 s (the camera falls silent), then
  // an IMU sample out of order, then everything 100 s later (a timestamp jump).
  const auto& imu = dataset.imu();
  const auto& frames = dataset.cameras()[0].frames;
  std::size_t next_frame = 0;
  int64_t seq = 0;
  auto publish_imu = [&](const ImuSample& s) {
    const imu_t msg = ImuToMessage(s, seq++);
    lcm.publish("IMU", &msg);
    std::this_thread::sleep_for(std::chrono::microseconds(300));
  };
  auto publish_image = [&](const CameraFrame& f, int64_t shift_ns) {
    image_t msg;
    REQUIRE(MakeImageMessage(AslDataset::LoadImage(f.image_path), image_t::GRAY8, f.t_ns + shift_ns,
                             static_cast<int64_t>(next_frame), 0, &msg).empty());
    lcm.publish("CAM0", &msg);
  };
  std::size_t k = 0;
  for (; k < imu.size() && imu[k].t_ns < imu[0].t_ns + SecondsToNs(3.5); ++k) {
    publish_imu(imu[k]);
    while (next_frame < frames.size() && frames[next_frame].t_ns <= imu[k].t_ns &&
           frames[next_frame].t_ns < imu[0].t_ns + SecondsToNs(1.0)) {
      publish_image(frames[next_frame++], 0);
    }
  }
  publish_imu(imu[k - 10]);  // out of order
  const int64_t jump_ns = SecondsToNs(100.0);
  while (next_frame < frames.size() && frames[next_frame].t_ns < imu[k].t_ns) ++next_frame;
  for (std::size_t end = k + 200; k < end && k < imu.size(); ++k) {
    ImuSample s = imu[k];
    s.t_ns += jump_ns;
    publish_imu(s);
    while (next_frame < frames.size() && frames[next_frame].t_ns <= imu[k].t_ns) {
      publish_image(frames[next_frame++], jump_ns);
    }
  }

  auto all_reported = [](const status_t& s) {
    std::map<std::string, int64_t> c = Counters(s);
    return c["malformed_images"] >= 6 && c["malformed_imu"] >= 6 && c["camera_silences"] >= 1 &&
           c["sync_imu_out_of_order"] >= 1 &&
           c["sync_imu_time_jumps"] + c["sync_image_time_jumps"] >= 1 &&
           c["time_jump_restarts"] >= 1 && c["frames_filtered"] > 10;
  };
  const bool reported = subscriber.WaitForStatus(all_reported, 5.0);
  if (!reported && !subscriber.status().empty()) {
    for (const auto& [name, value] : Counters(subscriber.status().back())) {
      UNSCOPED_INFO(name << " = " << value);
    }
  }
  INFO(test::ReadTextFile(text));
  CHECK(reported);
  StopAndCheck(&daemon, text);
}

// A unix datagram socket standing in for systemd's notification socket.
class NotifySocket {
 public:
  explicit NotifySocket(const std::string& path) : path_(path) {
    ::unlink(path.c_str());
    fd_ = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    REQUIRE(fd_ >= 0);
    sockaddr_un addr{};
    addr.sun_family = AF_UNIX;
    std::snprintf(addr.sun_path, sizeof(addr.sun_path), "%s", path.c_str());
    REQUIRE(::bind(fd_, reinterpret_cast<sockaddr*>(&addr), sizeof(addr)) == 0);
    timeval tv{0, 20000};
    ::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof(tv));
  }
  ~NotifySocket() {
    ::close(fd_);
    ::unlink(path_.c_str());
  }
  // Messages received within `seconds`.
  std::vector<std::string> Receive(double seconds) {
    std::vector<std::string> messages;
    const auto t0 = Clock::now();
    char buffer[4096];
    while (SecondsSince(t0) < seconds) {
      const ssize_t n = ::recv(fd_, buffer, sizeof(buffer), 0);
      if (n > 0) messages.emplace_back(buffer, static_cast<std::size_t>(n));
    }
    return messages;
  }

 private:
  std::string path_;
  int fd_ = -1;
};

int CountContaining(const std::vector<std::string>& messages, const std::string& needle) {
  int n = 0;
  for (const std::string& m : messages) n += m.find(needle) != std::string::npos ? 1 : 0;
  return n;
}

TEST_CASE("vilma-estimatord: READY and watchdog for systemd, a stalled filter stops the watchdog",
          "[integration][daemon]") {
  if (!HaveBinaries()) return;
  const RoomData& room = Room();
  const std::string socket_path = room.dir + "/notify.sock";
  // 400 ms watchdog: the daemon pets every 100 ms.
  const std::vector<std::string> env = {"NOTIFY_SOCKET=" + socket_path, "WATCHDOG_USEC=400000"};

  SECTION("idle and running: READY=1, then WATCHDOG=1 every 100 ms") {
    NotifySocket socket(socket_path);
    const std::string text = room.dir + "/watchdog_idle.out";
    test::ChildProcess daemon({kDaemon, "--rig", room.dataset + "/rig.yaml", "--lcm-url",
                               test::UniqueLcmUrl()},
                              text, env);
    const std::vector<std::string> messages = socket.Receive(1.5);
    INFO(test::ReadTextFile(text));
    REQUIRE(CountContaining(messages, "READY=1") == 1);
    CHECK(CountContaining(messages, "WATCHDOG=1") >= 8);
    StopAndCheck(&daemon, text);
    CHECK(CountContaining(socket.Receive(0.1), "STOPPING=1") == 1);
  }
  SECTION("--fault-stall-filter-after: the watchdog stops") {
    NotifySocket socket(socket_path);
    const std::string text = room.dir + "/watchdog_stall.out";
    test::ChildProcess daemon({kDaemon, "--rig", room.dataset + "/rig.yaml", "--input-log", room.log,
                               "--lcm-url", test::UniqueLcmUrl(), "--fault-stall-filter-after", "20"},
                              text, env);
    REQUIRE(test::WaitForOutput(text, "filter stalled", 10.0));
    const std::vector<std::string> before = socket.Receive(0.15);  // pets in flight
    CHECK(CountContaining(before, "READY=1") <= 1);
    const std::vector<std::string> stalled = socket.Receive(1.0);
    CHECK(CountContaining(stalled, "WATCHDOG=1") == 0);
    REQUIRE(daemon.running());
    StopAndCheck(&daemon, text);
  }
}

}  // namespace
}  // namespace vilma

namespace vilma {
namespace {

TEST_CASE("vilma-estimatord's command line: --print-config, and usage errors exit 2",
          "[integration][daemon]") {
  if (!test::FileExists(kDaemon)) {
    VILMA_SKIP(kDaemon << " not built");
  }
  const std::string dir = test::ScratchDir() + "/estimatord_cli";
  std::filesystem::create_directories(dir);
  // The effective options, exit 0.
  test::ChildProcess print(
      {kDaemon, "--print-config", "--rig", std::string(VILMA_SOURCE_DIR) + "/config/euroc-rig.yaml"},
      dir + "/print.out");
  CHECK(print.Wait(10.0) == 0);
  CHECK(test::ReadTextFile(dir + "/print.out").find("mapping:") != std::string::npos);
  // A flag given a value is an error, not a yes; so is a bad value or an unknown option.
  const std::vector<std::pair<std::vector<std::string>, std::string>> cases = {
      {{kDaemon, "--print-config=no"}, "--print-config: takes no value"},
      {{kDaemon, "--fault-reset-filter-at", "x"}, "expected a frame count >= 0, got 'x'"},
      {{kDaemon, "--config"}, "--config: expected a value"},
      {{kDaemon, "--rig=a.yaml", "--bogus"}, "unknown argument '--bogus'"},
  };
  for (const auto& [argv, message] : cases) {
    test::ChildProcess p(argv, dir + "/usage.out");
    CHECK(p.Wait(10.0) == 2);
    const std::string text = test::ReadTextFile(dir + "/usage.out");
    INFO(text);
    CHECK(text.find(message) != std::string::npos);
    CHECK(text.find("see 'vilma-estimatord --help'") != std::string::npos);
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace vilma
