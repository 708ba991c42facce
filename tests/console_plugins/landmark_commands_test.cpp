// The landmark commands in the console, on a daemon-built map: elq, rtl, rlq, rbl, itl with
// their flags; bad flags change nothing.
#include <catch2/catch.hpp>

#include "console_plugins/test_maps.h"
#include "vilma/mapstore/consistency.h"

namespace vilma::console {
namespace {

using Fixture = test::ConsoleFixture;

std::size_t Count(const mapstore::VIMap& map, mapstore::LandmarkQuality q) {
  std::size_t n = 0;
  for (const auto& m : map.mission_ids()) {
    for (const auto& id : map.landmark_ids(m)) n += map.landmark(id).quality == q;
  }
  return n;
}

TEST_CASE("rlq, elq, rtl, rbl, itl on a daemon map") {
  const auto& maps = test::TestMaps();
  Fixture f;
  REQUIRE(f.Run("load " + maps.session0_map).ok());
  const std::size_t landmarks = f.map().num_landmarks();
  const std::size_t good = Count(f.map(), mapstore::LandmarkQuality::kGood);
  REQUIRE(good > 0);

  REQUIRE(f.Run("rlq").ok());
  CHECK(Count(f.map(), mapstore::LandmarkQuality::kUnknown) == landmarks);
  // The map builder's rules are elq's defaults: the same verdicts.
  REQUIRE(f.Run("elq").ok());
  CHECK(Count(f.map(), mapstore::LandmarkQuality::kGood) == good);
  // Stricter flags, fewer good ones; `set` keeps a flag for the session.
  REQUIRE(f.Run("elq --elq_min_observers=8").ok());
  const std::size_t strict = Count(f.map(), mapstore::LandmarkQuality::kGood);
  CHECK(strict < good);
  REQUIRE(f.Run("set elq_min_observation_angle_deg 30").ok());
  REQUIRE(f.Run("evaluate_landmark_quality").ok());
  CHECK(Count(f.map(), mapstore::LandmarkQuality::kGood) < good);
  REQUIRE(f.Run("unset elq_min_observation_angle_deg").ok());

  f.out.str("");
  REQUIRE(f.Run("rtl").ok());
  CHECK_THAT(f.out.str(), Catch::Contains("rtl: " + std::to_string(landmarks) + " landmarks"));
  CHECK(Count(f.map(), mapstore::LandmarkQuality::kGood) >= good * 9 / 10);

  REQUIRE(f.Run("rbl").ok());
  CHECK(f.map().num_landmarks() == Count(f.map(), mapstore::LandmarkQuality::kGood));
  CHECK(mapstore::CheckMapConsistency(f.map()).ok());
  // The removed landmarks' tracks are free again: itl makes landmarks of them.
  f.out.str("");
  REQUIRE(f.Run("itl").ok());
  CHECK(f.map().num_landmarks() > Count(f.map(), mapstore::LandmarkQuality::kGood));
  CHECK_THAT(f.out.str(), Catch::Contains("landmarks created"));
  REQUIRE(f.Run("cmc").ok());
}

TEST_CASE("landmark commands: bad flags and missions are errors that change nothing") {
  const auto& maps = test::TestMaps();
  Fixture f;
  REQUIRE(f.Run("load " + maps.session0_map).ok());
  const std::size_t landmarks = f.map().num_landmarks();
  CommandResult r = f.Run("elq --elq_min_observers=1");
  CHECK(r.outcome == CommandOutcome::kFailed);
  CHECK_THAT(r.message, Catch::Contains("min_observers"));
  r = f.Run("rtl --triangulation_max_iterations=many");
  CHECK(r.outcome == CommandOutcome::kFailed);
  CHECK_THAT(r.message, Catch::Contains("triangulation_max_iterations"));
  r = f.Run("itl --min_track_length=1");
  CHECK(r.outcome == CommandOutcome::kFailed);
  r = f.Run("rbl --map_mission=nosuchmission");
  CHECK(r.outcome == CommandOutcome::kFailed);
  CHECK(f.map().num_landmarks() == landmarks);
  CHECK(Count(f.map(), mapstore::LandmarkQuality::kUnknown) == 0);
}

}  // namespace
}  // namespace vilma::console
