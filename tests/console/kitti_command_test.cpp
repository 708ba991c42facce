#include "vilma/console/kitti_command.h"
#include "test_skip.h"

#include <catch2/catch.hpp>
#include <filesystem>
#include <sstream>

namespace vilma::console {
namespace {

namespace fs = std::filesystem;

struct Result {
  int code;
  std::string out;
  std::string err;
};

Result Run(const std::vector<std::string>& args) {
  std::ostringstream out, err;
  const int code = RunKittiCommand(args, out, err);
  return {code, out.str(), err.str()};
}

TEST_CASE("vilma localize-kitti: help and usage errors", "[kitti_command]") {
  const Result help = Run({"--help"});
  CHECK(help.code == kExitOk);
  CHECK_THAT(help.out, Catch::Contains("usage: vilma localize-kitti KITTI_DIR"));
  CHECK(Run({}).code == kExitUsage);
  CHECK(Run({"a", "b"}).code == kExitUsage);
  CHECK(Run({"a", "--bogus"}).code == kExitUsage);
  CHECK(Run({"a", "--config"}).code == kExitUsage);
  CHECK(Run({"a", "--features", "f.yaml", "--indoor-features"}).code == kExitUsage);
  const Result missing = Run({"/nonexistent/kitti"});
  CHECK(missing.code == kExitInputError);
  CHECK_THAT(missing.err, Catch::Contains("/nonexistent/kitti/calib.txt"));
}

TEST_CASE("vilma localize-kitti: the shared KITTI slice", "[kitti_command]") {
  const fs::path dir = fs::path(VILMA_SHARED_DATA_DIR) / "kitti_slices" / "KITTI_sequence_1";
  if (!fs::exists(dir / "poses.txt")) {
    VILMA_SKIP("KITTI slice absent at " << dir);
  }
  const Result r =
      Run({dir.string(), "--config", std::string(VILMA_SOURCE_DIR) + "/config/localizer.yaml"});
  INFO(r.err);
  REQUIRE(r.code == kExitOk);
  CHECK_THAT(r.out, Catch::Contains("baseline 0.537"));
  // 25 odd frames; the target is >= 90 % (23 of 25).
  CHECK_THAT(r.out, Catch::Contains("/25 = "));
  const std::string prefix = "recall (within 0.30 m and 2.00 deg): ";
  const std::size_t at = r.out.find(prefix);
  REQUIRE(at != std::string::npos);
  const int localized = std::stoi(r.out.substr(at + prefix.size()));
  CHECK(localized >= 23);
}

}  // namespace
}  // namespace vilma::console
