// set_mission_baseframe_to_known / sbk.
#include <catch2/catch.hpp>

#include "console_plugins/test_maps.h"

namespace vilma::console {
namespace {

using Fixture = test::ConsoleFixture;

TEST_CASE("sbk marks the first mission known, or the one named, T_G_M unchanged") {
  const auto& maps = test::TestMaps();
  Fixture f;
  REQUIRE(f.Run("load_merge_all_maps " + maps.maps_folder).ok());
  REQUIRE(f.map().mission_ids().size() == 2);
  const auto first = f.map().mission_ids()[0];
  const auto second = f.map().mission_ids()[1];
  for (const auto& id : {first, second}) {
    f.session.maps().Get(f.session.maps().selected()).map->mission(id).baseframe_known = false;
  }
  const Transformation T_G_M = f.map().mission(second).T_G_M;
  REQUIRE(f.Run("sbk").ok());
  CHECK(f.map().mission(first).baseframe_known);
  CHECK_FALSE(f.map().mission(second).baseframe_known);
  CHECK_THAT(f.out.str(), Catch::Contains("now known"));
  REQUIRE(f.Run("set_mission_baseframe_to_known " + second.Hex().substr(0, 8)).ok());
  CHECK(f.map().mission(second).baseframe_known);
  CHECK(f.map().mission(second).T_G_M.translation() == T_G_M.translation());
  REQUIRE(f.Run("sbk").ok());
  CHECK_THAT(f.out.str(), Catch::Contains("was already known"));
  const CommandResult r = f.Run("sbk --map_mission=zzzz");
  CHECK(r.outcome == CommandOutcome::kFailed);
}

}  // namespace
}  // namespace vilma::console
