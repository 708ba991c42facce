// Camera-IMU calibration on a known target (docs/optimization.md "Target calibration"):
// load_target_recording / ltr builds a VI-map from a recording of detected target corners and
// the IMU (mapping/from_poses/map_from_target.h); optvi with the corners held estimates the
// trajectory, T_I_C and the time offset; target_calibration_report / tcr compares the result
// with per-frame PnP and with a reference calibration.
#include <cmath>
#include <iomanip>

#include "vilma/console/command_registry.h"
#include "vilma/core/error.h"
#include "vilma/core/rig.h"
#include "vilma/mapping/from_poses/map_from_target.h"
#include "vilma/mapping/inspection/map_statistics.h"

namespace vilma::console {
namespace {

struct LoadTargetOptions : mapping::MapFromTargetOptions {
  std::string recording;  // folder with imu0.csv and one folder per camera
  std::string rig;        // vilma rig YAML (cameras named as the recording's folders)
  std::string map_key = "target";
  double camera_time_shift_ms = 0.0;
  std::string Validate() const {
    if (recording.empty()) return "recording: expected the recording's folder";
    if (rig.empty()) return "rig: expected a rig YAML (e.g. config/euroc-rig.yaml)";
    if (!std::isfinite(camera_time_shift_ms) || std::abs(camera_time_shift_ms) > 1000.0) {
      return "camera_time_shift_ms: expected a shift within +-1000 ms";
    }
    return mapping::MapFromTargetOptions::Validate();
  }
};

struct TargetReportOptions {
  std::string reference_rig;   // rig YAML to compare T_I_C with ("": none)
  double time_offset_ms = 0.0; // the estimated offset (optvi's report) the poses are carried by
  int min_corners = 12;
  std::string map_mission;     // "" = the first mission
  std::string Validate() const {
    if (min_corners < 4) return "min_corners: expected >= 4";
    if (!std::isfinite(time_offset_ms)) return "time_offset_ms: expected a finite number";
    return "";
  }
};

void LoadTarget(CommandContext& c, const LoadTargetOptions& o) {
  mapping::MapFromTargetOptions options = o;
  options.camera_time_shift_ns = std::llround(o.camera_time_shift_ms * 1e6);
  mapping::MapFromTargetSummary summary;
  mapstore::VIMap map;
  try {
    const SensorRig rig = LoadSensorRig(o.rig);
    map = mapping::BuildMapFromTarget(o.recording, rig, options, &summary);
  } catch (const InputError& e) {
    throw CommandError(e.what());
  }
  c.out() << summary.FullReport();
  if (c.maps().Has(o.map_key)) c.maps().Remove(o.map_key);
  c.maps().Add(o.map_key, std::move(map), "");
  c.maps().Select(o.map_key);
  c.out() << "loaded as " << o.map_key << "\n";
}

void Report(CommandContext& c, const TargetReportOptions& o) {
  const mapstore::VIMap& map = c.map();
  const std::vector<mapstore::MissionId> missions =
      o.map_mission.empty() ? map.mission_ids() : mapping::ResolveMissions(map, o.map_mission);
  if (missions.empty()) throw CommandError("the map has no mission");
  const mapstore::MissionId mission = missions.front();
  const mapstore::Mission& m = map.mission(mission);
  std::ostream& out = c.out();
  out << std::fixed;
  for (uint32_t cam = 0; cam < m.rig.cameras.size(); ++cam) {
    const mapping::TargetPnpComparison p =
        mapping::CompareWithTargetPnp(map, mission, cam, 1e-3 * o.time_offset_ms, o.min_corners);
    out << "camera " << cam << " (" << m.rig.cameras[cam].name << "): " << p.FullReport();
  }
  if (!o.reference_rig.empty()) {
    SensorRig reference;
    try {
      reference = LoadSensorRig(o.reference_rig);
    } catch (const InputError& e) {
      throw CommandError(e.what());
    }
    for (const CameraConfig& camera : m.rig.cameras) {
      const int r = reference.CameraIndex(camera.name);
      if (r < 0) {
        out << "camera " << camera.name << ": not in " << o.reference_rig << "\n";
        continue;
      }
      const Transformation& T_ref = reference.cameras[static_cast<std::size_t>(r)].T_I_C;
      out << "camera " << camera.name << ": T_I_C vs " << o.reference_rig << ": rotation "
          << std::setprecision(3)
          << AngleBetween(camera.T_I_C.rotation(), T_ref.rotation()) * 180.0 / M_PI
          << " deg, translation " << std::setprecision(2)
          << 1000.0 * (camera.T_I_C.translation() - T_ref.translation()).norm() << " mm ("
          << std::setprecision(2) << 1000.0 * (camera.T_I_C.translation() - T_ref.translation()).x()
          << ", " << 1000.0 * (camera.T_I_C.translation() - T_ref.translation()).y() << ", "
          << 1000.0 * (camera.T_I_C.translation() - T_ref.translation()).z() << ")\n";
    }
  }
  out << std::defaultfloat;
}

void Register(CommandRegistry* registry) {
  registry->Add(
      Command<LoadTargetOptions>("load_target_recording")
          .Alias("ltr")
          .Group("maps")
          .Summary("a VI-map from a camera-IMU recording of a known target (corners held as "
                   "landmarks; then optvi estimates T_I_C and the time offset)")
          .PathFlag("recording", &LoadTargetOptions::recording,
                    "folder: imu0.csv and <camera>/<ts>.csv corner detections")
          .PathFlag("rig", &LoadTargetOptions::rig, "rig YAML (cameras named as the folders)")
          .Flag("map_key", &LoadTargetOptions::map_key, "key of the new map")
          .Flag("min_corners", &LoadTargetOptions::min_corners,
                "skip first-camera images with fewer corners")
          .Flag("max_pnp_rmse_px", &LoadTargetOptions::max_pnp_rmse_px,
                "skip images whose PnP fits worse [px]")
          .Flag("every_nth_image", &LoadTargetOptions::every_nth_image, "every n-th image")
          .Flag("max_duration_s", &LoadTargetOptions::max_duration_s,
                "only the first seconds (0: all)")
          .Flag("camera_time_shift_ms", &LoadTargetOptions::camera_time_shift_ms,
                "added to every camera stamp (a known offset injected) [ms]")
          .Flag("perturb_extrinsics_m", &LoadTargetOptions::perturb_extrinsics_m,
                "move the rig's extrinsics by this translation [m]")
          .Flag("perturb_extrinsics_deg", &LoadTargetOptions::perturb_extrinsics_deg,
                "and this rotation [deg] (seeded directions)")
          .Flag("seed", &LoadTargetOptions::seed, "seed of the perturbation's directions")
          .Positional("recording")
          .Access(MapAccess::kNone)
          .Run(LoadTarget));
  registry->Add(
      Command<TargetReportOptions>("target_calibration_report")
          .Alias("tcr")
          .Group("optimization")
          .Summary("a target map's camera poses against per-frame PnP, T_I_C against a "
                   "reference rig")
          .PathFlag("reference_rig", &TargetReportOptions::reference_rig,
                    "rig YAML to compare T_I_C with")
          .Flag("time_offset_ms", &TargetReportOptions::time_offset_ms,
                "the estimated time offset (optvi's report): poses carried over it [ms]")
          .Flag("min_corners", &TargetReportOptions::min_corners, "frames with this many corners")
          .Flag("map_mission", &TargetReportOptions::map_mission, "mission (default: the first)",
                {"mission"})
          .Access(MapAccess::kRead)
          .Run(Report));
}

}  // namespace
}  // namespace vilma::console

VILMA_CONSOLE_COMMANDS(vilma::console::Register)
