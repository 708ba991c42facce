// export_for_pmvs through the console on a saved map with images (the data export tests'
// projected map, saved and loaded as a user would): maplab's flag names, the mission selector,
// the folder made once and refused after, and a map without images refused with a message.
#include <catch2/catch.hpp>
#include <filesystem>

#include "console_plugins/test_maps.h"
#include "mapping_export/data_export_test_util.h"
#include "vilma/console/session.h"
#include "vilma/mapstore/map_io.h"

namespace vilma::console {
namespace {

namespace fs = std::filesystem;
using mapping::testing::MakeProjectedMap;
using mapping::testing::ProjectedMapOptions;
using mapping::testing::ReadLines;

using Fixture = test::ConsoleFixture;

TEST_CASE("export_for_pmvs writes the PMVS2 folder of a saved map with images") {
  const std::string dir = test::ConsoleScratch("pmvs");
  ProjectedMapOptions o;
  o.images = true;
  o.vertices_per_mission = 3;
  const mapping::testing::ProjectedMap m = MakeProjectedMap(o);
  mapstore::SaveMap(m.map, dir + "/map");

  Fixture f;
  REQUIRE(f.Run("load " + dir + "/map").ok());
  REQUIRE(f.Run("export_for_pmvs --pmvs_reconstruction_folder=" + dir +
                "/pmvs --pmvs_min_covisible_landmarks=3")
              .ok());
  const std::string report = f.out.str();
  INFO(report);
  CHECK_THAT(report, Catch::Contains("pmvs: 12 images") &&
                         Catch::Contains("observations dropped 0") &&
                         Catch::Contains("pmvs2 " + dir + "/pmvs/ option-0000"));
  for (const char* file : {"/visualize/00000000.jpg", "/visualize/00000011.jpg",
                           "/txt/00000011.txt", "/bundle.rd.out", "/vis.dat", "/option-0000"}) {
    CHECK(fs::is_regular_file(dir + "/pmvs" + file));
  }
  CHECK(fs::is_directory(dir + "/pmvs/models"));
  CHECK(ReadLines(dir + "/pmvs/vis.dat").size() == 2 + 12);

  // Once made, the folder is not written over.
  CommandResult r = f.Run("export_for_pmvs " + dir + "/pmvs");
  CHECK(r.outcome == CommandOutcome::kFailed);
  CHECK_THAT(r.message, Catch::Contains("new or empty folder"));
  // One mission by name, as the first word.
  REQUIRE(f.Run("export_for_pmvs " + dir + "/run1 --mission=run1").ok());
  CHECK(ReadLines(dir + "/run1/vis.dat").size() == 2 + 6);
  // No folder given.
  r = f.Run("export_for_pmvs");
  CHECK(r.outcome == CommandOutcome::kFailed);
  CHECK_THAT(r.message, Catch::Contains("out: expected"));
}

TEST_CASE("export_for_pmvs refuses a map without images and writes nothing") {
  const std::string dir = test::ConsoleScratch("pmvs_no_images");
  ProjectedMapOptions o;
  o.vertices_per_mission = 2;
  mapstore::SaveMap(MakeProjectedMap(o).map, dir + "/map");
  Fixture f;
  REQUIRE(f.Run("load " + dir + "/map").ok());
  const CommandResult r = f.Run("export_for_pmvs --out=" + dir + "/pmvs");
  CHECK(r.outcome == CommandOutcome::kFailed);
  CHECK_THAT(r.message, Catch::Contains("expected camera frames with image resources"));
  CHECK_FALSE(fs::exists(dir + "/pmvs"));
  CHECK_FALSE(fs::exists(dir + "/pmvs.partial"));
}

}  // namespace
}  // namespace vilma::console
