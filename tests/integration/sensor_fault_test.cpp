// Sensor faults through the real processes (issue 18, docs/reliability.md "Sensor faults"):
// vilma-replay --fault injects the fault into an LCM log of a simulated room session, and
// vilma-estimatord --input-log (deterministic) must give a valid pose again within 1 s of the
// fault's end (sensor time), having tracked before it; VILMA_STATUS counters name the fault.
// scripts/sensor-faults.sh measures every fault class live; this test keeps three in the suite.
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>
#include <string>
#include <vector>

#include <vilma/pose_t.hpp>

#include "integration/process_util.h"
#include "test_skip.h"
#include "vilma/core/asl_dataset.h"
#include "vilma/core/time.h"
#include "vilma/drivers/lcm_log.h"

namespace vilma {
namespace {

const std::string kBin = std::string(VILMA_BINARY_DIR) + "/bin/";
const std::string kDaemon = kBin + "vilma-estimatord";
const std::string kSim = kBin + "vilma-sim";
const std::string kReplay = kBin + "vilma-replay";

struct FaultRun {
  std::vector<pose_t> odom;  // VILMA_ODOM in log order
  std::string output;        // the daemon's stdout + stderr (final counters)
};

// The session (12 s of the room, 3 s static start), made once per test process.
const std::string& Session() {
  static const std::string dir = [] {
    const std::string d = test::ScratchDir() + "/sensor_faults";
    std::filesystem::remove_all(d);
    std::filesystem::create_directories(d);
    test::ChildProcess sim({kSim, "room", "--session", "0", "--seed", "2", "--seconds", "12",
                            "--out", d + "/room"},
                           d + "/sim.out");
    REQUIRE(sim.Wait(120.0) == 0);
    return d;
  }();
  return dir;
}

FaultRun RunWithFault(const std::string& name, const std::string& fault) {
  const std::string dir = Session();
  const std::string log = dir + "/" + name + ".lcmlog";
  const std::string out = dir + "/" + name + "-out.lcmlog";
  // fault "": the clean replay (the reference of a fault run).
  std::vector<std::string> replay_args = {kReplay, dir + "/room", "--to-log", log};
  if (!fault.empty()) {
    replay_args.push_back("--fault");
    replay_args.push_back(fault);
  }
  test::ChildProcess replay(replay_args, dir + "/" + name + "-replay.out");
  REQUIRE(replay.Wait(60.0) == 0);
  if (!fault.empty()) {
    CHECK_THAT(test::ReadTextFile(dir + "/" + name + "-replay.out"), Catch::Contains("faults: "));
  }
  test::ChildProcess daemon({kDaemon, "--rig", dir + "/room/rig.yaml", "--input-log", log,
                             "--lcm-url", "file://" + out + "?mode=w"},
                            dir + "/" + name + "-daemon.out");
  FaultRun run;
  const int status = daemon.Wait(120.0);
  run.output = test::ReadTextFile(dir + "/" + name + "-daemon.out");
  INFO(run.output);
  REQUIRE(status == 0);
  for (const LcmLogEvent& e : ReadLcmLog(out)) {
    if (e.channel != "VILMA_ODOM") continue;
    pose_t p;
    if (p.decode(e.data.data(), 0, static_cast<int>(e.data.size())) > 0) run.odom.push_back(p);
  }
  return run;
}

int64_t FirstStampNs() {
  return AslDataset::Open(Session() + "/room").imu().front().t_ns;
}

// Seconds (sensor time) from `fault_end_ns` to the first TRACKING pose at or after it; checks
// that the filter tracked before `fault_start_ns`. -1 if it never tracks again.
double RecoveryS(const FaultRun& run, int64_t fault_start_ns, int64_t fault_end_ns) {
  bool tracked_before = false;
  for (const pose_t& p : run.odom) {
    const int64_t t_ns = UtimeToNs(p.utime);
    if (t_ns < fault_start_ns && p.status == pose_t::TRACKING) tracked_before = true;
    if (t_ns >= fault_end_ns && p.status == pose_t::TRACKING) {
      CHECK(tracked_before);
      return NsToSeconds(t_ns - fault_end_ns);
    }
  }
  return -1.0;
}

// "name value" lines of the daemon's final report.
int64_t Counter(const std::string& output, const std::string& name) {
  const std::string key = "\n" + name + " ";
  const std::size_t at = output.find(key);
  if (at == std::string::npos) return -1;
  return std::stoll(output.substr(at + key.size()));
}

TEST_CASE("a camera silent for 2 s: tracking again within 1 s of its return",
          "[integration][daemon][faults]") {
  for (const std::string& b : {kDaemon, kSim, kReplay}) {
    if (!test::FileExists(b)) VILMA_SKIP(b << " not built");
  }
  const int64_t t0 = FirstStampNs();
  const FaultRun run = RunWithFault("camera_drop", "camera-drop:6:2");
  INFO(run.output);
  const double recovery_s = RecoveryS(run, t0 + SecondsToNs(6.0), t0 + SecondsToNs(8.0));
  CHECK(recovery_s >= 0.0);
  CHECK(recovery_s < 1.0);
  // No pose from the camera's silence (poses are per frame), and the silence is reported.
  for (const pose_t& p : run.odom) {
    const int64_t t_ns = UtimeToNs(p.utime);
    CHECK_FALSE((t_ns >= t0 + SecondsToNs(6.0) && t_ns < t0 + SecondsToNs(8.0)));
  }
  CHECK(Counter(run.output, "camera_silences") == 1);
  CHECK(Counter(run.output, "filter_resets") == 0);
}

TEST_CASE("an IMU gap of 0.5 s: tracking again within 1 s of its end",
          "[integration][daemon][faults]") {
  for (const std::string& b : {kDaemon, kSim, kReplay}) {
    if (!test::FileExists(b)) VILMA_SKIP(b << " not built");
  }
  const int64_t t0 = FirstStampNs();
  const FaultRun run = RunWithFault("imu_gap", "imu-gap:6:0.5");
  INFO(run.output);
  const double recovery_s = RecoveryS(run, t0 + SecondsToNs(6.0), t0 + SecondsToNs(6.5));
  CHECK(recovery_s >= 0.0);
  CHECK(recovery_s < 1.0);
  CHECK(Counter(run.output, "sync_imu_gaps") == 1);
}

TEST_CASE("stamps +2 s for 1 s, then back: the pre-jump filter resumes within 1 s of the return",
          "[integration][daemon][faults]") {
  for (const std::string& b : {kDaemon, kSim, kReplay}) {
    if (!test::FileExists(b)) VILMA_SKIP(b << " not built");
  }
  const int64_t t0 = FirstStampNs();
  const FaultRun run = RunWithFault("time_jump_return", "time-jump:6:1:2");
  const FaultRun clean = RunWithFault("clean", "");
  INFO(run.output);
  // In log order: poses before the jump (< 6 s), the jumped ones (stamps 8..9 s), then back on
  // the original timeline (from 7 s). The return is the first pose whose stamp goes back.
  std::size_t back = 0;
  for (std::size_t k = 1; k < run.odom.size(); ++k) {
    if (run.odom[k].utime < run.odom[k - 1].utime) {
      back = k;
      break;
    }
  }
  REQUIRE(back > 0);
  const int64_t fault_end_ns = t0 + SecondsToNs(7.0);
  CHECK(UtimeToNs(run.odom[back].utime) >= fault_end_ns);
  bool tracked_before = false;
  for (std::size_t k = 0; k < back; ++k) {
    if (UtimeToNs(run.odom[k].utime) < t0 + SecondsToNs(6.0) &&
        run.odom[k].status == pose_t::TRACKING) {
      tracked_before = true;
    }
  }
  CHECK(tracked_before);
  double recovery_s = -1.0;
  std::size_t first_tracking = run.odom.size();
  for (std::size_t k = back; k < run.odom.size(); ++k) {
    if (run.odom[k].status == pose_t::TRACKING) {
      recovery_s = NsToSeconds(UtimeToNs(run.odom[k].utime) - fault_end_ns);
      first_tracking = k;
      break;
    }
  }
  CHECK(recovery_s >= 0.0);
  CHECK(recovery_s < 1.0);
  // Resumed, not re-initialized: the poses after the return are in the clean run's frame M
  // (the pre-jump filter's), within a few cm of the clean run's at equal stamps.
  double max_diff_m = 0.0;
  int compared = 0;
  for (std::size_t k = first_tracking; k < run.odom.size(); ++k) {
    if (run.odom[k].status != pose_t::TRACKING) continue;
    for (const pose_t& c : clean.odom) {
      if (c.utime != run.odom[k].utime || c.status != pose_t::TRACKING) continue;
      const double dx = run.odom[k].position[0] - c.position[0];
      const double dy = run.odom[k].position[1] - c.position[1];
      const double dz = run.odom[k].position[2] - c.position[2];
      max_diff_m = std::max(max_diff_m, std::sqrt(dx * dx + dy * dy + dz * dz));
      ++compared;
    }
  }
  INFO("compared " << compared << " poses, max position difference " << max_diff_m << " m");
  CHECK(compared > 50);
  // Measured 0.018 m; interpolating across the 1-s gap instead of re-stamping gave 1.36 m.
  CHECK(max_diff_m < 0.1);
  CHECK(Counter(run.output, "time_jump_imu_restamped") > 150);  // of ~200 missing samples
  CHECK(Counter(run.output, "time_jump_restarts") == 1);  // at the jump away
  CHECK(Counter(run.output, "time_jump_resumes") == 1);   // at the return
  CHECK(Counter(run.output, "filter_resets") == 0);
}

}  // namespace
}  // namespace vilma
