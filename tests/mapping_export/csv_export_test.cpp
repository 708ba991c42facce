// csv_export: row counts equal the map's, every row has its header's columns, values read back
// exactly, a landmark's observation rows are its observations, mission selection keeps every
// reference inside the export.
#include "vilma/mapping/export/csv_export.h"

#include <catch2/catch.hpp>
#include <filesystem>
#include <map>
#include <set>

#include "mapping_export/data_export_test_util.h"
#include "mapstore/synthetic_map.h"
#include "vilma/core/error.h"

namespace vilma::mapping {
namespace {

using mapstore::LandmarkId;
using mapstore::MissionId;
using mapstore::VertexId;
using mapstore::VIMap;
using testing::ReadLines;
using testing::ScratchFolder;

// RFC 4180 fields of one line (quotes group, "" is a quote).
std::vector<std::string> CsvFields(const std::string& line) {
  std::vector<std::string> fields(1);
  bool quoted = false;
  for (std::size_t i = 0; i < line.size(); ++i) {
    const char c = line[i];
    if (quoted) {
      if (c == '"' && i + 1 < line.size() && line[i + 1] == '"') {
        fields.back() += '"';
        ++i;
      } else if (c == '"') {
        quoted = false;
      } else {
        fields.back() += c;
      }
    } else if (c == '"') {
      quoted = true;
    } else if (c == ',') {
      fields.emplace_back();
    } else {
      fields.back() += c;
    }
  }
  return fields;
}

// A CSV file as rows of named fields; checks that every row has the header's column count.
struct Table {
  std::vector<std::string> columns;
  std::vector<std::map<std::string, std::string>> rows;
};
Table ReadTable(const std::string& path) {
  const std::vector<std::string> lines = ReadLines(path);
  REQUIRE(!lines.empty());
  Table table;
  table.columns = CsvFields(lines[0]);
  for (std::size_t i = 1; i < lines.size(); ++i) {
    const std::vector<std::string> fields = CsvFields(lines[i]);
    REQUIRE(fields.size() == table.columns.size());
    std::map<std::string, std::string> row;
    for (std::size_t c = 0; c < fields.size(); ++c) row[table.columns[c]] = fields[c];
    table.rows.push_back(row);
  }
  return table;
}

double Num(const std::map<std::string, std::string>& row, const std::string& column) {
  double value = 0.0;
  REQUIRE(row.count(column) == 1);
  INFO(column << " = '" << row.at(column) << "'");
  REQUIRE(testing::ParseNumber(row.at(column), &value));
  return value;
}

TEST_CASE("csv export: counts, columns and exact values of the whole map", "[csv_export]") {
  VIMap map = mapstore::testing::MakeSyntheticMap({});
  map.mission(map.mission_ids()[0]).name = "lab, \"north\" wing";  // needs quoting
  const std::string dir = ScratchFolder("csv") + "/out";
  CsvExportOptions options;
  options.out = dir;
  options.descriptors = true;
  options.imu = true;
  const CsvExportSummary summary = ExportCsv(map, options);

  std::size_t observations = 0, keypoints = 0, imu_samples = 0;
  for (const MissionId& m : map.mission_ids()) {
    for (const LandmarkId& l : map.landmark_ids(m))
      observations += map.landmark(l).observations.size();
    for (const VertexId& v : map.vertex_ids(m)) {
      for (const auto& f : map.vertex(v).frames) keypoints += f.size();
    }
    for (const auto& e : map.edge_ids(m)) imu_samples += map.edge(e).imu_samples.size();
  }
  const Table missions = ReadTable(dir + "/missions.csv");
  const Table vertices = ReadTable(dir + "/vertices.csv");
  const Table edges = ReadTable(dir + "/edges.csv");
  const Table landmarks = ReadTable(dir + "/landmarks.csv");
  const Table obs = ReadTable(dir + "/observations.csv");
  const Table kps = ReadTable(dir + "/keypoints.csv");
  const Table descriptors = ReadTable(dir + "/descriptors.csv");
  const Table imu = ReadTable(dir + "/imu.csv");
  REQUIRE(missions.rows.size() == 2);
  REQUIRE(vertices.rows.size() == map.num_vertices());
  REQUIRE(edges.rows.size() == map.num_edges());
  REQUIRE(landmarks.rows.size() == map.num_landmarks());
  REQUIRE(obs.rows.size() == observations);
  REQUIRE(kps.rows.size() == keypoints);
  REQUIRE(descriptors.rows.size() == keypoints);
  REQUIRE(imu.rows.size() == imu_samples);
  REQUIRE(summary.rows.at("observations.csv") == observations);
  REQUIRE(summary.rows.at("vertices.csv") == map.num_vertices());
  REQUIRE(missions.rows[0].at("name") == map.mission(map.mission_ids()[0]).name);

  // Vertex poses in G and M, exactly.
  for (const auto& row : vertices.rows) {
    VertexId id;
    REQUIRE(mapstore::Id::FromHex(row.at("vertex_id"), &id));
    const mapstore::Vertex& v = map.vertex(id);
    REQUIRE(row.at("mission_id") == v.mission_id.Hex());
    REQUIRE(row.at("t_ns") == std::to_string(v.t_ns));
    const Transformation T_G_I = map.T_G_I(id);
    REQUIRE(Num(row, "p_G_I_x") == T_G_I.translation().x());
    REQUIRE(Num(row, "q_G_I_w") == T_G_I.rotation().w());
    REQUIRE(Num(row, "p_M_I_z") == v.T_M_I.translation().z());
    REQUIRE(Num(row, "q_M_I_y") == v.T_M_I.rotation().y());
    REQUIRE(Num(row, "v_M_y") == v.v_M.y());
    REQUIRE(Num(row, "b_a_z") == v.accel_bias.z());
  }
  // Landmarks in G, quality, observation counts.
  std::map<std::string, int> qualities;
  for (const auto& row : landmarks.rows) {
    LandmarkId id;
    REQUIRE(mapstore::Id::FromHex(row.at("landmark_id"), &id));
    const Eigen::Vector3d p_G = map.LandmarkPosition_G(id);
    REQUIRE(Num(row, "p_G_x") == p_G.x());
    REQUIRE(Num(row, "p_G_z") == p_G.z());
    REQUIRE(Num(row, "observations") == map.landmark(id).observations.size());
    ++qualities[row.at("quality")];
  }
  REQUIRE(qualities.size() == 3);  // good, bad and unknown all appear
  // Edge types and IMU sample counts.
  std::map<std::string, int> types;
  for (const auto& row : edges.rows) {
    mapstore::EdgeId id;
    REQUIRE(mapstore::Id::FromHex(row.at("edge_id"), &id));
    ++types[row.at("type")];
    REQUIRE(Num(row, "imu_samples") == map.edge(id).imu_samples.size());
    if (row.at("type") == "imu") REQUIRE(row.at("p_A_B_x").empty());
    if (row.at("type") == "loop_closure") {
      REQUIRE(Num(row, "switch_variable") == map.edge(id).switch_variable);
    }
  }
  REQUIRE(types.size() == 4);
  // Descriptors decode to the stored bytes.
  const auto& d0 = descriptors.rows[0];
  VertexId v0;
  REQUIRE(mapstore::Id::FromHex(d0.at("vertex_id"), &v0));
  const auto& frame = map.vertex(v0).frames.at(std::stoi(d0.at("camera")));
  const int k0 = std::stoi(d0.at("keypoint"));
  REQUIRE(d0.at("descriptor_hex").size() == 128);
  for (int b = 0; b < 64; ++b) {
    REQUIRE(std::stoi(d0.at("descriptor_hex").substr(2 * b, 2), nullptr, 16) ==
            frame.descriptor(k0)[b]);
  }
}

TEST_CASE("csv export: a landmark's observation rows are its observations", "[csv_export]") {
  const VIMap map = mapstore::testing::MakeSyntheticMap({});
  // The landmark with the most observers (a cross-mission one).
  LandmarkId best;
  std::size_t most = 0;
  for (const MissionId& m : map.mission_ids()) {
    for (const LandmarkId& l : map.landmark_ids(m)) {
      if (map.landmark(l).observations.size() > most) {
        most = map.landmark(l).observations.size();
        best = l;
      }
    }
  }
  REQUIRE(most >= 4);
  const std::string dir = ScratchFolder("csv_obs");
  CsvExportOptions options;
  options.out = dir;
  ExportCsv(map, options);
  std::set<std::tuple<std::string, int, int>> rows;
  std::set<std::string> missions;
  for (const auto& row : ReadTable(dir + "/observations.csv").rows) {
    if (row.at("landmark_id") != best.Hex()) continue;
    rows.insert({row.at("vertex_id"), std::stoi(row.at("camera")), std::stoi(row.at("keypoint"))});
    missions.insert(row.at("mission_id"));
    VertexId v;
    REQUIRE(mapstore::Id::FromHex(row.at("vertex_id"), &v));
    const Eigen::Vector2d uv = map.vertex(v)
                                   .frames[std::stoi(row.at("camera"))]
                                   .keypoints[std::stoi(row.at("keypoint"))]
                                   .uv;
    REQUIRE(Num(row, "u_px") == uv.x());
    REQUIRE(Num(row, "v_px") == uv.y());
  }
  std::set<std::tuple<std::string, int, int>> expected;
  for (const auto& o : map.landmark(best).observations) {
    expected.insert({o.vertex_id.Hex(), static_cast<int>(o.camera), static_cast<int>(o.keypoint)});
  }
  REQUIRE(rows == expected);
  REQUIRE(missions.size() == 2);  // seen from both missions
  // The keypoint rows of those observations name the landmark.
  std::size_t named = 0;
  for (const auto& row : ReadTable(dir + "/keypoints.csv").rows) {
    if (expected.count(
            {row.at("vertex_id"), std::stoi(row.at("camera")), std::stoi(row.at("keypoint"))})) {
      REQUIRE(row.at("landmark_id") == best.Hex());
      ++named;
    }
  }
  REQUIRE(named == expected.size());
  REQUIRE_FALSE(std::filesystem::exists(dir + "/descriptors.csv"));  // off by default
  REQUIRE_FALSE(std::filesystem::exists(dir + "/imu.csv"));
}

TEST_CASE("csv export: one mission keeps every reference inside the export", "[csv_export]") {
  const VIMap map = mapstore::testing::MakeSyntheticMap({});
  const MissionId second = map.mission_ids()[1];
  const std::string dir = ScratchFolder("csv_mission");
  CsvExportOptions options;
  options.out = dir;
  options.missions = {second};
  const CsvExportSummary summary = ExportCsv(map, options);
  std::set<std::string> vertex_ids, landmark_ids;
  for (const auto& row : ReadTable(dir + "/vertices.csv").rows)
    vertex_ids.insert(row.at("vertex_id"));
  for (const auto& row : ReadTable(dir + "/landmarks.csv").rows) {
    landmark_ids.insert(row.at("landmark_id"));
    REQUIRE(row.at("mission_id") == second.Hex());
  }
  REQUIRE(vertex_ids.size() == map.vertex_ids(second).size());
  REQUIRE(landmark_ids.size() == map.landmark_ids(second).size());
  for (const auto& row : ReadTable(dir + "/observations.csv").rows) {
    REQUIRE(vertex_ids.count(row.at("vertex_id")));
    REQUIRE(landmark_ids.count(row.at("landmark_id")));
  }
  for (const auto& row : ReadTable(dir + "/edges.csv").rows) {
    REQUIRE(vertex_ids.count(row.at("from_vertex_id")));
    REQUIRE(vertex_ids.count(row.at("to_vertex_id")));
    REQUIRE(row.at("type") != "loop_closure");  // it points into mission 0
  }
  for (const auto& row : ReadTable(dir + "/keypoints.csv").rows) {
    if (!row.at("landmark_id").empty()) REQUIRE(landmark_ids.count(row.at("landmark_id")));
  }
  REQUIRE(summary.rows.at("missions.csv") == 1);
}

TEST_CASE("csv export: cancelled writes nothing", "[csv_export]") {
  const VIMap map = mapstore::testing::MakeSyntheticMap({});
  const std::string dir = ScratchFolder("csv_cancel") + "/out";
  CsvExportOptions options;
  options.out = dir;
  testing::CancelAfter cancel(5);
  REQUIRE_THROWS_AS(ExportCsv(map, options, &cancel), Cancelled);
  REQUIRE_FALSE(std::filesystem::exists(dir));
}

TEST_CASE("csv export: bad input", "[csv_export]") {
  const VIMap map = mapstore::testing::MakeSyntheticMap({});
  CsvExportOptions options;
  REQUIRE_THROWS_WITH(ExportCsv(map, options), Catch::Contains("out: expected"));
  const std::string dir = ScratchFolder("csv_bad");
  std::ofstream(dir + "/file") << "x";
  options.out = dir + "/file/csv";
  REQUIRE_THROWS_WITH(ExportCsv(map, options), Catch::Contains("expected a folder"));
  options.out = dir + "/ok";
  options.missions = {mapstore::Id{7, 7}};
  REQUIRE_THROWS_WITH(ExportCsv(map, options), Catch::Contains("not in the map"));
  REQUIRE_FALSE(std::filesystem::exists(dir + "/ok"));
}

}  // namespace
}  // namespace vilma::mapping
