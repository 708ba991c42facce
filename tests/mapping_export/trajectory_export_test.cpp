// export_trajectory_to_csv: files read back by vilma's trajectory loader (the one `vilma eval`
// uses) give the map's poses; evo's reader rules hold; naming, frames and bad input.
#include "vilma/mapping/export/trajectory_export.h"

#include <catch2/catch.hpp>
#include <filesystem>

#include "mapping_export/data_export_test_util.h"
#include "mapstore/synthetic_map.h"
#include "vilma/core/error.h"
#include "vilma/eval/trajectory.h"
#include "vilma/eval/evaluate.h"

namespace vilma::mapping {
namespace {

namespace fs = std::filesystem;
using mapstore::MissionId;
using mapstore::VertexId;
using mapstore::VIMap;
using testing::ParseNumber;
using testing::ReadLines;
using testing::ScratchFolder;
using testing::Split;

VIMap TwoMissionMap() {
  mapstore::testing::SyntheticMapOptions o;
  o.vertices_per_mission = 15;
  return mapstore::testing::MakeSyntheticMap(o);
}

// The map's vertices of a mission in time order with T_W_I in the asked frame.
std::vector<std::pair<int64_t, Transformation>> Expected(const VIMap& map, const MissionId& id,
                                                         bool global) {
  std::vector<std::pair<int64_t, Transformation>> poses;
  for (const VertexId& v : map.vertex_ids(id)) {
    poses.push_back({map.vertex(v).t_ns, global ? map.T_G_I(v) : map.vertex(v).T_M_I});
  }
  std::sort(poses.begin(), poses.end(),
            [](const auto& a, const auto& b) { return a.first < b.first; });
  return poses;
}

void RequireSamePoses(const Trajectory& read,
                      const std::vector<std::pair<int64_t, Transformation>>& expected,
                      bool with_time) {
  REQUIRE(read.size() == expected.size());
  for (std::size_t i = 0; i < read.size(); ++i) {
    if (with_time) REQUIRE(read.t_ns[i] == expected[i].first);
    REQUIRE((read.T_W_B[i].translation() - expected[i].second.translation()).norm() < 2e-9);
    REQUIRE(AngleBetween(read.T_W_B[i].rotation(), expected[i].second.rotation()) < 3e-8);
  }
}

// evo's readers (file_interface.py): '#' lines skipped; TUM: exactly 8 fields split at single
// spaces; EuRoC: at least 8 (old evo: exactly 17) fields split at commas; every field a float.
void RequireEvoReadable(const std::string& path, char delimiter, std::size_t fields) {
  std::size_t rows = 0;
  for (const std::string& line : ReadLines(path)) {
    if (line.empty() || line[0] == '#') continue;
    const std::vector<std::string> parts = Split(line, delimiter);
    REQUIRE(parts.size() == fields);
    for (const std::string& p : parts) {
      double value;
      REQUIRE(ParseNumber(p, &value));
    }
    ++rows;
  }
  REQUIRE(rows > 0);
}

TEST_CASE("trajectory export: TUM in G, one file per mission, read back equal",
          "[trajectory_export]") {
  const VIMap map = TwoMissionMap();
  const std::string dir = ScratchFolder("traj_tum");
  TrajectoryExportOptions options;
  options.out = dir;
  const TrajectoryExportSummary summary = ExportTrajectories(map, options);
  REQUIRE(summary.files.size() == 2);
  REQUIRE(summary.poses == 30);
  REQUIRE(summary.frame == "G");
  for (std::size_t m = 0; m < 2; ++m) {
    const MissionId& id = map.mission_ids()[m];
    const std::string path = dir + "/trajectory_" + id.Hex() + ".txt";
    REQUIRE(summary.files[m].path == path);
    const Trajectory read = ReadTrajectoryFile(path);
    REQUIRE(read.format == TrajectoryFormat::kTum);
    RequireSamePoses(read, Expected(map, id, true), true);
    RequireEvoReadable(path, ' ', 8);
    // The header names the frame.
    REQUIRE(ReadLines(path)[0].find("T_G_I") != std::string::npos);
    // vilma eval of the export against itself: ATE 0.
    const EvalResult eval = EvaluateTrajectory(read, read, EvalOptions{});
    REQUIRE(eval.association.size() == 15);
    REQUIRE(eval.ate.translation_m.max < 1e-9);
    REQUIRE(eval.ate.rotation_deg.max < 1e-6);
  }
  // Mission 1's baseframe is unknown: the report says its G is its stored T_G_M.
  REQUIRE(summary.FullReport().find("baseframe unknown") != std::string::npos);
}

TEST_CASE("trajectory export: ASL (EuRoC 17 columns) in M with velocity and biases",
          "[trajectory_export]") {
  const VIMap map = TwoMissionMap();
  const MissionId id = map.mission_ids()[1];
  const std::string path = ScratchFolder("traj_asl") + "/poses.csv";
  TrajectoryExportOptions options;
  options.out = path;
  options.format = "asl";
  options.frame = "M";
  options.missions = {id};
  const TrajectoryExportSummary summary = ExportTrajectories(map, options);
  REQUIRE(summary.files.size() == 1);
  REQUIRE(summary.files[0].path == path);  // one mission: exactly --out
  const Trajectory read = ReadTrajectoryFile(path);
  REQUIRE(read.format == TrajectoryFormat::kEuroc);
  RequireSamePoses(read, Expected(map, id, false), true);
  RequireEvoReadable(path, ',', 17);
  const std::vector<std::string> lines = ReadLines(path);
  REQUIRE(lines[0].rfind("#timestamp [ns],p_M_I_x [m]", 0) == 0);
  // Velocity and biases of the first vertex in time order.
  std::vector<VertexId> ids = map.vertex_ids(id);
  std::sort(ids.begin(), ids.end(), [&](const VertexId& a, const VertexId& b) {
    return map.vertex(a).t_ns < map.vertex(b).t_ns;
  });
  const mapstore::Vertex& v = map.vertex(ids[0]);
  const std::vector<std::string> fields = Split(lines[1], ',');
  REQUIRE(fields.size() == 17);
  REQUIRE(fields[0] == std::to_string(v.t_ns));
  for (int k = 0; k < 3; ++k) {
    double value;
    REQUIRE(ParseNumber(fields[8 + k], &value));
    CHECK(value == Approx(v.v_M[k]).margin(1e-9));
    REQUIRE(ParseNumber(fields[11 + k], &value));
    CHECK(value == Approx(v.gyro_bias[k]).margin(1e-9));
    REQUIRE(ParseNumber(fields[14 + k], &value));
    CHECK(value == Approx(v.accel_bias[k]).margin(1e-9));
  }
}

TEST_CASE("trajectory export: G = T_G_M * M, velocities rotated", "[trajectory_export]") {
  const VIMap map = TwoMissionMap();
  const MissionId id = map.mission_ids()[0];
  const std::vector<ExportedState> g = MissionStates(map, id, ExportFrame::kGlobal);
  const std::vector<ExportedState> m = MissionStates(map, id, ExportFrame::kMission);
  REQUIRE(g.size() == m.size());
  const Transformation& T_G_M = map.mission(id).T_G_M;
  for (std::size_t i = 0; i < g.size(); ++i) {
    const Transformation expected = T_G_M * m[i].T_W_I;
    REQUIRE((g[i].T_W_I.translation() - expected.translation()).norm() < 1e-12);
    REQUIRE(AngleBetween(g[i].T_W_I.rotation(), expected.rotation()) < 1e-9);
    REQUIRE((g[i].v_W - T_G_M.rotationMatrix() * m[i].v_W).norm() < 1e-12);
    REQUIRE(g[i].gyro_bias == m[i].gyro_bias);
    if (i > 0) REQUIRE(g[i].t_ns > g[i - 1].t_ns);
  }
}

TEST_CASE("trajectory export: rpg and kitti read back, several missions into a file name",
          "[trajectory_export]") {
  const VIMap map = TwoMissionMap();
  const std::string dir = ScratchFolder("traj_rpg");
  TrajectoryExportOptions options;
  options.out = dir + "/sub/est.txt";  // the folder is created
  options.format = "rpg";
  const TrajectoryExportSummary rpg = ExportTrajectories(map, options);
  REQUIRE(rpg.files.size() == 2);
  for (std::size_t m = 0; m < 2; ++m) {
    const MissionId& id = map.mission_ids()[m];
    REQUIRE(rpg.files[m].path == dir + "/sub/est_" + id.Hex() + ".txt");
    RequireSamePoses(ReadTrajectoryFile(rpg.files[m].path), Expected(map, id, true), true);
    RequireEvoReadable(rpg.files[m].path, ' ', 8);
    REQUIRE(ReadLines(rpg.files[m].path)[1].rfind("# timestamp [s] p_G_Ix", 0) == 0);
  }
  options.out = dir + "/kitti";
  options.format = "kitti";
  options.frame = "mission";
  const TrajectoryExportSummary kitti = ExportTrajectories(map, options);
  REQUIRE(kitti.files.size() == 2);
  const MissionId& id = map.mission_ids()[1];
  REQUIRE(kitti.files[1].path == dir + "/kitti_" + id.Hex() + ".txt");
  const Trajectory read = ReadTrajectoryFile(kitti.files[1].path);
  REQUIRE(read.format == TrajectoryFormat::kKitti);
  RequireSamePoses(read, Expected(map, id, false), false);
}

TEST_CASE("trajectory export: bad input names the problem and writes nothing",
          "[trajectory_export]") {
  VIMap map = TwoMissionMap();
  const std::string dir = ScratchFolder("traj_bad");
  TrajectoryExportOptions options;
  options.out = dir;
  options.format = "csv";
  REQUIRE_THROWS_WITH(ExportTrajectories(map, options),
                      Catch::Contains("format: expected tum, asl (euroc), rpg or kitti"));
  options.format = "tum";
  options.frame = "W";
  REQUIRE_THROWS_WITH(ExportTrajectories(map, options), Catch::Contains("frame: expected G or M"));
  options.frame = "G";
  options.out = "";
  REQUIRE_THROWS_WITH(ExportTrajectories(map, options), Catch::Contains("out: expected"));
  // A path below a regular file cannot be created.
  std::ofstream(dir + "/file") << "x";
  options.out = dir + "/file/traj.txt";
  REQUIRE_THROWS_AS(ExportTrajectories(map, options), InputError);
  options.missions = {mapstore::Id{1, 2}};
  options.out = dir;
  REQUIRE_THROWS_WITH(ExportTrajectories(map, options), Catch::Contains("not in the map"));
  // Two vertices at one time in the second mission: refused before anything is written.
  options.missions.clear();
  const MissionId second = map.mission_ids()[1];
  map.vertex(map.vertex_ids(second)[3]).t_ns = map.vertex(map.vertex_ids(second)[2]).t_ns;
  REQUIRE_THROWS_WITH(ExportTrajectories(map, options),
                      Catch::Contains("expected strictly increasing vertex times"));
  std::size_t files = 0;
  for (const auto& entry : fs::directory_iterator(dir)) files += entry.path().filename() != "file";
  REQUIRE(files == 0);
}

TEST_CASE("trajectory export: cancelled after the first mission writes nothing",
          "[trajectory_export]") {
  const VIMap map = TwoMissionMap();
  const std::string dir = ScratchFolder("traj_cancel");
  TrajectoryExportOptions options;
  options.out = dir;
  testing::CancelAfter cancel(1);
  REQUIRE_THROWS_AS(ExportTrajectories(map, options, &cancel), Cancelled);
  REQUIRE(cancel.advances() == 1);
  REQUIRE(fs::is_empty(dir));
}

TEST_CASE("trajectory export: options validation", "[trajectory_export]") {
  TrajectoryExportOptions options;
  REQUIRE(options.Validate().rfind("out:", 0) == 0);
  options.out = "x.txt";
  REQUIRE(options.Validate().empty());
  for (const char* format : {"tum", "TUM", "asl", "euroc", "rpg", "kitti"}) {
    options.format = format;
    REQUIRE(options.Validate().empty());
  }
}

}  // namespace
}  // namespace vilma::mapping
