#include "vilma/mapping/export/calibration_export.h"

#include <sstream>

#include "export_files.h"
#include "vilma/core/asl_dataset.h"
#include "vilma/core/error.h"
#include "vilma/core/rig.h"

namespace vilma::mapping {

using mapstore::MissionId;

std::string CalibrationExportOptions::Validate() const {
  if (out.empty()) return "out: expected the path of a .yaml file or a folder to write";
  return "";
}

std::string CalibrationExportSummary::BriefReport() const {
  const std::string full = FullReport();
  return full.substr(0, full.find('\n'));
}

std::string CalibrationExportSummary::FullReport() const {
  std::ostringstream s;
  s << "calibration: " << files.size() << (files.size() == 1 ? " rig" : " rigs")
    << " (vilma rig YAML, extrinsics T_I_C)\n";
  for (const CalibrationExportFile& f : files) {
    s << "  " << f.mission_id.Hex().substr(0, 8) << " " << f.cameras
      << (f.cameras == 1 ? " camera -> " : " cameras -> ") << f.path << "\n";
  }
  return s.str();
}

CalibrationExportSummary ExportCalibrations(const mapstore::VIMap& map,
                                            const CalibrationExportOptions& options) {
  ThrowIfInvalid(options.Validate(), "export_ncamera_calibration");
  const std::vector<MissionId> missions =
      export_files::MissionsToExport(map, options.missions, "mission");
  std::vector<std::string> texts;
  CalibrationExportSummary summary;
  for (const MissionId& id : missions) {
    const SensorRig& rig = map.mission(id).rig;
    const std::string where = "mission " + id.Hex();
    if (rig.cameras.empty()) {
      throw InputError(
          FormatInputError(where, "rig", "expected a recorded sensor rig (it has no camera)"));
    }
    ThrowIfInvalid(rig.Validate(), where, "rig");
    texts.push_back(SensorRigToYaml(rig));
    CalibrationExportFile file;
    file.mission_id = id;
    file.cameras = rig.cameras.size();
    summary.files.push_back(file);
  }
  const std::vector<std::string> paths =
      export_files::PerMissionFiles(options.out, "out", missions, "rig", ".yaml");
  for (std::size_t i = 0; i < paths.size(); ++i) {
    WriteFileAtomically(paths[i], texts[i]);
    summary.files[i].path = paths[i];
  }
  return summary;
}

}  // namespace vilma::mapping
