// Map management and inspection commands on real daemon-built maps, and `vilma console` as a
// process (batch runs, exit codes).
#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>
#include <sstream>

#include "console_plugins/test_maps.h"
#include "vilma/console/session.h"
#include "vilma/mapstore/consistency.h"
#include "vilma/mapstore/map_io.h"

namespace vilma::console {
namespace {

namespace fs = std::filesystem;

using Fixture = test::ConsoleFixture;

TEST_CASE("load, list, map_stats, mission_stats, check_map_consistency on a daemon map") {
  const auto& maps = test::TestMaps();
  Fixture f;
  REQUIRE(f.Run("load " + maps.session0_map).ok());
  REQUIRE(f.Run("load --map_folder=" + maps.session1_map + " --map_key=second").ok());
  CHECK(f.session.maps().Keys() == std::vector<std::string>{"second", "session0"});
  CHECK(f.session.maps().selected() == "second");
  REQUIRE(f.Run("select session0").ok());
  f.out.str("");
  REQUIRE(f.Run("ls").ok());
  CHECK_THAT(f.out.str(), Catch::Contains("* session0: 1 missions"));
  f.out.str("");
  REQUIRE(f.Run("ms").ok());
  const mapstore::VIMap& map = f.map();
  CHECK_THAT(f.out.str(), Catch::Contains(std::to_string(map.num_vertices())) &&
                              Catch::Contains("total") && Catch::Contains("on disk"));
  REQUIRE(f.Run("mission_stats").ok());
  REQUIRE(f.Run("check_map_consistency").ok());
  CHECK_THAT(f.out.str(), Catch::Contains("map is consistent"));
}

TEST_CASE("bad input: missing folder, corrupted file, unknown command, bad flag, no --overwrite") {
  const auto& maps = test::TestMaps();
  Fixture f;
  CommandResult r = f.Run("load /nonexistent/map");
  CHECK(r.outcome == CommandOutcome::kFailed);
  CHECK_THAT(r.message, Catch::Contains("/nonexistent/map: no such map folder"));
  CHECK(f.session.maps().empty());

  // A corrupted copy: one flipped byte in a vertex chunk.
  const std::string dir = test::ConsoleScratch("corrupted");
  fs::copy(maps.session0_map, dir + "/map", fs::copy_options::recursive);
  std::string chunk;
  for (const auto& e : fs::recursive_directory_iterator(dir + "/map")) {
    if (e.path().filename().string().rfind("vertices_", 0) == 0) chunk = e.path().string();
  }
  REQUIRE_FALSE(chunk.empty());
  {
    std::fstream file(chunk, std::ios::in | std::ios::out | std::ios::binary);
    file.seekp(100);
    file.put('\x5a');
  }
  r = f.Run("load " + dir + "/map");
  CHECK(r.outcome == CommandOutcome::kFailed);
  CHECK_THAT(r.message, Catch::Contains(chunk) && Catch::Contains("crc32"));
  CHECK(f.session.maps().empty());

  r = f.Run("optimise_everything");
  CHECK_THAT(r.message, Catch::Contains("unknown command 'optimise_everything'"));
  REQUIRE(f.Run("load " + maps.session0_map).ok());
  r = f.Run("save --overwrite=maybe");
  CHECK(r.message == "--overwrite: expected true or false, got 'maybe'");
  r = f.Run("save");  // into the folder it came from: a map is there
  CHECK_THAT(r.message, Catch::Contains("a map exists there; add --overwrite"));
  r = f.Run("save --map_folder=" + maps.session1_map);
  CHECK_THAT(r.message, Catch::Contains("add --overwrite"));
  CHECK(mapstore::LoadMap(maps.session1_map).num_vertices() > 0);  // untouched
}

TEST_CASE("save writes a map that loads back equal, --overwrite replaces it atomically") {
  const auto& maps = test::TestMaps();
  const std::string dir = test::ConsoleScratch("save");
  Fixture f;
  REQUIRE(f.Run("load " + maps.session0_map).ok());
  REQUIRE(f.Run("save --out " + dir + "/copy").ok());
  const mapstore::VIMap original = mapstore::LoadMap(maps.session0_map);
  const mapstore::VIMap copy = mapstore::LoadMap(dir + "/copy");
  CHECK(copy.num_vertices() == original.num_vertices());
  CHECK(copy.num_landmarks() == original.num_landmarks());
  CHECK(copy.num_edges() == original.num_edges());
  REQUIRE(f.Run("rm " + original.mission_ids()[0].Hex().substr(0, 6)).ok());
  CHECK(f.map().num_vertices() == 0);
  REQUIRE(f.Run("save --overwrite").ok());  // to dir/copy, where it was saved last
  CHECK(mapstore::LoadMap(dir + "/copy").num_vertices() == 0);
}

TEST_CASE("load_merge_all_maps, join_all_maps and remove_mission keep the map consistent") {
  const auto& maps = test::TestMaps();
  Fixture f;
  REQUIRE(f.Run("load_merge_all_maps --maps_folder=" + maps.maps_folder + " --map_key=merged").ok());
  const mapstore::VIMap a = mapstore::LoadMap(maps.session0_map);
  const mapstore::VIMap b = mapstore::LoadMap(maps.session1_map);
  CHECK(f.map().mission_ids().size() == 2);
  CHECK(f.map().num_vertices() == a.num_vertices() + b.num_vertices());
  CHECK(f.map().mission_ids()[0] == a.mission_ids()[0]);  // sorted folder order
  CHECK(mapstore::CheckMapConsistency(f.map()).ok());
  // Loading the same maps again and joining fails (same ids) and changes nothing.
  REQUIRE(f.Run("load_all " + maps.maps_folder).ok());
  CHECK(f.session.maps().Keys().size() == 3);
  CommandResult r = f.Run("join_all_maps");
  CHECK(r.outcome == CommandOutcome::kFailed);
  CHECK_THAT(r.message, Catch::Contains("used in both maps"));
  CHECK(f.session.maps().Keys().size() == 3);
  REQUIRE(f.Run("delete merged").ok());
  REQUIRE(f.Run("join_all_maps --target_map_key=joined").ok());
  CHECK(f.session.maps().Keys() == std::vector<std::string>{"joined"});
  CHECK(f.map().num_vertices() == a.num_vertices() + b.num_vertices());
  REQUIRE(f.Run("remove_mission --map_mission=" + b.mission_ids()[0].Hex()).ok());
  CHECK(f.map().num_vertices() == a.num_vertices());
  CHECK(f.map().num_landmarks() == a.num_landmarks());
  CHECK(mapstore::CheckMapConsistency(f.map()).ok());
  r = f.Run("rm --map_mission=zzzz");
  CHECK_THAT(r.message, Catch::Contains("mission 'zzzz'"));
}

TEST_CASE("vilma console --script / -c: echo, stop at the first failure, exit codes") {
  const auto& maps = test::TestMaps();
  const std::string dir = test::ConsoleScratch("batch");
  const std::string vilma = test::BinDir() + "/vilma";
  {
    std::ofstream script(dir + "/ok.txt");
    script << "# a batch\nload " << maps.session0_map << "\nms; check_map_consistency\n";
  }
  test::ChildProcess ok({vilma, "console", "--script", dir + "/ok.txt"}, dir + "/ok.out");
  CHECK(ok.Wait(120.0) == 0);
  const std::string ok_out = test::ReadTextFile(dir + "/ok.out");
  CHECK_THAT(ok_out, Catch::Contains("> load ") && Catch::Contains("> ms") &&
                         Catch::Contains("(check_map_consistency: ") &&
                         Catch::Contains("3 commands ok"));

  test::ChildProcess bad({vilma, "console", maps.session0_map, "-c",
                          "ms; kfh_typo --x=1; check_map_consistency"},
                         dir + "/bad.out");
  CHECK(bad.Wait(120.0) == 1);
  const std::string bad_out = test::ReadTextFile(dir + "/bad.out");
  CHECK_THAT(bad_out, Catch::Contains("unknown command 'kfh_typo'") &&
                          Catch::Contains("failed at -c:1: kfh_typo --x=1") &&
                          !Catch::Contains("> check_map_consistency"));

  test::ChildProcess usage({vilma, "console", "--no-such-option"}, dir + "/usage.out");
  CHECK(usage.Wait(30.0) == 2);
}

}  // namespace
}  // namespace vilma::console
