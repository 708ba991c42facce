// export_landmarks_ply: the file parses back (binary and ASCII) to the map's landmarks in G with
// the asked colours, the good-only filter and the header's frame statement.
#include "vilma/mapping/export/ply_export.h"

#include <catch2/catch.hpp>
#include <cstring>
#include <filesystem>
#include <sstream>

#include "mapping_export/data_export_test_util.h"
#include "mapstore/synthetic_map.h"
#include "vilma/core/error.h"
#include "vilma/mapping/export/map_plot.h"

namespace vilma::mapping {
namespace {

using mapstore::LandmarkId;
using mapstore::MissionId;
using mapstore::VIMap;
using testing::ScratchFolder;

struct PlyPoint {
  Eigen::Vector3d p;
  int r, g, b, quality, mission;
  unsigned observations;
};
struct PlyFile {
  bool binary = false;
  std::vector<std::string> comments;
  std::vector<std::string> properties;  // "type name"
  std::vector<PlyPoint> points;
};

// A reader for the PLY this export writes, written from the format's definition (Turk 1994):
// header lines up to end_header, then the vertex records.
PlyFile ParsePly(const std::string& bytes) {
  PlyFile ply;
  std::size_t pos = 0;
  auto line = [&]() {
    const std::size_t end = bytes.find('\n', pos);
    REQUIRE(end != std::string::npos);
    std::string l = bytes.substr(pos, end - pos);
    pos = end + 1;
    return l;
  };
  REQUIRE(line() == "ply");
  const std::string format = line();
  REQUIRE((format == "format binary_little_endian 1.0" || format == "format ascii 1.0"));
  ply.binary = format.find("binary") != std::string::npos;
  std::size_t count = 0;
  for (std::string l = line(); l != "end_header"; l = line()) {
    if (l.rfind("comment ", 0) == 0) ply.comments.push_back(l.substr(8));
    if (l.rfind("element vertex ", 0) == 0) count = std::stoul(l.substr(15));
    if (l.rfind("property ", 0) == 0) ply.properties.push_back(l.substr(9));
  }
  const std::vector<std::string> expected = {
      "double x",   "double y",      "double z",       "uchar red",        "uchar green",
      "uchar blue", "uchar quality", "ushort mission", "uint observations"};
  REQUIRE(ply.properties == expected);
  if (ply.binary) {
    const std::size_t record = 3 * 8 + 3 + 1 + 2 + 4;
    REQUIRE(bytes.size() - pos == count * record);
    auto u = [&](std::size_t at, int n) {
      uint64_t v = 0;
      for (int i = 0; i < n; ++i) v |= uint64_t(static_cast<uint8_t>(bytes[at + i])) << (8 * i);
      return v;
    };
    for (std::size_t i = 0; i < count; ++i, pos += record) {
      PlyPoint p;
      for (int k = 0; k < 3; ++k) {
        const uint64_t bits = u(pos + 8 * k, 8);
        std::memcpy(&p.p[k], &bits, 8);
      }
      p.r = static_cast<int>(u(pos + 24, 1));
      p.g = static_cast<int>(u(pos + 25, 1));
      p.b = static_cast<int>(u(pos + 26, 1));
      p.quality = static_cast<int>(u(pos + 27, 1));
      p.mission = static_cast<int>(u(pos + 28, 2));
      p.observations = static_cast<unsigned>(u(pos + 30, 4));
      ply.points.push_back(p);
    }
  } else {
    std::istringstream body(bytes.substr(pos));
    for (std::size_t i = 0; i < count; ++i) {
      PlyPoint p;
      REQUIRE(static_cast<bool>(body >> p.p.x() >> p.p.y() >> p.p.z() >> p.r >> p.g >> p.b >>
                                p.quality >> p.mission >> p.observations));
      ply.points.push_back(p);
    }
    std::string rest;
    REQUIRE_FALSE(static_cast<bool>(body >> rest));
  }
  return ply;
}

// Landmarks of the map in mission order, as the export lists them.
std::vector<LandmarkId> MapLandmarks(const VIMap& map, bool good_only) {
  std::vector<LandmarkId> ids;
  for (const MissionId& m : map.mission_ids()) {
    for (const LandmarkId& l : map.landmark_ids(m)) {
      if (!good_only || map.landmark(l).quality == mapstore::LandmarkQuality::kGood) {
        ids.push_back(l);
      }
    }
  }
  return ids;
}

TEST_CASE("landmarks ply: binary, coloured by mission, parses back to p_G", "[ply_export]") {
  const VIMap map = mapstore::testing::MakeSyntheticMap({});
  const std::string dir = ScratchFolder("ply");
  PlyExportOptions options;
  options.out = dir;  // a folder: landmarks.ply in it
  const PlyExportSummary summary = ExportLandmarksPly(map, options);
  REQUIRE(summary.path == dir + "/landmarks.ply");
  const PlyFile ply = ParsePly(testing::ReadText(summary.path));
  REQUIRE(ply.binary);
  const std::vector<LandmarkId> ids = MapLandmarks(map, false);
  REQUIRE(ply.points.size() == ids.size());
  REQUIRE(summary.points == ids.size());
  for (std::size_t i = 0; i < ids.size(); ++i) {
    const mapstore::Landmark& l = map.landmark(ids[i]);
    const PlyPoint& p = ply.points[i];
    REQUIRE(p.p == map.LandmarkPosition_G(ids[i]));  // bit-exact doubles
    const int mission = map.vertex(l.store_vertex_id).mission_id == map.mission_ids()[0] ? 0 : 1;
    REQUIRE(p.mission == mission);
    const auto rgb = MissionColorRgb(mission);
    REQUIRE((p.r == rgb[0] && p.g == rgb[1] && p.b == rgb[2]));
    REQUIRE(p.quality == static_cast<int>(l.quality));
    REQUIRE(p.observations == l.observations.size());
  }
  REQUIRE(ply.comments[0].find("global frame G") != std::string::npos);
  REQUIRE(ply.comments[2].find(map.mission_ids()[0].Hex()) != std::string::npos);
  REQUIRE(ply.comments[3].find("baseframe unknown") != std::string::npos);
}

TEST_CASE("landmarks ply: ASCII, good only, coloured by quality", "[ply_export]") {
  const VIMap map = mapstore::testing::MakeSyntheticMap({});
  const std::string path = ScratchFolder("ply_ascii") + "/good.ply";
  PlyExportOptions options;
  options.out = path;
  options.binary = false;
  options.good_only = true;
  options.color_by = "quality";
  const PlyExportSummary summary = ExportLandmarksPly(map, options);
  REQUIRE(summary.path == path);
  const PlyFile ply = ParsePly(testing::ReadText(path));
  REQUIRE_FALSE(ply.binary);
  const std::vector<LandmarkId> good = MapLandmarks(map, true);
  REQUIRE(!good.empty());
  REQUIRE(ply.points.size() == good.size());
  REQUIRE(summary.skipped_not_good == map.num_landmarks() - good.size());
  const auto green = LandmarkQualityColorRgb(mapstore::LandmarkQuality::kGood);
  for (std::size_t i = 0; i < good.size(); ++i) {
    REQUIRE(ply.points[i].p == map.LandmarkPosition_G(good[i]));  // %.17g reads back exactly
    REQUIRE(ply.points[i].quality == 2);
    REQUIRE((ply.points[i].r == green[0] && ply.points[i].g == green[1] &&
             ply.points[i].b == green[2]));
  }
}

TEST_CASE("landmarks ply: one mission, bad input and cancel", "[ply_export]") {
  const VIMap map = mapstore::testing::MakeSyntheticMap({});
  const std::string dir = ScratchFolder("ply_bad");
  PlyExportOptions options;
  options.out = dir + "/m1.ply";
  options.missions = {map.mission_ids()[1]};
  const PlyExportSummary one = ExportLandmarksPly(map, options);
  REQUIRE(one.points == map.landmark_ids(map.mission_ids()[1]).size());
  REQUIRE(one.missions == 1);
  options.color_by = "height";
  REQUIRE_THROWS_WITH(ExportLandmarksPly(map, options),
                      Catch::Contains("color_by: expected mission or quality"));
  options.color_by = "mission";
  options.out.clear();
  REQUIRE_THROWS_WITH(ExportLandmarksPly(map, options), Catch::Contains("out: expected"));
  std::ofstream(dir + "/file") << "x";
  options.out = dir + "/file/x.ply";
  REQUIRE_THROWS_AS(ExportLandmarksPly(map, options), InputError);
  // Cancelled: nothing written.
  options.out = dir + "/cancelled.ply";
  testing::CancelAfter cancel(1);
  REQUIRE_THROWS_AS(ExportLandmarksPly(map, options, &cancel), Cancelled);
  REQUIRE_FALSE(std::filesystem::exists(options.out));
}

}  // namespace
}  // namespace vilma::mapping
