// optvi / optv in the console on a daemon-built map: better against ground truth, consistent,
// deterministic; bad flags change nothing.
#include <catch2/catch.hpp>

#include "console_plugins/test_maps.h"
#include "vilma/mapstore/consistency.h"

namespace vilma::console {
namespace {

using Fixture = test::ConsoleFixture;

double JsonNumberAfter(const std::string& text, const std::string& key) {
  const auto at = text.find("\"" + key + "\"");
  REQUIRE(at != std::string::npos);
  const auto rmse = text.find("\"rmse\": ", at);
  return std::stod(text.substr(rmse + 8));
}

TEST_CASE("optvi on a daemon map: the IMU biases and landmarks improve, runs agree") {
  const auto& maps = test::TestMaps();
  const std::string dir = test::ConsoleScratch("optvi");
  std::string results[2];
  for (int run = 0; run < 2; ++run) {
    Fixture f;
    REQUIRE(f.Run("load " + maps.session0_map).ok());
    REQUIRE(f.Run("eval_map " + maps.session0_dataset + " --json=" + dir + "/before.json").ok());
    REQUIRE(f.Run("optvi").ok());
    CHECK_THAT(f.out.str(), Catch::Contains("residuals: reprojection") &&
                                Catch::Contains("ms per iteration"));
    CHECK(mapstore::CheckMapConsistency(f.map()).ok());
    REQUIRE(f.Run("eval_map " + maps.session0_dataset + " --json=" + dir + "/after.json").ok());
    const std::string before = test::ReadTextFile(dir + "/before.json");
    results[run] = test::ReadTextFile(dir + "/after.json");
    CHECK(JsonNumberAfter(results[run], "gyro_bias_error") <
          JsonNumberAfter(before, "gyro_bias_error") * 2);
    CHECK(JsonNumberAfter(results[run], "surface_distance_m") <
          JsonNumberAfter(before, "surface_distance_m"));
    CHECK(JsonNumberAfter(results[run], "reprojection_px") <
          JsonNumberAfter(before, "reprojection_px"));
  }
  CHECK(results[0] == results[1]);
}

TEST_CASE("optv and the optimization flags, bad values change nothing") {
  const auto& maps = test::TestMaps();
  Fixture f;
  REQUIRE(f.Run("load " + maps.session0_map).ok());
  const auto v = f.map().VertexChain(f.map().mission_ids()[0])[60];
  const Eigen::Vector3d p = f.map().vertex(v).T_M_I.translation();
  CommandResult r = f.Run("optvi --ba_linear_solver=magic");
  CHECK(r.outcome == CommandOutcome::kFailed);
  CHECK_THAT(r.message, Catch::Contains("ba_linear_solver"));
  r = f.Run("optvi --ba_num_iterations=lots");
  CHECK(r.outcome == CommandOutcome::kFailed);
  CHECK(f.map().vertex(v).T_M_I.translation() == p);
  REQUIRE(f.Run("optv --ba_num_iterations=5 --ba_linear_solver=iterative_schur").ok());
  CHECK_THAT(f.out.str(), Catch::Contains("optv: cost"));
  CHECK(f.map().vertex(v).T_M_I.translation() != p);
  REQUIRE(f.Run("rlq").ok());
  r = f.Run("optvi --ba_num_iterations=3");  // the IMU terms alone still make a problem
  CHECK(r.ok());
  REQUIRE(f.Run("cmc").ok());
}

TEST_CASE("optvi --ba_estimate_noise_scales reports the scales of each solve") {
  const auto& maps = test::TestMaps();
  Fixture f;
  REQUIRE(f.Run("load " + maps.session0_map).ok());
  const auto v = f.map().VertexChain(f.map().mission_ids()[0])[60];
  const Eigen::Vector3d p = f.map().vertex(v).T_M_I.translation();
  CommandResult r = f.Run("optvi --ba_estimate_noise_scales --ba_noise_scale_max=0.5");
  CHECK(r.outcome == CommandOutcome::kFailed);
  CHECK_THAT(r.message, Catch::Contains("ba_noise_scale_max"));
  r = f.Run("optv --ba_estimate_noise_scales");
  CHECK(r.outcome == CommandOutcome::kFailed);
  CHECK_THAT(r.message, Catch::Contains("ba_estimate_noise_scales"));
  r = f.Run("optvi --ba_accel_noise_scale=0");
  CHECK(r.outcome == CommandOutcome::kFailed);
  CHECK(f.map().vertex(v).T_M_I.translation() == p);
  REQUIRE(f.Run("optvi --ba_estimate_noise_scales --ba_noise_scale_rounds=2 --ba_num_iterations=6")
              .ok());
  CHECK_THAT(f.out.str(), Catch::Contains("noise scales, solve 1: visual 1 gyro_noise 1") &&
                              Catch::Contains("noise scales, solve 2:") &&
                              Catch::Contains("variance factors (chi2 / redundancy): visual"));
  CHECK(f.map().vertex(v).T_M_I.translation() != p);
  REQUIRE(f.Run("cmc").ok());
}

}  // namespace
}  // namespace vilma::console
