// One estimator path (issue 19): the same dataset through `vilma vio` (offline, VioPipeline)
// and through `vilma-replay --to-log` + `vilma-estimatord --input-log` (LCM log, the daemon's
// threads) gives the same trajectory.
#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <vector>

#include <vilma/pose_t.hpp>

#include "integration/process_util.h"
#include "test_skip.h"
#include "vilma/drivers/lcm_log.h"

namespace vilma {
namespace {

const std::string kBin = std::string(VILMA_BINARY_DIR) + "/bin/";

struct Pose {
  double p[3];
  double q[4];  // x y z w
};

// TUM text -> poses by time in microseconds (pose_t's utime resolution).
std::map<int64_t, Pose> ReadTum(const std::string& path) {
  std::map<int64_t, Pose> poses;
  std::ifstream in(path);
  std::string line;
  while (std::getline(in, line)) {
    if (line.empty() || line[0] == '#') continue;
    std::istringstream s(line);
    std::string t;
    Pose pose;
    s >> t >> pose.p[0] >> pose.p[1] >> pose.p[2] >> pose.q[0] >> pose.q[1] >> pose.q[2] >> pose.q[3];
    const std::size_t dot = t.find('.');
    const int64_t seconds = std::stoll(t.substr(0, dot));
    const int64_t us = std::stoll((t.substr(dot + 1) + "000000").substr(0, 6));
    poses[seconds * 1000000 + us] = pose;
  }
  return poses;
}

struct DaemonRun {
  std::map<int64_t, Pose> tracking;  // TRACKING poses by utime
  int64_t frames = 0;                // VILMA_ODOM messages
};

// `vilma-estimatord --input-log LOG` (+ extra arguments), its VILMA_ODOM read from the
// file:// output.
DaemonRun RunDaemon(const std::string& dir, const std::string& dataset, const std::string& log,
                    const std::vector<std::string>& extra, const std::string& name) {
  const std::string odom = dir + "/" + name + ".lcm";
  std::vector<std::string> args{kBin + "vilma-estimatord", "--rig", dataset + "/rig.yaml",
                                "--input-log", log, "--lcm-url", "file://" + odom + "?mode=w"};
  args.insert(args.end(), extra.begin(), extra.end());
  test::ChildProcess daemon(args, dir + "/" + name + ".out");
  REQUIRE(daemon.Wait(60.0) == 0);
  DaemonRun run;
  for (const LcmLogEvent& e : ReadLcmLog(odom)) {
    if (e.channel != "VILMA_ODOM") continue;
    pose_t msg;
    REQUIRE(msg.decode(e.data.data(), 0, static_cast<int>(e.data.size())) ==
            static_cast<int>(e.data.size()));
    ++run.frames;
    if (msg.status != pose_t::TRACKING) continue;
    Pose p;
    for (int i = 0; i < 3; ++i) p.p[i] = msg.position[i];
    p.q[0] = msg.orientation[1];
    p.q[1] = msg.orientation[2];
    p.q[2] = msg.orientation[3];
    p.q[3] = msg.orientation[0];
    run.tracking[msg.utime] = p;
  }
  return run;
}

// `vilma vio DATASET --out TRAJ` (+ extra arguments).
std::map<int64_t, Pose> RunVio(const std::string& dir, const std::string& dataset,
                               const std::vector<std::string>& extra, const std::string& name) {
  const std::string traj = dir + "/" + name + ".txt";
  std::vector<std::string> args{kBin + "vilma", "vio", dataset, "--out", traj};
  args.insert(args.end(), extra.begin(), extra.end());
  test::ChildProcess vio(args, dir + "/" + name + ".out");
  REQUIRE(vio.Wait(120.0) == 0);
  return ReadTum(traj);
}

// Every daemon pose is a `vilma vio` pose at the same time, equal up to the TUM file's 9
// decimals.
void CheckSamePoses(const std::map<int64_t, Pose>& from_daemon,
                    const std::map<int64_t, Pose>& from_vio) {
  REQUIRE(from_daemon.size() > 100);
  REQUIRE(from_vio.size() == from_daemon.size());
  double max_dp = 0.0, max_dq = 0.0;
  for (const auto& [t, a] : from_daemon) {
    const auto it = from_vio.find(t);
    REQUIRE(it != from_vio.end());
    for (int i = 0; i < 3; ++i) max_dp = std::max(max_dp, std::abs(a.p[i] - it->second.p[i]));
    // q and -q are the same rotation; the TUM file has 9 decimals.
    double same = 0.0, flipped = 0.0;
    for (int i = 0; i < 4; ++i) {
      same = std::max(same, std::abs(a.q[i] - it->second.q[i]));
      flipped = std::max(flipped, std::abs(a.q[i] + it->second.q[i]));
    }
    max_dq = std::max(max_dq, std::min(same, flipped));
  }
  INFO("max |dp| " << max_dp << " m, max |dq| " << max_dq);
  CHECK(max_dp < 1e-8);  // the same numbers, up to the text file's 9 decimals
  CHECK(max_dq < 1e-8);
}

// The value of a "name value" line of the daemon's end-of-run counter report (-1: absent).
int64_t ReportCounter(const std::string& report, const std::string& name) {
  std::istringstream in(report);
  std::string line;
  while (std::getline(in, line)) {
    if (line.rfind(name + " ", 0) == 0) return std::stoll(line.substr(name.size() + 1));
  }
  return -1;
}

TEST_CASE("vilma vio and vilma-estimatord --input-log give the same trajectory",
          "[integration][vio]") {
  for (const char* b : {"vilma", "vilma-sim", "vilma-replay", "vilma-estimatord"}) {
    if (!test::FileExists(kBin + b)) VILMA_SKIP(kBin + b << " not built");
  }
  const std::string dir = test::ScratchDir() + "/vio_equivalence";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string dataset = dir + "/room", log = dir + "/room.lcmlog";
  // 6 s of the simulated room: a static start, then motion (stamps are whole microseconds, so
  // the LCM messages carry them exactly).
  test::ChildProcess sim({kBin + "vilma-sim", "room", "--out", dataset, "--seconds", "6", "--seed", "5"},
                         dir + "/sim.out");
  REQUIRE(sim.Wait(120.0) == 0);
  test::ChildProcess replay({kBin + "vilma-replay", dataset, "--to-log", log, "--quiet"},
                            dir + "/replay.out");
  REQUIRE(replay.Wait(60.0) == 0);

  const DaemonRun daemon = RunDaemon(dir, dataset, log, {}, "daemon");
  const std::map<int64_t, Pose> from_vio = RunVio(dir, dataset, {}, "vio");
  INFO(test::ReadTextFile(dir + "/vio.out") << test::ReadTextFile(dir + "/daemon.out"));
  CHECK(daemon.frames >= 119);  // 6 s at 20 Hz (the last frame may wait for IMU beyond the end)
  CheckSamePoses(daemon.tracking, from_vio);
  std::filesystem::remove_all(dir);
}

TEST_CASE("stereo: vilma vio --stereo and vilma-estimatord --stereo give the same trajectory, "
          "also when CAM1 drops frames",
          "[integration][vio][stereo]") {
  for (const char* b : {"vilma", "vilma-sim", "vilma-replay", "vilma-estimatord"}) {
    if (!test::FileExists(kBin + b)) VILMA_SKIP(kBin + b << " not built");
  }
  const std::string dir = test::ScratchDir() + "/vio_equivalence_stereo";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string dataset = dir + "/room", log = dir + "/room.lcmlog";
  test::ChildProcess sim({kBin + "vilma-sim", "room", "--out", dataset, "--seconds", "6", "--seed",
                          "5", "--stereo"},
                         dir + "/sim.out");
  REQUIRE(sim.Wait(120.0) == 0);
  {
    test::ChildProcess replay({kBin + "vilma-replay", dataset, "--to-log", log, "--quiet"},
                              dir + "/replay.out");
    REQUIRE(replay.Wait(60.0) == 0);
  }
  const DaemonRun daemon = RunDaemon(dir, dataset, log, {"--stereo"}, "daemon");
  const std::map<int64_t, Pose> from_vio = RunVio(dir, dataset, {"--stereo"}, "vio");
  const std::string daemon_out = test::ReadTextFile(dir + "/daemon.out");
  const std::string vio_out = test::ReadTextFile(dir + "/vio.out");
  {
    INFO(vio_out << daemon_out);
    CHECK(daemon.frames >= 119);
    CHECK(ReportCounter(daemon_out, "frames_without_stereo") == 0);
    CHECK_THAT(vio_out, Catch::Contains("0 frames without it"));
    // Stereo is on in both (its counters are printed; a mono run would not match them).
    CHECK_THAT(vio_out, Catch::Matches("[\\s\\S]*stereo +camera 1: [1-9][0-9]* updates accepted[\\s\\S]*"));
    CheckSamePoses(daemon.tracking, from_vio);
  }

  // CAM1 drops three frames in motion (the room moves after its 3 s static start): the
  // synchronizer releases those frames without the second image after
  // sync.incomplete_frame_timeout_ns, the filter updates them with CAM0 alone, counts them, and
  // goes on; `vilma vio` and the daemon still agree.
  const std::string csv = dataset + "/mav0/cam1/data.csv";
  std::vector<std::string> lines;
  {
    std::ifstream in(csv);
    for (std::string line; std::getline(in, line);) lines.push_back(line);
  }
  REQUIRE(lines.size() > 100);
  std::vector<int64_t> dropped_us;
  {
    std::ofstream out(csv, std::ios::trunc);
    int row = -1;
    for (const std::string& line : lines) {
      if (!line.empty() && line[0] != '#') ++row;
      if (row == 70 || row == 71 || row == 95) {
        dropped_us.push_back(std::stoll(line.substr(0, line.find(','))) / 1000);
        continue;
      }
      out << line << "\n";
    }
  }
  REQUIRE(dropped_us.size() == 3);
  const std::string log_drop = dir + "/room_drop.lcmlog";
  {
    test::ChildProcess replay({kBin + "vilma-replay", dataset, "--to-log", log_drop, "--quiet"},
                              dir + "/replay_drop.out");
    REQUIRE(replay.Wait(60.0) == 0);
  }
  const DaemonRun drop = RunDaemon(dir, dataset, log_drop, {"--stereo"}, "daemon_drop");
  const std::map<int64_t, Pose> vio_drop = RunVio(dir, dataset, {"--stereo"}, "vio_drop");
  const std::string drop_out = test::ReadTextFile(dir + "/daemon_drop.out");
  const std::string vio_drop_out = test::ReadTextFile(dir + "/vio_drop.out");
  INFO(vio_drop_out << drop_out);
  CHECK(drop.frames == daemon.frames);  // no frame lost, no stall
  CHECK(ReportCounter(drop_out, "frames_without_stereo") == 3);
  CHECK(ReportCounter(drop_out, "sync_frames_incomplete") == 3);
  CHECK_THAT(vio_drop_out, Catch::Contains("3 frames without it"));
  for (int64_t t_us : dropped_us) {
    INFO("frame at " << t_us << " us without CAM1");
    CHECK(drop.tracking.count(t_us) == 1);  // tracked through the dropout
  }
  CheckSamePoses(drop.tracking, vio_drop);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace vilma
