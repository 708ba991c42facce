// eval_map in the console on a daemon-built map and its simulated dataset.
#include <catch2/catch.hpp>

#include "console_plugins/test_maps.h"

namespace vilma::console {
namespace {

using Fixture = test::ConsoleFixture;

TEST_CASE("eval_map judges a daemon map against its dataset's ground truth and world") {
  const auto& maps = test::TestMaps();
  Fixture f;
  REQUIRE(f.Run("load " + maps.session0_map).ok());
  const std::string json = test::ConsoleScratch("eval_map") + "/eval.json";
  REQUIRE(f.Run("eval_map " + maps.session0_dataset + " --json=" + json).ok());
  const std::string report = f.out.str();
  CHECK_THAT(report, Catch::Contains("ATE translation [m]") &&
                         Catch::Contains("good landmarks to the true surfaces [cm]"));
  const std::string text = test::ReadTextFile(json);
  CHECK_THAT(text, Catch::Contains("\"ate_translation_m\"") && Catch::Contains("\"surface_distance_m\""));
  // A 10 s VIO map: centimetres, not metres.
  const auto at = text.find("\"rmse\": ");
  REQUIRE(at != std::string::npos);
  CHECK(std::stod(text.substr(at + 8)) < 0.1);

  CommandResult r = f.Run("eval_map " + maps.session0_dataset + " --align=bogus");
  CHECK(r.outcome == CommandOutcome::kFailed);
  CHECK_THAT(r.message, Catch::Contains("--align"));
  r = f.Run("eval_map");
  CHECK(r.outcome == CommandOutcome::kFailed);
  CHECK_THAT(r.message, Catch::Contains("--dataset"));
  r = f.Run("eval_map /nonexistent/dataset");
  CHECK(r.outcome == CommandOutcome::kFailed);
  CHECK_THAT(r.message, Catch::Contains("/nonexistent/dataset"));
}

}  // namespace
}  // namespace vilma::console
