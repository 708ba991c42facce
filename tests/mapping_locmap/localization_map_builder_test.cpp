#include "vilma/mapping/locmap/localization_map_builder.h"

#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>

#include "vilma/core/error.h"
#include "mapping_locmap/test_missions.h"

using namespace vilma;
using namespace vilma::localizer;
using namespace vilma::mapping;
using vilma::mapping::test::AddTestMission;
namespace fs = std::filesystem;

namespace {

// One mission, anchored at T_G_M = translation (10, 0, 0).
mapstore::VIMap MakeMap(int vertices) {
  mapstore::VIMap map;
  mapstore::IdGenerator ids(1);
  AddTestMission(&map, &ids, vertices, true, Eigen::Vector3d(10, 0, 0));
  return map;
}

std::string ReadAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

}  // namespace

TEST_CASE("localization map: good landmarks in G with a spread descriptor subset",
          "[localization]") {
  const mapstore::VIMap vimap = MakeMap(12);
  LocalizationMapOptions o;
  o.max_descriptors_per_landmark = 4;
  const LocalizationMap map = BuildLocalizationMap(vimap, o);
  REQUIRE(map.Validate().empty());
  REQUIRE(map.num_landmarks() == 6);  // landmarks 0, 2, 4, 6, 8, 10 are good
  CHECK(map.p_G[1].isApprox(Eigen::Vector3d(12, 0, 1)));  // landmark 2: p_I + (10, 0, 0)
  CHECK(map.observers.size() == 12);
  CHECK(map.num_descriptors() == 6 * 4);
  // Observations 0, 4, 7, 11 of 12 (evenly spread, first and last included).
  for (int j = 0; j < 4; ++j) CHECK(map.descriptor_landmark[4 + j] == 1u);
  const int expected_vertex[] = {0, 4, 7, 11};
  for (int j = 0; j < 4; ++j) CHECK(map.descriptor(4 + j)[0] == 16 * expected_vertex[j] + 2);
  for (uint32_t l = 0; l < 6; ++l) CHECK(map.observer_begin[l + 1] - map.observer_begin[l] == 12);
  o.min_observations = 13;
  CHECK(BuildLocalizationMap(vimap, o).num_landmarks() == 0);
}

TEST_CASE("localization map: save / load round trip and errors naming file and field",
          "[localization]") {
  LocalizationMap map = BuildLocalizationMap(MakeMap(8));
  map.projection = Eigen::MatrixXf::Random(4, 512);
  const std::string path = (fs::temp_directory_path() / "vilma_locmap_test.vlocmap").string();
  SaveLocalizationMap(map, path);
  const LocalizationMap back = LoadLocalizationMap(path);
  CHECK(back.landmark_ids == map.landmark_ids);
  CHECK(back.p_G == map.p_G);
  CHECK(back.observer_begin == map.observer_begin);
  CHECK(back.observer_index == map.observer_index);
  CHECK(back.observers == map.observers);
  CHECK(back.descriptor_landmark == map.descriptor_landmark);
  CHECK(back.descriptors == map.descriptors);
  CHECK(back.projection == map.projection);
  const std::string bytes = ReadAll(path);
  // Corrupt byte -> checksum; truncated -> checksum; wrong magic; wrong version.
  auto write = [&](const std::string& b) { std::ofstream(path, std::ios::binary) << b; };
  std::string corrupt = bytes;
  corrupt[100] ^= 0x5a;
  write(corrupt);
  CHECK_THROWS_WITH(LoadLocalizationMap(path), Catch::Contains(path) && Catch::Contains("crc32"));
  write(bytes.substr(0, bytes.size() / 2));
  CHECK_THROWS_AS(LoadLocalizationMap(path), InputError);
  write("not a map at all");
  CHECK_THROWS_WITH(LoadLocalizationMap(path), Catch::Contains("magic"));
  std::string version = bytes;
  version[8] = 9;
  write(version);
  CHECK_THROWS_WITH(LoadLocalizationMap(path), Catch::Contains("version"));
  fs::remove(path);
  CHECK_THROWS_WITH(LoadLocalizationMap(path), Catch::Contains(path));
  // A projection the index cannot use (odd rows; non-finite values) is refused at load, naming
  // the file and the field, not later by the index.
  LocalizationMap odd = map;
  odd.projection = Eigen::MatrixXf::Random(3, 512);
  SaveLocalizationMap(odd, path);
  CHECK_THROWS_WITH(LoadLocalizationMap(path), Catch::Contains(path) && Catch::Contains("projection"));
  LocalizationMap nan = map;
  nan.projection(1, 7) = std::numeric_limits<float>::quiet_NaN();
  SaveLocalizationMap(nan, path);
  CHECK_THROWS_WITH(LoadLocalizationMap(path), Catch::Contains("projection") && Catch::Contains("finite"));
  fs::remove(path);
  // An inconsistent map is not written.
  map.descriptor_landmark.push_back(99);
  CHECK_THROWS_AS(SaveLocalizationMap(map, path), InputError);
  CHECK_FALSE(fs::exists(path));
}

