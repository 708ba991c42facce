// vilma-loc-acceptance, the acceptance benchmark's program (localizer/tools/loc_acceptance.cpp).
#include <sys/wait.h>

#include <array>
#include <catch2/catch.hpp>
#include <cstdio>
#include <filesystem>
#include <string>

#include "test_skip.h"

namespace fs = std::filesystem;

namespace {

const std::string kTool = std::string(VILMA_BINARY_DIR) + "/bin/vilma-loc-acceptance";

// Runs a shell command; its stdout and stderr (2>&1 appended) in *out; the exit code.
int Run(const std::string& command, std::string* out) {
  out->clear();
  FILE* pipe = popen((command + " 2>&1").c_str(), "r");
  if (pipe == nullptr) return -1;
  std::array<char, 4096> buffer;
  while (fgets(buffer.data(), buffer.size(), pipe) != nullptr) *out += buffer.data();
  const int status = pclose(pipe);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

}  // namespace

TEST_CASE("vilma-loc-acceptance: usage and input errors", "[localization]") {
  if (!fs::exists(kTool)) {
    VILMA_SKIP(kTool << " not built");
  }
  std::string out;
  CHECK(Run(kTool + " --help", &out) == 0);
  CHECK_THAT(out, Catch::Contains("possible") && Catch::Contains("--swap"));
  CHECK(Run(kTool, &out) == 2);
  CHECK(Run(kTool + " frobnicate", &out) == 2);
  CHECK(Run(kTool + " asl only-one-argument", &out) == 2);
  CHECK(Run(kTool + " asl a b --box 0,0,2,1", &out) == 2);
  CHECK_THAT(out, Catch::Contains("box"));
  CHECK(Run(kTool + " asl a b --swap x", &out) == 2);
  CHECK(Run(kTool + " kitti a --swap 0.5", &out) == 2);  // the scenarios define their own
  CHECK(Run(kTool + " kitti a --features f.yaml", &out) == 2);
  CHECK_THAT(out, Catch::Contains("--features are for asl"));
  // A bad --features file is named before the dataset is read.
  CHECK(Run(kTool + " asl /nonexistent-dataset x.vlocmap --features /nonexistent-features.yaml",
            &out) == 1);
  CHECK_THAT(out, Catch::Contains("/nonexistent-features.yaml"));
  CHECK(Run(kTool + " kitti a --kitti-map exact", &out) == 2);
  CHECK_THAT(out, Catch::Contains("integer, subpixel or tracks"));
  CHECK(Run(kTool + " asl a b --kitti-map integer", &out) == 2);  // KITTI maps only
  CHECK(Run(kTool + " asl a b --perturbation-seed 3", &out) == 2);
  CHECK(Run(kTool + " asl /nonexistent-dataset x.vlocmap", &out) == 1);
  // landmarks: two arguments; a folder without sim.yaml is named.
  CHECK(Run(kTool + " landmarks only-one.vlocmap", &out) == 2);
  CHECK(Run(kTool + " landmarks x.vlocmap /nonexistent-dataset", &out) == 1);
  CHECK_THAT(out, Catch::Contains("sim.yaml"));
  CHECK_THAT(out, Catch::Contains("/nonexistent-dataset"));
  CHECK(Run(kTool + " header", &out) == 0);
  CHECK_THAT(out, Catch::StartsWith("| data set | queries | possible | accepted |"));
}

TEST_CASE("vilma-loc-acceptance: a KITTI scenario's row and per-query lines",
          "[localization][kitti]") {
  const fs::path dir = fs::path(VILMA_SHARED_DATA_DIR) / "kitti_slices" / "KITTI_sequence_1";
  if (!fs::exists(kTool)) {
    VILMA_SKIP(kTool << " not built");
  }
  if (!fs::exists(dir / "calib.txt")) {
    VILMA_SKIP("KITTI slice absent at " << dir);
  }
  std::string out;
  CHECK(Run(kTool + " kitti '" + dir.string() + "' --scenario bogus", &out) == 2);
  CHECK_THAT(out, Catch::Contains("unknown scenario 'bogus'"));
  // few-keypoints: the 100 best query keypoints; quick (small queries).
  // --inliers: frame 1 is accepted (a right pose), frame 2 is a map frame, not a query.
  REQUIRE(Run(kTool + " kitti '" + dir.string() +
                  "' --scenario few-keypoints --queries --inliers 1 --inliers 2",
              &out) == 0);
  INFO(out);
  CHECK_THAT(out, Catch::Contains("| kitti few-keypoints | 25 |"));
  CHECK_THAT(out, Catch::Contains("frame  status"));
  CHECK_THAT(out, Catch::Contains("  100 "));  // keypoints per query after the perturbation
  CHECK_THAT(out, !Catch::Contains("WRONG"));
  CHECK_THAT(out, Catch::Contains("frame 1 ok: position error in the true camera frame"));
  CHECK_THAT(out, !Catch::Contains("frame 2 "));
  CHECK_THAT(out, Catch::Contains("u       v  inlier oracle  err_est[px] err_truth[px]"));
  CHECK_THAT(out, Catch::Contains("\ninliers "));
  CHECK_THAT(out, Catch::Contains(" m, error under the truth median "));
  CHECK(Run(kTool + " kitti '" + dir.string() + "' --inliers x", &out) == 2);
}
