// Stereo initial-depth matching on the simulator's renders (perfect images, exact rig): the
// share of new features whose inverse distance is matched in camera 2, and why the others are
// not (StereoMatchFailure). docs/estimator-stereo-history.md "Why stereo matches fail". With
// stereo.probation_frames, the matched depths tested against C1's flow (session 36).
#include <catch2/catch.hpp>
#include <cstdlib>
#include <filesystem>
#include <string>
#include <unistd.h>

#include "test_skip.h"
#include "vilma/core/asl_dataset.h"
#include "vilma/core/rig.h"
#include "vilma/estimator/vio_filter.h"

namespace vilma::estimator {
namespace {

TEST_CASE("stereo: most new features of a simulated room are matched in camera 2") {
  const std::string sim = std::string(VILMA_BINARY_DIR) + "/bin/vilma-sim";
  if (!std::filesystem::exists(sim)) {
    VILMA_SKIP(sim << " is not built");
  }
  const std::filesystem::path dir = std::filesystem::temp_directory_path() /
                                    ("vilma_stereo_sim_test_" + std::to_string(::getpid()));
  std::filesystem::remove_all(dir);
  const std::string command = sim + " room --stereo --out " + dir.string() + " --seconds 4 > /dev/null 2>&1";
  REQUIRE(std::system(command.c_str()) == 0);
  const AslDataset dataset = AslDataset::Open(dir.string());
  const SensorRig rig = LoadSensorRig((dir / "rig.yaml").string());
  REQUIRE(dataset.cameras().size() >= 2);
  auto run = [&](const FilterOptions& options) {
    VioFilter filter(rig, 0, options);
    const auto& frames0 = dataset.cameras()[0].frames;
    const auto& frames1 = dataset.cameras()[1].frames;
    std::size_t next = 0, j = 0;
    for (const CameraFrame& frame : frames0) {
      while (next < dataset.imu().size() && dataset.imu()[next].t_ns <= frame.t_ns) {
        filter.AddImu(dataset.imu()[next++]);
      }
      while (j < frames1.size() && frames1[j].t_ns < frame.t_ns) ++j;
      REQUIRE(j < frames1.size());
      REQUIRE(frames1[j].t_ns == frame.t_ns);
      filter.AddImage(frame.t_ns, AslDataset::LoadImage(frame.image_path),
                      AslDataset::LoadImage(frames1[j].image_path));
    }
    return filter.stats();
  };
  FilterOptions options;
  options.stereo.enabled = true;
  // The candidate search alone (its recall): the uniqueness test that rejects ambiguous
  // matches for precision (off by default) is off here whatever the default.
  options.stereo.min_uniqueness_ratio = 0.0;
  const FilterStats s = run(options);
  // stereo.probation_frames (session 36): the matched depths are tested against C1's flow
  // before C2 joins; on the room's renders most matches are right and pass.
  options.stereo.probation_frames = 5;
  const FilterStats p = run(options);
  std::filesystem::remove_all(dir);
  INFO("probation: " << p.probation_passes << " passed, " << p.probation_removals
                     << " removed of " << p.stereo_matches << " matches");
  CHECK(p.probation_passes > 0);
  CHECK(p.probation_passes >= 3 * p.probation_removals);
  CHECK(s.probation_passes + s.probation_removals == 0);  // off by default
  const auto& why = s.stereo_match_failure_reasons;
  INFO("matched " << s.stereo_matches << ", not " << s.stereo_match_failures
                  << " (no sample " << why[1] << ", not converged " << why[2] << ", residual "
                  << why[3] << ", no depth " << why[4] << ", epipolar " << why[5] << ")");
  REQUIRE(s.stereo_matches + s.stereo_match_failures >= 20);
  // Measured (4 s room, seed 1): 11 of 25 matched with only the global minimum of the coarse
  // search (false minima at the near end of the curve), 17 of 25 with the 3 lowest local minima
  // tried. The remaining failures: a patch at C1's left edge outside C2, 2D alignments that
  // do not converge or slide off the curve.
  CHECK(s.stereo_matches >= 2 * s.stereo_match_failures);
}

}  // namespace
}  // namespace vilma::estimator
