#include "vilma/mapping/locmap/localization_map_file.h"

#include <unistd.h>

#include <catch2/catch.hpp>
#include <filesystem>

#include "mapping_locmap/test_missions.h"
#include "vilma/core/error.h"
#include "vilma/mapstore/map_io.h"

using namespace vilma;
namespace fs = std::filesystem;

namespace {

struct TempDir {
  fs::path path = fs::temp_directory_path() / ("vilma_locmap_file_" + std::to_string(::getpid()));
  TempDir() { fs::create_directories(path); }
  ~TempDir() { fs::remove_all(path); }
};

}  // namespace

TEST_CASE("OpenLocalizationMap: a VI-map folder and the .vlocmap made of it give the same map") {
  TempDir dir;
  mapstore::VIMap vimap;
  mapstore::IdGenerator ids(1);
  mapping::test::AddTestMission(&vimap, &ids, 8, true, Eigen::Vector3d(10, 0, 0));
  mapping::test::AddTestMission(&vimap, &ids, 8, false, Eigen::Vector3d::Zero());  // not in G
  const std::string folder = (dir.path / "vimap").string();
  mapstore::SaveMap(vimap, folder);
  const localizer::LocalizationMapOptions options;

  const mapping::OpenedLocalizationMap from_folder =
      mapping::OpenLocalizationMap(folder, options, "MAP");
  CHECK(from_folder.from_vimap);
  CHECK(from_folder.vimap_missions == 2);
  CHECK(from_folder.missions.missions_used == 1);
  CHECK(from_folder.map->num_landmarks() == 4);  // the good landmarks 0, 2, 4, 6
  CHECK_THAT(from_folder.BriefReport(),
             Catch::StartsWith("VI-map folder, 2 missions (1 in the common frame G), summary "
                               "built in "));

  const std::string file = (dir.path / "map.vlocmap").string();
  localizer::SaveLocalizationMap(*from_folder.map, file);
  const mapping::OpenedLocalizationMap from_file =
      mapping::OpenLocalizationMap(file, options, "MAP");
  CHECK_FALSE(from_file.from_vimap);
  CHECK(from_file.map->num_landmarks() == from_folder.map->num_landmarks());
  CHECK(from_file.map->num_descriptors() == from_folder.map->num_descriptors());
  CHECK(from_file.map->p_G == from_folder.map->p_G);
  CHECK_THAT(from_file.BriefReport(), Catch::StartsWith("localization map file, loaded in "));
  CHECK(from_file.FullReport() == from_file.BriefReport() + "\n");
}

TEST_CASE("OpenLocalizationMap: a missing path and a map without good landmarks are named") {
  TempDir dir;
  const localizer::LocalizationMapOptions options;
  CHECK_THROWS_WITH(
      mapping::OpenLocalizationMap((dir.path / "nothing").string(), options, "--localization-map"),
      (dir.path / "nothing").string() +
          ": --localization-map: a .vlocmap file or a VI-map folder");
  // One vertex: its only good landmark has one observation, fewer than the map needs.
  mapstore::VIMap vimap;
  mapstore::IdGenerator ids(1);
  mapping::test::AddTestMission(&vimap, &ids, 1, true, Eigen::Vector3d::Zero());
  const std::string folder = (dir.path / "one-vertex").string();
  mapstore::SaveMap(vimap, folder);
  CHECK_THROWS_WITH(mapping::OpenLocalizationMap(folder, options, "MAP"),
                    folder + ": landmarks: a map with good landmarks");
}
