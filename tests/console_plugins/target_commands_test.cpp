// load_target_recording / ltr and target_calibration_report / tcr (console/plugins/calibration).
#include <catch2/catch.hpp>

#include <filesystem>

#include "console_plugins/test_maps.h"
#include "test_skip.h"

namespace vilma::console {
namespace {

using Fixture = test::ConsoleFixture;

TEST_CASE("ltr: a missing recording or rig fails naming what is missing") {
  Fixture f;
  const std::string rig = std::string(VILMA_SOURCE_DIR) + "/config/euroc-rig.yaml";
  CHECK(f.Run("ltr /nonexistent/recording --rig " + rig).outcome == CommandOutcome::kFailed);
  CHECK_THAT(f.err.str(), Catch::Contains("/nonexistent/recording"));
  CHECK(f.Run("ltr /nonexistent/recording").outcome == CommandOutcome::kFailed);
  CHECK_THAT(f.err.str(), Catch::Contains("rig"));
  CHECK(f.session.maps().empty());
}

TEST_CASE("ltr, optvi and tcr on the first seconds of euroc_imu_april") {
  const std::string recording = std::string(VILMA_SHARED_DATA_DIR) + "/euroc_imu_april";
  if (!std::filesystem::exists(recording + "/imu0.csv")) {
    VILMA_SKIP(recording << " not found");
  }
  const std::string rig = std::string(VILMA_SOURCE_DIR) + "/config/euroc-rig.yaml";
  Fixture f;
  REQUIRE(f.Run("ltr " + recording + " --rig " + rig +
                " --max_duration_s 4 --perturb_extrinsics_m 0.02 --perturb_extrinsics_deg 2")
              .ok());
  CHECK_THAT(f.out.str(), Catch::Contains("loaded as target"));
  REQUIRE(f.Run("tcr --reference_rig " + rig).ok());
  CHECK_THAT(f.out.str(), Catch::Contains("rotation 2.000 deg"));
  REQUIRE(f.Run("optvi --ba_fix_landmarks --ba_fix_extrinsics=false --ba_estimate_time_offset "
                "--ba_estimate_baseframe_tilt --ba_outlier_rejection=false "
                "--evaluate_quality=false")
              .ok());
  CHECK_THAT(f.out.str(), Catch::Contains("time offset 0 ->"));
  // 4 s of hand-held motion bring the 2 deg back well under 1 deg.
  const Transformation T_I_C = f.map().mission(f.map().mission_ids()[0]).rig.cameras[0].T_I_C;
  const Transformation T_ref = LoadSensorRig(rig).cameras[0].T_I_C;
  CHECK(AngleBetween(T_I_C.rotation(), T_ref.rotation()) * 180.0 / M_PI < 1.0);
  REQUIRE(f.Run("tcr --reference_rig " + rig + " --time_offset_ms 0").ok());
  CHECK_THAT(f.out.str(), Catch::Contains("frames against PnP"));
}

}  // namespace
}  // namespace vilma::console
