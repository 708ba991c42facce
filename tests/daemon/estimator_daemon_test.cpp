// The daemon's pipeline in-process, on a small LCM log (no network): log order, blocking
// backpressure, counters, the end of the log ends the run. The multi-process tests with real
// LCM, signals and systemd are in tests/integration/estimatord_test.cpp.
#include "vilma/daemon/estimator_daemon.h"

#include <unistd.h>

#include <catch2/catch.hpp>
#include <cstdlib>
#include <filesystem>
#include <random>
#include <thread>

#include <vilma/pose_t.hpp>

#include "vilma/core/time.h"
#include "vilma/drivers/lcm_convert.h"
#include "vilma/drivers/lcm_log.h"
#include "vilma/mapstore/consistency.h"
#include "vilma/mapstore/map_io.h"

namespace vilma::daemon {
namespace {

SensorRig SmallRig() {
  SensorRig rig;
  CameraConfig camera;
  camera.camera = Camera(160, 120, Eigen::Vector4d(150, 150, 80, 60), DistortionModel::kNone,
                         Eigen::VectorXd());
  rig.cameras.push_back(camera);
  return rig;
}

// 2 s of a static rig at 200 Hz IMU / 20 Hz camera with a random texture, plus bad messages.
std::string WriteLog(const std::string& dir) {
  const std::string path = dir + "/small.lcmlog";
  LcmLogWriter writer(path);
  std::mt19937 rng(7);
  cv::Mat texture(120, 160, CV_8UC1);
  cv::randu(texture, 0, 255);
  const int64_t t0 = SecondsToNs(100.0);
  int64_t image_seq = 0;
  for (int i = 0; i <= 400; ++i) {
    const int64_t t = t0 + i * 5000000;
    ImuSample s;
    s.t_ns = t;
    s.a_I = Eigen::Vector3d(0, 0, 9.81);
    writer.WriteMessage("IMU", ImuToMessage(s, i), NsToUtime(t));
    if (i % 10 == 0) {
      image_t msg;
      REQUIRE(MakeImageMessage(texture, image_t::GRAY8, t, image_seq++, 0, &msg).empty());
      writer.WriteMessage("CAM0", msg, NsToUtime(t));
    }
    if (i == 100) {
      std::vector<uint8_t> junk(333);
      for (uint8_t& b : junk) b = static_cast<uint8_t>(rng());
      writer.Write("CAM0", junk.data(), static_cast<int>(junk.size()), NsToUtime(t));
      writer.Write("IMU", junk.data(), 72, NsToUtime(t));
      image_t small;
      REQUIRE(MakeImageMessage(cv::Mat(10, 10, CV_8UC1, cv::Scalar(1)), image_t::GRAY8, t, 0, 0, &small).empty());
      writer.WriteMessage("CAM0", small, NsToUtime(t));  // not the rig's size
    }
  }
  writer.Close();
  return path;
}

TEST_CASE("the daemon runs an LCM log to its end, counting bad input, dropping nothing") {
  const std::string dir = "/tmp/vilma_daemon_test_" + std::to_string(::getpid());
  std::filesystem::create_directories(dir);
  DaemonOptions options;
  options.channels.cameras = {"CAM0"};
  options.input_log = WriteLog(dir);
  options.lcm_url = "file://" + dir + "/out.lcm?mode=w";
  // A small pool and queues: the log mode must block, not drop.
  options.queues.max_frames_in_flight = 1;
  options.queues.input_capacity = 16;
  options.queues.filter_capacity = 16;
  options.queues.output_capacity = 4;
  options.queues.image_pool_slots = 1 * (options.sync.max_pending_frames + 2) + 1 + 2;
  EstimatorDaemon daemon(options, SmallRig());
  const DaemonSummary summary = daemon.Run();
  INFO(summary.report);
  CHECK(summary.frames_filtered == 41);
  CHECK(summary.poses_published == 41);
  CHECK(summary.malformed_messages == 3);  // junk on CAM0 and IMU, an image of the wrong size
  CHECK(summary.drops == 0);
  int odom = 0;
  int statuses = 0;
  for (const LcmLogEvent& e : ReadLcmLog(dir + "/out.lcm")) {
    if (e.channel == "VILMA_ODOM") {
      pose_t msg;
      REQUIRE(msg.decode(e.data.data(), 0, static_cast<int>(e.data.size())) > 0);
      CHECK(msg.seq == odom++);
      CHECK(msg.parent_frame == "M");
    }
    statuses += e.channel == "VILMA_STATUS" ? 1 : 0;
  }
  CHECK(odom == 41);
  CHECK(statuses >= 1);  // at least the final STOPPING report
  std::filesystem::remove_all(dir);
}

TEST_CASE("the daemon rejects a pool too small for the synchronizer and bad options") {
  {
    // The defaults fit a stereo rig.
    SensorRig stereo = SmallRig();
    stereo.cameras.push_back(stereo.cameras[0]);
    stereo.cameras[1].name = "cam1";
    DaemonOptions defaults;
    defaults.lcm_url = "memq://";
    CHECK_NOTHROW(EstimatorDaemon(defaults, stereo));
  }
  DaemonOptions options;
  options.channels.cameras = {"CAM0"};
  options.lcm_url = "memq://";
  options.queues.image_pool_slots = 4;
  CHECK_THROWS_AS(EstimatorDaemon(options, SmallRig()), InputError);
  options = DaemonOptions();
  options.lcm_url = "memq://";
  options.vio_camera = 1;  // the rig has one camera
  CHECK_THROWS_AS(EstimatorDaemon(options, SmallRig()), InputError);
}

TEST_CASE("map building: the stage runs a log, saves the mission, drops nothing",
          "[daemon][mapping]") {
  const std::string dir = "/tmp/vilma_daemon_map_test_" + std::to_string(::getpid());
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  DaemonOptions options;
  options.channels.cameras = {"CAM0"};
  options.input_log = WriteLog(dir);
  options.lcm_url = "file://" + dir + "/out.lcm?mode=w";
  options.mapping.enabled = true;
  options.mapping.save_dir = dir + "/map";
  options.mapping.max_frames_in_flight = 1;  // the filter must wait for the builder (log mode)
  options.mapping.queue_capacity = 16;
  options.mapping.mission_name = "small";
  DaemonSummary summary;
  {
    EstimatorDaemon daemon(options, SmallRig());
    summary = daemon.Run();
  }
  INFO(summary.report << summary.map_report);
  CHECK(summary.drops == 0);
  CHECK(summary.map_saved);
  CHECK(summary.map_error.empty());
  const mapstore::VIMap map = mapstore::LoadMap(dir + "/map");
  REQUIRE(map.mission_ids().size() == 1);
  const mapstore::Mission& mission = map.mission(map.mission_ids()[0]);
  CHECK(mission.complete);
  CHECK(mission.name == "small");
  // At most 10 Hz over 2 s of frames; only frames with a tracked pose become vertices.
  CHECK(map.vertex_ids(mission.id).size() <= 21);
  CHECK(mapstore::CheckMapConsistency(map).ok());

  // A second run into the same folder is refused before anything runs (no silent overwrite).
  CHECK_THROWS_AS(EstimatorDaemon(options, SmallRig()), InputError);
  std::filesystem::remove_all(dir);
}

// "name value" of the daemon's final report (-1 when absent).
long long ReportCounter(const std::string& report, const std::string& name) {
  const std::string key = name + " ";
  std::size_t at = report.rfind("\n" + key);
  if (at != std::string::npos) {
    ++at;
  } else if (report.compare(0, key.size(), key) == 0) {
    at = 0;
  } else {
    return -1;
  }
  return std::atoll(report.c_str() + at + key.size());
}

// A filter reset (fault injection) ends the mission: the frames after it are a new mission
// with its own ids and name, not linked to the first; one left with < 2 vertices is dropped.
TEST_CASE("map building: a filter reset starts a new mission", "[daemon][mapping]") {
  const std::string dir = "/tmp/vilma_daemon_reset_test_" + std::to_string(::getpid());
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  DaemonOptions options;
  options.channels.cameras = {"CAM0"};
  options.input_log = WriteLog(dir);
  options.mapping.enabled = true;
  options.mapping.max_frames_in_flight = 1;
  options.mapping.queue_capacity = 16;
  options.mapping.mission_name = "small";
  auto run = [&](int64_t reset_at, const std::string& name) {
    options.lcm_url = "file://" + dir + "/" + name + ".lcm?mode=w";
    options.mapping.save_dir = dir + "/" + name;
    options.fault_reset_filter_at = reset_at;
    EstimatorDaemon daemon(options, SmallRig());
    return daemon.Run();
  };

  SECTION("reset in the middle: two missions") {
    const DaemonSummary summary = run(20, "middle");
    INFO(summary.report << summary.map_report);
    CHECK(summary.map_saved);
    CHECK(ReportCounter(summary.report, "filter_resets") == 1);
    CHECK(ReportCounter(summary.report, "map_missions") == 2);
    CHECK(ReportCounter(summary.report, "map_missions_dropped") == 0);
    const mapstore::VIMap map = mapstore::LoadMap(dir + "/middle");
    CHECK(mapstore::CheckMapConsistency(map).ok());
    REQUIRE(map.mission_ids().size() == 2);
    CHECK(map.mission(map.mission_ids()[0]).name == "small");
    CHECK(map.mission(map.mission_ids()[1]).name == "small-1");
    std::size_t vertices = 0;
    for (const mapstore::MissionId& id : map.mission_ids()) {
      CHECK(map.mission(id).complete);
      CHECK(map.vertex_ids(id).size() >= 2);
      CHECK(map.VertexChain(id).size() == map.vertex_ids(id).size());
      for (const mapstore::EdgeId& e : map.edge_ids(id)) {
        CHECK(map.vertex(map.edge(e).to).mission_id == id);  // nothing links the missions
      }
      vertices += map.vertex_ids(id).size();
    }
    CHECK(ReportCounter(summary.report, "map_vertices") == static_cast<long long>(vertices));
    // The first mission is the one a run without reset makes (same seed, same id).
    const DaemonSummary plain = run(-1, "plain");
    const mapstore::VIMap single = mapstore::LoadMap(dir + "/plain");
    REQUIRE(single.mission_ids().size() == 1);
    CHECK(single.mission_ids()[0] == map.mission_ids()[0]);
    CHECK(ReportCounter(plain.report, "map_missions") == 1);
  }
  SECTION("reset at the last frame: the new mission has < 2 vertices and is dropped") {
    const DaemonSummary summary = run(39, "late");
    INFO(summary.report << summary.map_report);
    CHECK(summary.map_saved);
    CHECK(ReportCounter(summary.report, "map_missions") == 2);
    CHECK(ReportCounter(summary.report, "map_missions_dropped") == 1);
    const mapstore::VIMap map = mapstore::LoadMap(dir + "/late");
    REQUIRE(map.mission_ids().size() == 1);
    CHECK(map.mission(map.mission_ids()[0]).name == "small");
  }
  std::filesystem::remove_all(dir);
}

TEST_CASE("map building: bad combinations are refused at construction", "[daemon][mapping]") {
  DaemonOptions options;
  options.channels.cameras = {"CAM0"};
  options.lcm_url = "memq://";
  options.mapping.enabled = true;
  CHECK_NOTHROW(EstimatorDaemon(options, SmallRig()));
  options.mapping.map_builder.cameras = {1};  // the daemon subscribes one camera
  CHECK_THROWS_AS(EstimatorDaemon(options, SmallRig()), InputError);
  options.mapping.map_builder.cameras.clear();
  options.queues.image_pool_slots = 1 * (options.sync.max_pending_frames + 2) + 2 + 2;  // enough
  CHECK_THROWS_AS(EstimatorDaemon(options, SmallRig()), InputError);  // ... without mapping only
  {
    // The defaults fit a stereo rig with map building.
    SensorRig stereo = SmallRig();
    stereo.cameras.push_back(stereo.cameras[0]);
    stereo.cameras[1].name = "cam1";
    DaemonOptions defaults;
    defaults.lcm_url = "memq://";
    defaults.mapping.enabled = true;
    CHECK_NOTHROW(EstimatorDaemon(defaults, stereo));
  }
  // Streaming opens its own LCM.
  options = DaemonOptions();
  options.channels.cameras = {"CAM0"};
  options.lcm_url = "memq://";
  options.mapping.enabled = true;
  options.mapping.stream.enabled = true;
  CHECK_NOTHROW(EstimatorDaemon(options, SmallRig()));
  options.mapping.stream.lcm_url = "nosuchprovider://x";
  CHECK_THROWS_AS(EstimatorDaemon(options, SmallRig()), InputError);
}

TEST_CASE("a stop request ends a live run promptly") {
  DaemonOptions options;
  options.lcm_url = "memq://";
  EstimatorDaemon daemon(options, SmallRig());
  std::thread stopper([&] {
    std::this_thread::sleep_for(std::chrono::milliseconds(200));
    daemon.RequestStop();
  });
  const auto t0 = std::chrono::steady_clock::now();
  const DaemonSummary summary = daemon.Run();
  stopper.join();
  CHECK(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count() < 1.0);
  CHECK(summary.frames_filtered == 0);
}

}  // namespace
}  // namespace vilma::daemon
