// vilma-estimatord in LOC mode (docs/daemon.md "Localization"): simulated `room` session 1
// localized against a ground-truth map of session 0 (G = the simulator's world W), through
// --input-log (deterministic), as real processes.
#include <catch2/catch.hpp>
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <vilma/pose_t.hpp>
#include <vilma/status_t.hpp>

#include "integration/process_util.h"
#include "vilma/core/asl_dataset.h"
#include "vilma/core/geometry.h"
#include "vilma/core/time.h"
#include "vilma/drivers/lcm_log.h"

namespace vilma {
namespace {

const std::string kBin = std::string(VILMA_BINARY_DIR) + "/bin/";
const std::string kDaemon = kBin + "vilma-estimatord";
const std::string kSim = kBin + "vilma-sim";
const std::string kReplay = kBin + "vilma-replay";
const std::string kLocmap = kBin + "vilma-locmap-gt";

struct LocData {
  std::string dir, session1, log1, map_room, map_hall;
};

const LocData& Data() {
  static LocData data = [] {
    LocData d;
    d.dir = test::ScratchDir() + "/estimatord_loc";
    std::filesystem::remove_all(d.dir);
    std::filesystem::create_directories(d.dir);
    auto run = [&](const std::vector<std::string>& args, const std::string& name) {
      test::ChildProcess p(args, d.dir + "/" + name + ".out");
      if (p.Wait(120.0) != 0) {
        throw std::runtime_error(name + " failed: " + test::ReadTextFile(d.dir + "/" + name + ".out"));
      }
    };
    run({kSim, "room", "--session", "0", "--seed", "1", "--seconds", "20", "--out", d.dir + "/room0"}, "sim0");
    run({kSim, "room", "--session", "1", "--seed", "1", "--seconds", "15", "--out", d.dir + "/room1"}, "sim1");
    run({kSim, "hall", "--session", "0", "--seed", "1", "--seconds", "6", "--out", d.dir + "/hall0"}, "simh");
    d.session1 = d.dir + "/room1";
    d.log1 = d.dir + "/room1.lcmlog";
    d.map_room = d.dir + "/room0.vlocmap";
    d.map_hall = d.dir + "/hall0.vlocmap";
    run({kReplay, d.session1, "--to-log", d.log1, "--quiet"}, "replay1");
    run({kLocmap, d.dir + "/room0", d.map_room}, "locmap_room");
    run({kLocmap, d.dir + "/hall0", d.map_hall}, "locmap_hall");
    static const std::string dir_to_remove = d.dir;
    std::atexit([] {
      if (!std::getenv("VILMA_KEEP_TEST_DATA")) std::filesystem::remove_all(dir_to_remove);
    });
    return d;
  }();
  return data;
}

struct Run {
  int exit_status = -1;
  std::vector<std::vector<uint8_t>> pose_payloads;
  std::vector<pose_t> odom, pose;
  std::map<std::string, int64_t> counters;  // the last status
  std::string output;
};

Run RunDaemon(const std::string& map, const std::string& name) {
  const LocData& d = Data();
  const std::string out = d.dir + "/" + name + ".lcm";
  std::filesystem::remove(out);
  std::vector<std::string> args = {kDaemon, "--rig", d.session1 + "/rig.yaml", "--input-log", d.log1,
                                   "--lcm-url", "file://" + out + "?mode=w"};
  if (!map.empty()) {
    args.push_back("--localization-map");
    args.push_back(map);
  }
  Run r;
  test::ChildProcess p(args, d.dir + "/" + name + ".out");
  r.exit_status = p.Wait(60.0);
  r.output = test::ReadTextFile(d.dir + "/" + name + ".out");
  for (const LcmLogEvent& e : ReadLcmLog(out)) {
    if (e.channel == "VILMA_POSE") {
      r.pose_payloads.push_back(e.data);
      pose_t m;
      if (m.decode(e.data.data(), 0, static_cast<int>(e.data.size())) > 0) r.pose.push_back(m);
    } else if (e.channel == "VILMA_ODOM") {
      pose_t m;
      if (m.decode(e.data.data(), 0, static_cast<int>(e.data.size())) > 0) r.odom.push_back(m);
    } else if (e.channel == "VILMA_STATUS") {
      status_t s;
      if (s.decode(e.data.data(), 0, static_cast<int>(e.data.size())) > 0) {
        r.counters.clear();
        for (int i = 0; i < s.num_counters; ++i) r.counters[s.counter_names[i]] = s.counter_values[i];
      }
    }
  }
  return r;
}

Transformation PoseOf(const pose_t& m) {
  return Transformation(Eigen::Quaterniond(m.orientation[0], m.orientation[1], m.orientation[2],
                                           m.orientation[3]),
                        Eigen::Vector3d(m.position[0], m.position[1], m.position[2]));
}

// Position RMSE against ground truth at the same stamps [m]; `align_first`: the poses are
// first moved by the transformation that puts the first one onto its ground truth. Only the
// stamps in `only` count when it is not empty.
double Rmse(const std::vector<pose_t>& poses, const std::string& dataset, bool align_first,
            int status, const std::vector<int64_t>& only = {}) {
  const AslDataset ds = AslDataset::Open(dataset);
  std::map<int64_t, Transformation> gt;
  for (const GroundTruthState& s : ds.ground_truth()) gt[s.t_ns] = Transformation(s.q_W_I, s.p_W_I);
  double sum = 0.0;
  int n = 0;
  bool have_alignment = false;
  Transformation T_W_X;
  for (const pose_t& m : poses) {
    if (m.status != status) continue;
    const auto it = gt.find(UtimeToNs(m.utime));
    if (it == gt.end()) continue;
    Transformation T = PoseOf(m);
    if (align_first) {
      if (!have_alignment) {
        T_W_X = it->second * T.inverse();
        have_alignment = true;
      }
      T = T_W_X * T;
    }
    if (!only.empty() && !std::binary_search(only.begin(), only.end(), m.utime)) continue;
    sum += (T.translation() - it->second.translation()).squaredNorm();
    ++n;
  }
  return n > 0 ? std::sqrt(sum / n) : 1e9;
}

bool HaveBinaries() {
  for (const std::string& b : {kDaemon, kSim, kReplay, kLocmap}) {
    if (!test::FileExists(b)) {
      WARN("skipped: " << b << " not built");
      return false;
    }
  }
  return true;
}

TEST_CASE("vilma-estimatord --localization-map: global pose against a prior map, deterministic",
          "[integration][daemon][localization]") {
  if (!HaveBinaries()) return;
  const LocData& d = Data();
  const Run a = RunDaemon(d.map_room, "loc_a");
  INFO(a.output);
  REQUIRE(a.exit_status == 0);
  REQUIRE(!a.pose.empty());
  for (const pose_t& m : a.pose) {
    CHECK(m.status == pose_t::LOCALIZED);
    CHECK(m.parent_frame == "G");
  }
  const double rmse_loc = Rmse(a.pose, d.session1, false, pose_t::LOCALIZED);
  // VIO only: aligned at its first pose, on the frames that have a VILMA_POSE (the same
  // frames), and over the whole run.
  std::vector<int64_t> stamps;
  for (const pose_t& m : a.pose) stamps.push_back(m.utime);
  const double rmse_vio = Rmse(a.odom, d.session1, true, pose_t::TRACKING, stamps);
  const double rmse_vio_all = Rmse(a.odom, d.session1, true, pose_t::TRACKING);
  const int64_t attempts = a.counters.at("loc_attempts");
  const int64_t accepted = a.counters.at("loc_tgm_updates");
  WARN("LOC: VILMA_POSE " << a.pose.size() << " of " << a.odom.size() << " frames, RMSE (no alignment) "
                          << rmse_loc << " m; VIO only (first pose aligned) " << rmse_vio
                          << " m on the same frames, " << rmse_vio_all << " m over the run; recall " << accepted << "/" << attempts << ", stage p50 "
                          << a.counters.at("loc_stage_us_p50") / 1000.0 << " ms");
  CHECK(rmse_loc <= 0.15);
  CHECK(rmse_loc < rmse_vio);
  CHECK(attempts > 0);
  CHECK(a.counters.at("loc_poses_published") == static_cast<int64_t>(a.pose.size()));
  // Deterministic: a second run publishes the same VILMA_POSE bytes.
  const Run b = RunDaemon(d.map_room, "loc_b");
  REQUIRE(b.exit_status == 0);
  CHECK(a.pose_payloads == b.pose_payloads);
}

TEST_CASE("vilma-estimatord --localization-map: a map of another world gives no global pose",
          "[integration][daemon][localization]") {
  if (!HaveBinaries()) return;
  const LocData& d = Data();
  const Run r = RunDaemon(d.map_hall, "loc_hall");
  INFO(r.output);
  REQUIRE(r.exit_status == 0);
  CHECK(r.pose.empty());
  CHECK(r.counters.at("loc_attempts") > 0);
  CHECK(r.counters.at("loc_initialized") == 0);
  CHECK(!r.odom.empty());
}

}  // namespace
}  // namespace vilma
