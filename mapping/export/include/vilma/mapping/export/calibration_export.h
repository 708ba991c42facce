// export_ncamera_calibration (maplab's `encc`): each mission's sensor rig (cameras with
// intrinsics, distortion and extrinsics T_I_C, the IMU with its noise) as vilma's rig YAML
// (docs/formats.md "Sensor rig"), the file that `vilma-estimatord --rig`, `vilma vio --rig` and
// core/rig.h's LoadSensorRig read. The extrinsics are T_I_C (camera in the IMU frame), not a
// map frame: a rig has no G or M.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "vilma/mapstore/vi_map.h"

namespace vilma::mapping {

struct CalibrationExportOptions {
  // A .yaml file, or a folder (existing, or ending in '/'); several missions give one file each
  // (docs/export.md "Output paths": rig.yaml / rig_<mission id>.yaml).
  std::string out;
  // Missions to export; empty: every mission of the map.
  std::vector<mapstore::MissionId> missions;

  // "field: expectation", or "" when valid.
  std::string Validate() const;
};

struct CalibrationExportFile {
  mapstore::MissionId mission_id;
  std::string path;
  std::size_t cameras = 0;
};

struct CalibrationExportSummary {
  std::vector<CalibrationExportFile> files;
  std::string BriefReport() const;  // one line: counts and where it went
  std::string FullReport() const;   // the brief line and the details (what the command prints)
};

// Writes each mission's rig YAML atomically, after checking every rig (nothing is written when
// one fails). Throws InputError when a mission has no rig recorded (no camera) or an invalid
// one (SensorRig::Validate), naming the mission; and for an unwritable path.
CalibrationExportSummary ExportCalibrations(const mapstore::VIMap& map,
                                            const CalibrationExportOptions& options);

}  // namespace vilma::mapping
