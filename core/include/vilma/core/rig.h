// Sensor rig: cameras and one IMU, with extrinsics T_I_C (camera in IMU frame) and the
// camera-IMU time offset. YAML format: docs/formats.md ("Sensor rig"); EuRoC/Kalibr
// `sensor.yaml` files can be imported.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "vilma/core/camera.h"
#include "vilma/core/geometry.h"
#include "vilma/core/imu.h"

namespace vilma {

struct CameraConfig {
  std::string name = "cam0";
  double rate_hz = 20.0;
  Camera camera;
  Transformation T_I_C;
  // Camera time shift: t_imu = t_cam + time_offset_ns (Kalibr's timeshift_cam_imu sign).
  int64_t time_offset_ns = 0;
};

struct ImuConfig {
  std::string name = "imu0";
  double rate_hz = 200.0;
  ImuNoise noise;
  double gravity_magnitude = kDefaultGravityMagnitude;  // [m/s^2]
};

struct SensorRig {
  std::vector<CameraConfig> cameras;
  ImuConfig imu;

  // Empty if valid, otherwise the first problem as "field: expectation".
  std::string Validate() const;
  // Index of the camera with this name, or -1.
  int CameraIndex(const std::string& name) const;
};

// Loads a vilma rig YAML; throws InputError naming the file, key and expectation.
SensorRig LoadSensorRig(const std::string& path);
SensorRig ParseSensorRig(const std::string& yaml_text, const std::string& source_name);
// Writes a vilma rig YAML atomically (temporary file + rename); throws InputError on I/O error.
void SaveSensorRig(const SensorRig& rig, const std::string& path);
std::string SensorRigToYaml(const SensorRig& rig);

// Imports an EuRoC/ASL `mav0` folder's sensor.yaml files (cam*/sensor.yaml, imu0/sensor.yaml):
// T_I_C = T_B_I^-1 T_B_C from their T_BS entries. `dataset_root` is the folder that holds
// `mav0/` or the `mav0` folder itself.
SensorRig ImportEurocRig(const std::string& dataset_root);

// Writes EuRoC-style sensor.yaml files for the rig into `mav0_dir` (cam<i>/sensor.yaml,
// imu0/sensor.yaml) with the IMU as body frame (T_BS of the IMU is identity).
void WriteEurocSensorYamls(const SensorRig& rig, const std::string& mav0_dir);

}  // namespace vilma
