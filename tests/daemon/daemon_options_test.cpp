#include "vilma/daemon/daemon_options.h"

#include <catch2/catch.hpp>
#include <fstream>
#include <sstream>

#include "vilma/core/error.h"

namespace vilma::daemon {
namespace {

std::string DefaultConfigText() {
  std::ifstream in(std::string(VILMA_SOURCE_DIR) + "/config/daemon.yaml");
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string Replace(std::string text, const std::string& from, const std::string& to) {
  const std::size_t at = text.find(from);
  REQUIRE(at != std::string::npos);
  return text.replace(at, from.size(), to);
}

std::string ErrorOf(const std::string& text) {
  try {
    ParseDaemonOptions(text, "daemon.yaml");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST_CASE("config/daemon.yaml equals the built-in defaults") {
  const DaemonOptions loaded = ParseDaemonOptions(DefaultConfigText(), "daemon.yaml");
  CHECK(DaemonOptionsToYaml(loaded) == DaemonOptionsToYaml(DaemonOptions()));
  CHECK(DaemonOptions().Validate().empty());
}

TEST_CASE("the effective config reads back to the same options") {
  DaemonOptions o;
  o.channels.cameras = {"CAM0"};
  o.queues.image_pool_slots = 40;
  o.sync.max_pending_frames = 5;
  o.estimator.features.max_features = 30;
  const DaemonOptions back = ParseDaemonOptions(DaemonOptionsToYaml(o), "effective.yaml");
  CHECK(DaemonOptionsToYaml(back) == DaemonOptionsToYaml(o));
  CHECK(back.estimator.features.max_features == 30);
}

TEST_CASE("bad daemon configs are rejected naming the key") {
  const std::string good = DefaultConfigText();
  CHECK(ErrorOf(good).empty());
  CHECK_THAT(ErrorOf(Replace(good, "vio_camera: 0", "vio_camera: 2")),
             Catch::Contains("daemon.yaml") && Catch::Contains("vio_camera"));
  CHECK_THAT(ErrorOf(Replace(good, "imu: IMU", "imu: imu.*")), Catch::Contains("channels.imu"));
  CHECK_THAT(ErrorOf(Replace(good, "input_capacity: 4096", "input_capacity: 3")),
             Catch::Contains("queues.input_capacity"));
  CHECK_THAT(ErrorOf(Replace(good, "max_pending_frames: 8", "max_pending_frames: 8\n  bogus: 1")),
             Catch::Contains("bogus"));
  CHECK_THAT(ErrorOf(Replace(good, "status_period_s: 1.0", "")), Catch::Contains("status_period_s"));
  CHECK_THAT(ErrorOf(Replace(good, "estimator: \"\"", "estimator: {max_features: 3}")),
             Catch::Contains("estimator"));
  CHECK_THAT(ErrorOf(Replace(good, "estimator: \"\"", "estimator: no-such-file.yaml")),
             Catch::Contains("no-such-file.yaml"));
}

TEST_CASE("the estimator options can be given inline") {
  std::ifstream in(std::string(VILMA_SOURCE_DIR) + "/config/estimator.yaml");
  std::stringstream ss;
  ss << in.rdbuf();
  std::string inline_options;
  std::string line;
  while (std::getline(ss, line)) inline_options += "  " + line + "\n";
  inline_options = Replace(inline_options, "max_features: 25", "max_features: 30");
  const std::string text =
      Replace(DefaultConfigText(), "estimator: \"\"", "estimator:\n" + inline_options);
  const DaemonOptions o = ParseDaemonOptions(text, "daemon.yaml");
  CHECK(o.estimator.features.max_features == 30);
}

}  // namespace
}  // namespace vilma::daemon