TEST_CASE("localization map: only missions in one common frame G", "[localization]") {
  // Two unanchored missions (the daemon's second mission after a filter reset): their frames
  // are unrelated, so only the first one (M = G) is summarized.
  mapstore::VIMap map;
  mapstore::IdGenerator ids(3);
  AddTestMission(&map, &ids, 8, false, Eigen::Vector3d::Zero());
  AddTestMission(&map, &ids, 8, false, Eigen::Vector3d::Zero());
  LocalizationMapReport report;
  LocalizationMap loc = BuildLocalizationMap(map, {}, &report);
  CHECK(report.missions_used == 1);
  CHECK(report.missions_skipped == 1);
  CHECK(loc.num_landmarks() == 4);  // 4 good landmarks of 8, of the first mission
  REQUIRE(MissionsInCommonFrame(map).size() == 1);
  CHECK(MissionsInCommonFrame(map).front() == map.mission_ids().front());
  for (const MapObjectId& id : loc.landmark_ids) {
    CHECK(map.vertex(map.landmark(ToVIMapId(id)).store_vertex_id).mission_id == map.mission_ids().front());
  }

  // Anchored missions share G: both anchored ones, the unanchored one skipped.
  AddTestMission(&map, &ids, 8, true, Eigen::Vector3d(0, 0, 5));
  map.mission(map.mission_ids()[1]).baseframe_known = true;
  map.mission(map.mission_ids()[1]).T_G_M =
      Transformation(Eigen::Quaterniond::Identity(), Eigen::Vector3d(-5, 0, 0));
  loc = BuildLocalizationMap(map, {}, &report);
  CHECK(report.missions_used == 2);
  CHECK(report.missions_skipped == 1);
  CHECK(loc.num_landmarks() == 8);
  // Positioned with their own T_G_M: landmark 2 of mission 1 at (2, 0, 1) + (-5, 0, 0), of
  // mission 2 at (2, 0, 1) + (0, 0, 5).
  CHECK(loc.p_G[1].isApprox(Eigen::Vector3d(-3, 0, 1)));
  CHECK(loc.p_G[5].isApprox(Eigen::Vector3d(2, 0, 6)));
}

TEST_CASE("localization map: landmark covariances rotated into G, none when all are unknown",
          "[localization]") {
  mapstore::VIMap vimap = MakeMap(4);
  // Without covariances (all zero): none stored, the localizer takes the landmarks as exact.
  CHECK(BuildLocalizationMap(vimap).p_G_covariance.empty());
  // A mission rotated 90 deg about z and a store vertex rotated 90 deg about x: a landmark
  // uncertain along its store vertex's x (sigma 2 m) and y (sigma 0.1 m).
  const mapstore::MissionId mission = vimap.mission_ids().front();
  vimap.mission(mission).T_G_M = Transformation(
      Eigen::Quaterniond(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitZ())),
      Eigen::Vector3d(10, 0, 0));
  const mapstore::LandmarkId first = vimap.landmark_ids(mission).front();
  mapstore::Landmark& l = vimap.landmark(first);
  vimap.vertex(l.store_vertex_id).T_M_I =
      Transformation(Eigen::Quaterniond(Eigen::AngleAxisd(M_PI / 2, Eigen::Vector3d::UnitX())),
                     Eigen::Vector3d::Zero());
  l.covariance = Eigen::Vector3d(4.0, 0.01, 0.0).asDiagonal();
  const LocalizationMap map = BuildLocalizationMap(vimap);
  REQUIRE(map.Validate().empty());
  REQUIRE(map.p_G_covariance.size() == map.num_landmarks());
  // R_G_I = Rz(90) Rx(90): I's x is G's y, I's y is G's z.
  const Eigen::Matrix3d expected = Eigen::Vector3d(0.0, 4.0, 0.01).asDiagonal();
  CHECK((map.p_G_covariance[0].cast<double>() - expected).norm() <= 1e-6);
  // The other landmarks (zero covariance) are stored as zero: exact.
  for (std::size_t i = 1; i < map.num_landmarks(); ++i) CHECK(map.p_G_covariance[i].isZero());
}
