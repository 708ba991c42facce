#include "vilma/console/rig_command.h"

#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <sstream>

#include "core/test_data.h"
#include "vilma/core/rig.h"

namespace vilma::console {
namespace {

struct Result {
  int code;
  std::string out;
  std::string err;
};

Result Run(const std::vector<std::string>& args) {
  std::ostringstream out, err;
  const int code = RunRigCommand(args, out, err);
  return {code, out.str(), err.str()};
}

TEST_CASE("vilma rig import writes a rig that check accepts", "[rig_command]") {
  const std::string euroc = testing::EurocMicroDir();
  VILMA_REQUIRE_SHARED_DATA(euroc);
  testing::TempDir dir;
  const std::string rig_path = dir.File("rig.yaml");
  const Result imported = Run({"import", euroc, "--out", rig_path});
  INFO(imported.err);
  REQUIRE(imported.code == kExitOk);
  CHECK_THAT(imported.out, Catch::Contains("2 cameras"));
  const SensorRig rig = LoadSensorRig(rig_path);
  CHECK(rig.cameras.size() == 2);

  const Result checked = Run({"check", rig_path});
  REQUIRE(checked.code == kExitOk);
  CHECK_THAT(checked.out, Catch::Contains("baseline cam0-cam1: 0.110"));
  CHECK_THAT(checked.out, Catch::Contains(": ok"));
}

TEST_CASE("vilma rig reports bad input and bad usage with exit codes", "[rig_command]") {
  testing::TempDir dir;
  std::ofstream(dir.File("bad.yaml")) << "imu: {rate_hz: 200}\ncameras: []\n";
  const Result bad = Run({"check", dir.File("bad.yaml")});
  CHECK(bad.code == kExitInputError);
  CHECK_THAT(bad.err, Catch::Contains("bad.yaml") && Catch::Contains("imu.gyroscope_noise_density"));
  CHECK(Run({"import", dir.File("nothing")}).code == kExitInputError);
  CHECK(Run({}).code == kExitUsage);
  CHECK(Run({"frobnicate", "x"}).code == kExitUsage);
  CHECK(Run({"check"}).code == kExitUsage);
  CHECK(Run({"check", "a", "b"}).code == kExitUsage);
  CHECK(Run({"import", "x", "--out"}).code == kExitUsage);
  const Result help = Run({"--help"});
  CHECK(help.code == kExitOk);
  CHECK_THAT(help.out, Catch::Contains("usage: vilma rig import"));
}

}  // namespace
}  // namespace vilma::console
