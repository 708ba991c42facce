// The .vlocmap file of the localizer (version 2: landmark covariances), on hand-made maps; maps
// built from VI-maps are tested in tests/mapping_locmap.
#include "vilma/localizer/localization_map.h"

#include <catch2/catch.hpp>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <unistd.h>
#include <zlib.h>

#include "vilma/core/error.h"

using namespace vilma;
using namespace vilma::localizer;
namespace fs = std::filesystem;

namespace {

// Three landmarks with two observers and two descriptors each.
LocalizationMap MakeMap() {
  LocalizationMap m;
  m.descriptor_bytes = 64;
  for (uint32_t l = 0; l < 3; ++l) {
    m.landmark_ids.push_back({0x1000u + l, 0xabcdef00u + l});
    m.p_G.emplace_back(l, 2.0 * l, 5.0 + l);
    m.observer_begin.push_back(2 * l);
    m.observer_index.push_back(l);
    m.observer_index.push_back(l + 1);
    for (int d = 0; d < 2; ++d) {
      m.descriptor_landmark.push_back(l);
      m.descriptors.insert(m.descriptors.end(), 64, static_cast<uint8_t>(10 * l + d));
    }
  }
  m.observer_begin.push_back(6);
  for (uint32_t o = 0; o < 4; ++o) m.observers.push_back({7u, 100u + o});
  return m;
}

std::string ReadAll(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

void WriteAll(const std::string& path, const std::string& bytes) {
  std::ofstream(path, std::ios::binary) << bytes;
}

std::string TempPath(const std::string& name) {
  return (fs::temp_directory_path() / ("vilma_locmap_" + std::to_string(::getpid()) + name))
      .string();
}

}  // namespace

TEST_CASE("localization map file: landmark covariances round trip, absent ones stay absent",
          "[localization]") {
  LocalizationMap map = MakeMap();
  const std::string path = TempPath("a.vlocmap");
  SaveLocalizationMap(map, path);
  LocalizationMap loaded = LoadLocalizationMap(path);
  CHECK(loaded.p_G_covariance.empty());
  REQUIRE(loaded.landmark_ids.size() == 3);
  CHECK(loaded.landmark_ids[2] == MapObjectId{0x1002u, 0xabcdef02u});
  CHECK(loaded.observers[3] == MapObjectId{7u, 103u});

  for (int l = 0; l < 3; ++l) {
    Eigen::Matrix3f c = Eigen::Matrix3f::Identity() * (0.01f * (l + 1));
    c(0, 2) = c(2, 0) = 0.001f * l;
    map.p_G_covariance.push_back(c);
  }
  SaveLocalizationMap(map, path);
  loaded = LoadLocalizationMap(path);
  REQUIRE(loaded.p_G_covariance.size() == 3);
  for (int l = 0; l < 3; ++l) CHECK(loaded.p_G_covariance[l] == map.p_G_covariance[l]);
  CHECK(loaded.p_G == map.p_G);
  fs::remove(path);
}

TEST_CASE("localization map file: version 1 files (no covariances) still load", "[localization]") {
  // A version-1 file is a version-2 file without the covariance array (its 8-byte count after
  // p_G), version field 1, and its own CRC.
  const LocalizationMap map = MakeMap();
  const std::string path = TempPath("v1.vlocmap");
  SaveLocalizationMap(map, path);
  std::string bytes = ReadAll(path);
  const uint32_t v1 = 1;
  std::memcpy(&bytes[8], &v1, 4);
  // magic 8, version 4, descriptor_bytes 4, four counts 32, landmark_ids (8 + 3 x 16),
  // p_G (8 + 3 x 24): the covariance count follows.
  const std::size_t covariance_count_at = 8 + 4 + 4 + 32 + (8 + 48) + (8 + 72);
  uint64_t count = 99;
  std::memcpy(&count, &bytes[covariance_count_at], 8);
  REQUIRE(count == 0);
  bytes.erase(covariance_count_at, 8);
  bytes.resize(bytes.size() - 4);
  const uint32_t crc = static_cast<uint32_t>(
      crc32(0L, reinterpret_cast<const Bytef*>(bytes.data()), static_cast<uInt>(bytes.size())));
  bytes.append(reinterpret_cast<const char*>(&crc), 4);
  WriteAll(path, bytes);
  const LocalizationMap loaded = LoadLocalizationMap(path);
  CHECK(loaded.p_G_covariance.empty());
  CHECK(loaded.p_G == map.p_G);
  CHECK(loaded.descriptors == map.descriptors);
  // Version 3 is not known.
  const uint32_t v3 = 3;
  std::memcpy(&bytes[8], &v3, 4);
  WriteAll(path, bytes);
  CHECK_THROWS_WITH(LoadLocalizationMap(path), Catch::Contains(path) && Catch::Contains("version") &&
                                                   Catch::Contains("expected 1 or 2"));
  fs::remove(path);
}

TEST_CASE("localization map file: bad covariances are refused naming the field",
          "[localization]") {
  LocalizationMap map = MakeMap();
  map.p_G_covariance.assign(2, Eigen::Matrix3f::Identity());  // not one per landmark
  CHECK_THAT(map.Validate(), Catch::Contains("p_G_covariance"));
  const std::string path = TempPath("bad.vlocmap");
  CHECK_THROWS_WITH(SaveLocalizationMap(map, path), Catch::Contains("p_G_covariance"));
  CHECK_FALSE(fs::exists(path));
  map.p_G_covariance.assign(3, Eigen::Matrix3f::Identity());
  map.p_G_covariance[1](0, 1) = 0.5f;  // not symmetric
  CHECK_THAT(map.Validate(), Catch::Contains("symmetric"));
  map.p_G_covariance[1] = -Eigen::Matrix3f::Identity();  // negative variances
  CHECK_THAT(map.Validate(), Catch::Contains("non-negative"));
  map.p_G_covariance[1] = Eigen::Matrix3f::Identity() * std::numeric_limits<float>::quiet_NaN();
  CHECK_THAT(map.Validate(), Catch::Contains("finite"));
}
