// The data export commands (ettc, encc, csv_export, export_landmarks_ply, export_colmap)
// through the console on the real daemon-built two-mission map (test_maps.h): the files are
// read back by vilma's loaders, `vilma eval` and `colmap model_analyzer`; bad input (missing or
// unwritable --out, an unknown format or mission) fails with a message naming it.
#include <catch2/catch.hpp>
#include <filesystem>
#include <sstream>

#include "console_plugins/test_maps.h"
#include "mapping_export/colmap_analyzer.h"
#include "mapping_export/data_export_test_util.h"
#include "vilma/console/session.h"
#include "vilma/core/rig.h"
#include "vilma/eval/trajectory.h"
#include "vilma/mapstore/vi_map.h"
#include "test_skip.h"

namespace vilma::console {
namespace {

namespace fs = std::filesystem;
using mapping::testing::ReadLines;

using Fixture = test::ConsoleFixture;

// Loads both sessions as one map of two missions.
void LoadBoth(Fixture* f) {
  REQUIRE(f->Run("load_merge_all_maps --maps_folder " + test::TestMaps().maps_folder).ok());
  REQUIRE(f->map().mission_ids().size() == 2);
}

// A number after `"key": ` in a JSON text.
double JsonNumber(const std::string& json, const std::string& key) {
  const std::size_t at = json.find("\"" + key + "\": ");
  REQUIRE(at != std::string::npos);
  return std::stod(json.substr(at + key.size() + 4));
}

TEST_CASE("ettc writes one trajectory per mission that vilma eval reads (ATE 0 on itself)") {
  Fixture f;
  LoadBoth(&f);
  const std::string dir = test::ConsoleScratch("ettc");
  REQUIRE(
      f.Run("ettc --pose_export_file=" + dir + "/traj.csv --csv_export_format=asl --frame=M").ok());
  CHECK_THAT(f.out.str(), Catch::Contains("2 files") && Catch::Contains("frame M"));
  for (const mapstore::MissionId& id : f.map().mission_ids()) {
    const std::string path = dir + "/traj_" + id.Hex() + ".csv";
    const Trajectory read = ReadTrajectoryFile(path);
    REQUIRE(read.size() == f.map().vertex_ids(id).size());
    // `vilma eval` of the export against itself.
    const std::string json = dir + "/self_" + id.Hex() + ".json";
    test::ChildProcess eval(
        {test::BinDir() + "/vilma", "eval", "--gt", path, "--est", path, "--json", json},
        dir + "/eval.out");
    REQUIRE(eval.Wait(60.0) == 0);
    const std::string text = test::ReadTextFile(json);
    CHECK(JsonNumber(text, "matched_poses") == read.size());
    CHECK(JsonNumber(text, "translation_rmse_m") == 0.0);
    CHECK(JsonNumber(text, "rotation_rmse_deg") < 1e-5);  // acos of a dot product near 1
  }
  // Session 0's VIO map against the simulator's ground truth (EuRoC CSV both): the map's drift.
  const mapstore::MissionId first = f.map().mission_ids()[0];
  REQUIRE(f.Run("ettc " + dir + "/s0.txt --mission=" + first.Hex().substr(0, 8)).ok());
  test::ChildProcess eval(
      {test::BinDir() + "/vilma", "eval", "--gt",
       test::TestMaps().session0_dataset + "/mav0/state_groundtruth_estimate0/data.csv", "--est",
       dir + "/s0.txt", "--json", dir + "/s0.json"},
      dir + "/eval_s0.out");
  REQUIRE(eval.Wait(60.0) == 0);
  const std::string text = test::ReadTextFile(dir + "/s0.json");
  CHECK(JsonNumber(text, "matched_poses") == f.map().vertex_ids(first).size());
  CHECK(JsonNumber(text, "translation_rmse_m") < 0.05);  // measured 0.0044 m
}

TEST_CASE("encc, csv_export and export_landmarks_ply on a daemon map") {
  Fixture f;
  LoadBoth(&f);
  const std::string dir = test::ConsoleScratch("data_exports");
  const mapstore::VIMap& map = f.map();

  REQUIRE(f.Run("encc --ncamera_calibration_export_folder=" + dir + "/rigs/").ok());
  for (const mapstore::MissionId& id : map.mission_ids()) {
    const SensorRig rig = LoadSensorRig(dir + "/rigs/rig_" + id.Hex() + ".yaml");
    REQUIRE(rig.cameras.size() == map.mission(id).rig.cameras.size());
    CHECK(rig.cameras[0].camera.intrinsics() == map.mission(id).rig.cameras[0].camera.intrinsics());
  }

  REQUIRE(f.Run("csv_export --csv_export_path=" + dir + "/csv --csv_export_descriptors").ok());
  std::size_t observations = 0, good = 0;
  for (const mapstore::MissionId& id : map.mission_ids()) {
    for (const mapstore::LandmarkId& l : map.landmark_ids(id)) {
      observations += map.landmark(l).observations.size();
      good += map.landmark(l).quality == mapstore::LandmarkQuality::kGood;
    }
  }
  CHECK(ReadLines(dir + "/csv/vertices.csv").size() == map.num_vertices() + 1);
  CHECK(ReadLines(dir + "/csv/landmarks.csv").size() == map.num_landmarks() + 1);
  CHECK(ReadLines(dir + "/csv/observations.csv").size() == observations + 1);
  CHECK(ReadLines(dir + "/csv/missions.csv").size() == 3);
  CHECK(ReadLines(dir + "/csv/edges.csv").size() == map.num_edges() + 1);
  CHECK(fs::exists(dir + "/csv/descriptors.csv"));

  REQUIRE(f.Run("export_landmarks_ply " + dir + "/good.ply --good_only --color_by=quality").ok());
  CHECK_THAT(f.out.str(),
             Catch::Contains(std::to_string(good) + " landmarks") && Catch::Contains("frame G"));
  const std::string ply = mapping::testing::ReadText(dir + "/good.ply");
  CHECK(ply.find("element vertex " + std::to_string(good) + "\n") != std::string::npos);
}

TEST_CASE("export_colmap of a daemon map: colmap model_analyzer reports the same counts") {
  Fixture f;
  LoadBoth(&f);
  const std::string dir = test::ConsoleScratch("colmap") + "/model";
  REQUIRE(f.Run("export_colmap --out=" + dir).ok());
  const mapstore::VIMap& map = f.map();
  std::size_t points = 0, observations = 0;
  for (const mapstore::MissionId& id : map.mission_ids()) {
    for (const mapstore::LandmarkId& l : map.landmark_ids(id)) {
      const mapstore::Landmark& landmark = map.landmark(l);
      if (landmark.quality != mapstore::LandmarkQuality::kGood) continue;
      if (landmark.observations.size() < 2) continue;
      ++points;
      observations += landmark.observations.size();
    }
  }
  const std::string report = f.out.str();
  INFO(report);
  CHECK_THAT(report, Catch::Contains(std::to_string(points) + " points") &&
                         Catch::Contains(std::to_string(observations) + " observations") &&
                         Catch::Contains("observations dropped 0"));
  const std::string colmap = mapping::testing::FindColmap();
  if (colmap.empty()) {
    VILMA_SKIP("the model_analyzer check: colmap is not installed (Debian package colmap)");
  }
  const auto counts = mapping::testing::ModelAnalyzer(colmap, dir);
  CHECK(counts.at("Cameras") == 2);  // one camera per mission
  CHECK(counts.at("Images") == map.num_vertices());
  CHECK(counts.at("Registered images") == map.num_vertices());
  CHECK(counts.at("Points") == points);
  CHECK(counts.at("Observations") == observations);
}

TEST_CASE("data exports refuse missing or unwritable --out, unknown formats and missions") {
  Fixture f;
  const std::string dir = test::ConsoleScratch("export_bad");
  CommandResult r = f.Run("ettc --out=" + dir + "/t.txt");
  CHECK(r.outcome == CommandOutcome::kFailed);  // no map loaded
  LoadBoth(&f);
  for (const std::string command :
       {"ettc", "encc", "csv_export", "export_landmarks_ply", "export_colmap"}) {
    r = f.Run(command);
    CHECK(r.outcome == CommandOutcome::kFailed);
    CHECK_THAT(r.message, Catch::Contains("out: expected"));
    // A path below a regular file cannot be created.
    std::ofstream(dir + "/file") << "x";
    r = f.Run(command + " --out=" + dir + "/file/sub/x");
    CHECK(r.outcome == CommandOutcome::kFailed);
    CHECK_THAT(r.message, Catch::Contains(dir + "/file/sub"));
  }
  r = f.Run("ettc --out=" + dir + "/t.txt --format=csv");
  CHECK(r.outcome == CommandOutcome::kFailed);
  CHECK_THAT(r.message, Catch::Contains("format: expected tum, asl (euroc), rpg or kitti"));
  r = f.Run("ettc --out=" + dir + "/t.txt --frame=W");
  CHECK_THAT(r.message, Catch::Contains("frame: expected G or M"));
  r = f.Run("export_landmarks_ply --out=" + dir + "/l.ply --color_by=height");
  CHECK_THAT(r.message, Catch::Contains("color_by: expected mission or quality"));
  r = f.Run("export_colmap --out=" + dir + "/c --camera_model=fisheye");
  CHECK_THAT(r.message, Catch::Contains("camera_model: expected auto or pinhole"));
  r = f.Run("export_colmap --out=" + dir + "/c --min_track_length=two");
  CHECK_THAT(r.message, Catch::Contains("--min_track_length") && Catch::Contains("integer"));
  r = f.Run("ettc --out=" + dir + "/t.txt --mission=nosuchmission");
  CHECK(r.outcome == CommandOutcome::kFailed);
  CHECK_THAT(r.message, Catch::Contains("nosuchmission"));
  // Nothing was written by the failed commands.
  std::size_t entries = 0;
  for (const auto& entry : fs::directory_iterator(dir))
    entries += entry.path().filename() != "file";
  CHECK(entries == 0);
}

}  // namespace
}  // namespace vilma::console
