// landmark_sparsify and generate_summary_map_and_save_to_disk in the console, on a daemon-built
// map: the budget, a consistent map, a .vlocmap that loads with the kept landmarks; wrong
// flags change nothing.
#include <catch2/catch.hpp>
#include <filesystem>

#include "console_plugins/test_maps.h"
#include "vilma/localizer/localization_map.h"
#include "vilma/mapstore/consistency.h"

namespace vilma::console {
namespace {

using Fixture = test::ConsoleFixture;

std::size_t GoodLandmarks(const mapstore::VIMap& map) {
  std::size_t n = 0;
  for (const auto& m : map.mission_ids()) {
    for (const auto& l : map.landmark_ids(m)) {
      n += map.landmark(l).quality == mapstore::LandmarkQuality::kGood ? 1 : 0;
    }
  }
  return n;
}

TEST_CASE("lsparsify then summary_map: N landmarks kept, the .vlocmap holds them", "[lsparsify]") {
  const auto& maps = test::TestMaps();
  const std::string dir = test::ConsoleScratch("summarization");
  Fixture f;
  REQUIRE(f.Run("load " + maps.session0_map).ok());
  REQUIRE(f.Run("elq").ok());
  const std::size_t good = GoodLandmarks(f.map());
  REQUIRE(good > 200);

  // The full map's localization map first, for comparison.
  REQUIRE(f.Run("generate_summary_map_and_save_to_disk --summary_map_save_path=" + dir +
                "/full.vlocmap")
              .ok());
  CHECK_THAT(f.out.str(), Catch::Contains("summary_map: " + dir + "/full.vlocmap"));
  const localizer::LocalizationMap full = localizer::LoadLocalizationMap(dir + "/full.vlocmap");
  CHECK(full.num_landmarks() > 0);
  CHECK(full.projection.size() > 0);  // trained and stored

  REQUIRE(f.Run("lsparsify --num_landmarks_to_keep=100").ok());
  CHECK_THAT(f.out.str(), Catch::Contains("lsparsify (ilp): "));
  CHECK_THAT(f.out.str(), Catch::Contains("-> 100, observations"));
  CHECK(f.map().num_landmarks() == 100);
  CHECK(GoodLandmarks(f.map()) == 100);
  CHECK(mapstore::CheckMapConsistency(f.map()).ok());

  REQUIRE(f.Run("summary_map " + dir + "/small.vlocmap").ok());
  const localizer::LocalizationMap small = localizer::LoadLocalizationMap(dir + "/small.vlocmap");
  CHECK(small.num_landmarks() <= 100);
  CHECK(small.num_landmarks() >= 70);  // landmarks seen once are not localization landmarks
  CHECK(std::filesystem::file_size(dir + "/small.vlocmap") <
        std::filesystem::file_size(dir + "/full.vlocmap") / 2);
}

TEST_CASE("lsparsify flags: methods, fraction, bad values leave the map unchanged", "[lsparsify]") {
  const auto& maps = test::TestMaps();
  Fixture f;
  REQUIRE(f.Run("load " + maps.session0_map).ok());
  REQUIRE(f.Run("elq").ok());
  const std::size_t n = f.map().num_landmarks();
  const std::size_t good = GoodLandmarks(f.map());

  CommandResult r = f.Run("lsparsify");
  CHECK(r.outcome == CommandOutcome::kFailed);
  CHECK_THAT(r.message, Catch::Contains("num_landmarks_to_keep"));
  r = f.Run("lsparsify --num_landmarks_to_keep=10 --lsparsify_method=greedy");
  CHECK(r.outcome == CommandOutcome::kFailed);
  CHECK_THAT(r.message, Catch::Contains("ilp, most_observed or random"));
  r = f.Run("lsparsify --lsparsify_keep_fraction=1.5");
  CHECK(r.outcome == CommandOutcome::kFailed);
  r = f.Run("summary_map");
  CHECK(r.outcome == CommandOutcome::kFailed);
  CHECK_THAT(r.message, Catch::Contains("summary_map_save_path"));
  CHECK(f.map().num_landmarks() == n);

  REQUIRE(f.Run("lsparsify --lsparsify_keep_fraction=0.5 --lsparsify_method=random").ok());
  CHECK(f.map().num_landmarks() == static_cast<std::size_t>(std::llround(0.5 * good)));
  CHECK_THAT(f.out.str(), Catch::Contains("lsparsify (random)"));
}

}  // namespace
}  // namespace vilma::console
