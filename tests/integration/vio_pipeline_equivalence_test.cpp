// One estimator path (issue 19): the same dataset through `vilma vio` (offline, VioPipeline)
// and through `vilma-replay --to-log` + `vilma-estimatord --input-log` (LCM log, the daemon's
// threads) gives the same trajectory.
#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>

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

  const std::string odom = dir + "/odom.lcm";
  test::ChildProcess daemon({kBin + "vilma-estimatord", "--rig", dataset + "/rig.yaml",
                             "--input-log", log, "--lcm-url", "file://" + odom + "?mode=w"},
                            dir + "/daemon.out");
  REQUIRE(daemon.Wait(60.0) == 0);
  std::map<int64_t, Pose> from_daemon;
  int64_t daemon_frames = 0;
  for (const LcmLogEvent& e : ReadLcmLog(odom)) {
    if (e.channel != "VILMA_ODOM") continue;
    pose_t msg;
    REQUIRE(msg.decode(e.data.data(), 0, static_cast<int>(e.data.size())) ==
            static_cast<int>(e.data.size()));
    ++daemon_frames;
    if (msg.status != pose_t::TRACKING) continue;
    Pose p;
    for (int i = 0; i < 3; ++i) p.p[i] = msg.position[i];
    p.q[0] = msg.orientation[1];
    p.q[1] = msg.orientation[2];
    p.q[2] = msg.orientation[3];
    p.q[3] = msg.orientation[0];
    from_daemon[msg.utime] = p;
  }

  const std::string traj = dir + "/vio.txt";
  test::ChildProcess vio({kBin + "vilma", "vio", dataset, "--out", traj}, dir + "/vio.out");
  REQUIRE(vio.Wait(120.0) == 0);
  const std::map<int64_t, Pose> from_vio = ReadTum(traj);
  INFO(test::ReadTextFile(dir + "/vio.out") << test::ReadTextFile(dir + "/daemon.out"));

  CHECK(daemon_frames >= 119);  // 6 s at 20 Hz (the last frame may wait for IMU beyond the end)
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
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace vilma
