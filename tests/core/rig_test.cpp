#include "vilma/core/rig.h"

#include <catch2/catch.hpp>
#include <fstream>

#include "core/test_data.h"
#include "vilma/core/error.h"

namespace vilma {
namespace {

const char* kValidRig = R"(
imu:
  name: imu0
  rate_hz: 200
  gyroscope_noise_density: 1.6968e-04
  gyroscope_random_walk: 1.9393e-05
  accelerometer_noise_density: 2.0e-3
  accelerometer_random_walk: 3.0e-3
cameras:
  - name: cam0
    rate_hz: 20
    resolution: [752, 480]
    intrinsics: [458.654, 457.296, 367.215, 248.375]
    distortion_model: radtan
    distortion_coefficients: [-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05]
    T_I_C:
      - [0.0148655429818, -0.999880929698, 0.00414029679422, -0.0216401454975]
      - [0.999557249008, 0.0149672133247, 0.025715529948, -0.064676986768]
      - [-0.0257744366974, 0.00375618835797, 0.999660727178, 0.00981073058949]
      - [0.0, 0.0, 0.0, 1.0]
)";

// Replaces the first occurrence of `from` in the valid rig.
std::string Mutate(const std::string& from, const std::string& to) {
  std::string text = kValidRig;
  const auto pos = text.find(from);
  REQUIRE(pos != std::string::npos);
  text.replace(pos, from.size(), to);
  return text;
}

std::string ErrorOf(const std::string& yaml) {
  try {
    ParseSensorRig(yaml, "rig.yaml");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST_CASE("A valid rig parses with all fields", "[rig]") {
  const SensorRig rig = ParseSensorRig(kValidRig, "rig.yaml");
  REQUIRE(rig.cameras.size() == 1);
  CHECK(rig.Validate().empty());
  CHECK(rig.imu.rate_hz == 200.0);
  CHECK(rig.imu.noise.accelerometer_random_walk == Approx(3.0e-3));
  CHECK(rig.imu.gravity_magnitude == Approx(9.81));
  const CameraConfig& cam = rig.cameras[0];
  CHECK(cam.name == "cam0");
  CHECK(cam.camera.width() == 752);
  CHECK(cam.camera.height() == 480);
  CHECK(cam.camera.fx() == Approx(458.654));
  CHECK(cam.camera.distortion_model() == DistortionModel::kRadTan);
  CHECK(cam.time_offset_ns == 0);
  CHECK(cam.T_I_C.translation().x() == Approx(-0.0216401454975));
}

TEST_CASE("Each bad rig input gets a message naming file, key and expectation", "[rig]") {
  struct Case {
    const char* what;
    std::string yaml;
    std::vector<std::string> expected_parts;
  };
  const std::vector<Case> cases = {
      {"wrong type", Mutate("rate_hz: 200", "rate_hz: fast"),
       {"rig.yaml", "imu.rate_hz", "a number", "'fast'"}},
      {"missing key", Mutate("  gyroscope_random_walk: 1.9393e-05\n", ""),
       {"rig.yaml", "imu.gyroscope_random_walk", "required"}},
      {"negative noise density", Mutate("2.0e-3", "-2.0e-3"),
       {"rig.yaml", "imu.accelerometer_noise_density", ">= 0"}},
      {"non-orthonormal rotation", Mutate("0.999557249008", "0.9"),
       {"rig.yaml", "cameras[0].T_I_C", "orthonormal"}},
      {"bad last row", Mutate("[0.0, 0.0, 0.0, 1.0]", "[0.0, 0.0, 1.0, 1.0]"),
       {"rig.yaml", "cameras[0].T_I_C", "0 0 0 1"}},
      {"unknown key", Mutate("    rate_hz: 20\n", "    rate_hz: 20\n    exposure: 3\n"),
       {"rig.yaml", "cameras[0].exposure", "unknown key"}},
      {"unknown distortion", Mutate("distortion_model: radtan", "distortion_model: fov"),
       {"rig.yaml", "cameras[0].distortion_model", "'fov'"}},
      {"coefficient count", Mutate(", 1.76187114e-05]", "]"),
       {"rig.yaml", "cameras[0].distortion_coefficients", "4 numbers", "3 elements"}},
      {"matrix shape", Mutate("      - [0.0, 0.0, 0.0, 1.0]\n", ""),
       {"rig.yaml", "cameras[0].T_I_C", "4x4"}},
      {"zero focal length", Mutate("458.654", "0"), {"rig.yaml", "cameras[0].intrinsics"}},
      {"resolution", Mutate("[752, 480]", "[752.5, 480]"),
       {"rig.yaml", "cameras[0].resolution", "whole numbers"}},
      // Found by fuzz_rig_yaml: converting 1.1e18 to int was undefined behaviour.
      {"huge resolution", Mutate("[752, 480]", "[1.11111e18, 480]"),
       {"rig.yaml", "cameras[0].resolution", "from 1 to 65535"}},
      {"no cameras section", Mutate("cameras:", "camerass:"), {"rig.yaml", "cameras"}},
      {"invalid yaml", Mutate("rate_hz: 200", "rate_hz: [200"), {"rig.yaml", "valid YAML"}},
  };
  for (const Case& c : cases) {
    INFO(c.what);
    const std::string message = ErrorOf(c.yaml);
    INFO(message);
    REQUIRE_FALSE(message.empty());
    for (const std::string& part : c.expected_parts) CHECK_THAT(message, Catch::Contains(part));
  }
}

TEST_CASE("A missing rig file is named in the error", "[rig]") {
  CHECK_THROWS_WITH(LoadSensorRig("/nonexistent/rig.yaml"),
                    Catch::Contains("/nonexistent/rig.yaml") && Catch::Contains("cannot open"));
}

TEST_CASE("Save then load gives the same rig", "[rig]") {
  SensorRig rig = ParseSensorRig(kValidRig, "rig.yaml");
  rig.cameras.push_back(rig.cameras[0]);
  rig.cameras[1].name = "cam1";
  rig.cameras[1].time_offset_ns = -1234567;
  rig.cameras[1].camera = Camera(640, 480, Eigen::Vector4d(380, 381, 320.5, 239.5),
                                 DistortionModel::kEquidistant,
                                 Eigen::Vector4d(0.01, -0.002, 0.0003, -0.00004));
  rig.imu.gravity_magnitude = 9.80665;
  testing::TempDir dir;
  SaveSensorRig(rig, dir.File("rig.yaml"));
  const SensorRig loaded = LoadSensorRig(dir.File("rig.yaml"));
  REQUIRE(loaded.cameras.size() == 2);
  CHECK(loaded.imu.gravity_magnitude == rig.imu.gravity_magnitude);
  CHECK(loaded.imu.noise.gyroscope_random_walk == rig.imu.noise.gyroscope_random_walk);
  for (std::size_t i = 0; i < 2; ++i) {
    const CameraConfig& a = rig.cameras[i];
    const CameraConfig& b = loaded.cameras[i];
    CHECK(a.name == b.name);
    CHECK(a.time_offset_ns == b.time_offset_ns);
    CHECK(a.camera.intrinsics() == b.camera.intrinsics());
    CHECK(a.camera.distortion_model() == b.camera.distortion_model());
    CHECK(a.camera.distortion_coefficients() == b.camera.distortion_coefficients());
    CHECK((a.T_I_C.matrix() - b.T_I_C.matrix()).cwiseAbs().maxCoeff() < 1e-15);
  }
}

TEST_CASE("EuRoC sensor.yaml files import into a rig and write back", "[rig]") {
  const std::string euroc = testing::EurocMicroDir();
  VILMA_REQUIRE_SHARED_DATA(euroc);
  const SensorRig rig = ImportEurocRig(euroc);
  REQUIRE(rig.cameras.size() == 2);
  CHECK(rig.cameras[0].name == "cam0");
  CHECK(rig.cameras[1].name == "cam1");
  CHECK(rig.imu.noise.gyroscope_noise_density == Approx(1.6968e-04));
  CHECK(rig.cameras[0].T_I_C.translation().x() == Approx(-0.0216401454975));
  // The VI-sensor's stereo baseline is about 11 cm.
  const Transformation T_C0_C1 = rig.cameras[0].T_I_C.inverse() * rig.cameras[1].T_I_C;
  CHECK(T_C0_C1.translation().norm() == Approx(0.110).margin(0.002));

  testing::TempDir dir;
  WriteEurocSensorYamls(rig, dir.File("mav0"));
  const SensorRig again = ImportEurocRig(dir.path());
  REQUIRE(again.cameras.size() == 2);
  CHECK((again.cameras[1].T_I_C.matrix() - rig.cameras[1].T_I_C.matrix()).norm() < 1e-12);
  CHECK(again.cameras[1].camera.distortion_coefficients() ==
        rig.cameras[1].camera.distortion_coefficients());
}

TEST_CASE("Validate rejects rigs built in code with bad values", "[rig]") {
  SensorRig rig = ParseSensorRig(kValidRig, "rig.yaml");
  rig.imu.noise.gyroscope_noise_density = -1.0;
  CHECK_THAT(rig.Validate(), Catch::Contains("imu.gyroscope_noise_density"));
  rig = ParseSensorRig(kValidRig, "rig.yaml");
  rig.cameras.push_back(rig.cameras[0]);
  CHECK_THAT(rig.Validate(), Catch::Contains("unique"));
  rig.cameras.clear();
  CHECK_THAT(rig.Validate(), Catch::Contains("at least one camera"));
}

}  // namespace
}  // namespace vilma
