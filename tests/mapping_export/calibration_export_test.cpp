// export_ncamera_calibration: the written rig YAML loads with core/rig.h's loader to the same
// rig; one file per mission; missions without a rig are refused.
#include "vilma/mapping/export/calibration_export.h"

#include <catch2/catch.hpp>
#include <filesystem>

#include "mapping_export/data_export_test_util.h"
#include "mapstore/synthetic_map.h"
#include "vilma/core/error.h"
#include "vilma/core/rig.h"

namespace vilma::mapping {
namespace {

using mapstore::VIMap;
using testing::ScratchFolder;

void RequireSameRig(const SensorRig& a, const SensorRig& b) {
  REQUIRE(a.cameras.size() == b.cameras.size());
  for (std::size_t c = 0; c < a.cameras.size(); ++c) {
    const CameraConfig& x = a.cameras[c];
    const CameraConfig& y = b.cameras[c];
    CHECK(x.name == y.name);
    CHECK(x.rate_hz == y.rate_hz);
    CHECK(x.time_offset_ns == y.time_offset_ns);
    CHECK(x.camera.width() == y.camera.width());
    CHECK(x.camera.height() == y.camera.height());
    CHECK(x.camera.intrinsics() == y.camera.intrinsics());
    CHECK(x.camera.distortion_model() == y.camera.distortion_model());
    CHECK(x.camera.distortion_coefficients() == y.camera.distortion_coefficients());
    // The YAML holds the 4x4 matrix: the rotation comes back through a matrix -> quaternion
    // conversion, equal to the last bits.
    CHECK((x.T_I_C.translation() - y.T_I_C.translation()).norm() == 0.0);
    CHECK(AngleBetween(x.T_I_C.rotation(), y.T_I_C.rotation()) < 1e-12);
  }
  CHECK(a.imu.name == b.imu.name);
  CHECK(a.imu.rate_hz == b.imu.rate_hz);
  CHECK(a.imu.gravity_magnitude == b.imu.gravity_magnitude);
  CHECK(a.imu.noise.gyroscope_noise_density == b.imu.noise.gyroscope_noise_density);
  CHECK(a.imu.noise.gyroscope_random_walk == b.imu.noise.gyroscope_random_walk);
  CHECK(a.imu.noise.accelerometer_noise_density == b.imu.noise.accelerometer_noise_density);
  CHECK(a.imu.noise.accelerometer_random_walk == b.imu.noise.accelerometer_random_walk);
}

TEST_CASE("calibration export: rig YAML round trip, one file per mission", "[calibration_export]") {
  VIMap map = mapstore::testing::MakeSyntheticMap({});
  // Make the second mission's rig differ: an equidistant camera, another time offset and IMU.
  SensorRig& rig1 = map.mission(map.mission_ids()[1]).rig;
  rig1.cameras[1].camera = testing::ProjectedMapCamera(DistortionModel::kEquidistant);
  rig1.cameras[1].time_offset_ns = -1234567;
  rig1.imu.rate_hz = 400.0;
  rig1.imu.noise.gyroscope_noise_density = 1.7e-4;
  const std::string dir = ScratchFolder("calib");
  CalibrationExportOptions options;
  options.out = dir + "/rigs/";  // a folder (created)
  const CalibrationExportSummary summary = ExportCalibrations(map, options);
  REQUIRE(summary.files.size() == 2);
  for (std::size_t m = 0; m < 2; ++m) {
    const mapstore::MissionId& id = map.mission_ids()[m];
    REQUIRE(summary.files[m].path == dir + "/rigs/rig_" + id.Hex() + ".yaml");
    REQUIRE(summary.files[m].cameras == 2);
    RequireSameRig(LoadSensorRig(summary.files[m].path), map.mission(id).rig);
  }
  // One mission into a file name.
  options.out = dir + "/one.yaml";
  options.missions = {map.mission_ids()[1]};
  const CalibrationExportSummary one = ExportCalibrations(map, options);
  REQUIRE(one.files.size() == 1);
  REQUIRE(one.files[0].path == dir + "/one.yaml");
  RequireSameRig(LoadSensorRig(dir + "/one.yaml"), rig1);
  REQUIRE(one.BriefReport().find("T_I_C") != std::string::npos);
}

TEST_CASE("calibration export: a mission without rig or with an invalid one is refused",
          "[calibration_export]") {
  VIMap map = mapstore::testing::MakeSyntheticMap({});
  const std::string dir = ScratchFolder("calib_bad");
  CalibrationExportOptions options;
  REQUIRE_THROWS_WITH(ExportCalibrations(map, options), Catch::Contains("out: expected"));
  options.out = dir;
  map.mission(map.mission_ids()[1]).rig.cameras.clear();
  REQUIRE_THROWS_WITH(ExportCalibrations(map, options),
                      Catch::Contains("expected a recorded sensor rig"));
  REQUIRE(std::filesystem::is_empty(dir));  // the first mission's rig was not written either
  map.mission(map.mission_ids()[1]).rig = mapstore::testing::TestRig();
  map.mission(map.mission_ids()[1]).rig.imu.rate_hz = -1.0;
  REQUIRE_THROWS_WITH(ExportCalibrations(map, options), Catch::Contains("rig.imu"));
}

}  // namespace
}  // namespace vilma::mapping
