#include "vilma/console/map_from_poses_command.h"

#include <filesystem>
#include <iomanip>
#include <stdexcept>

#include "vilma/console/command.h"
#include "vilma/core/error.h"
#include "vilma/core/rig.h"
#include "vilma/core/strict_parse.h"
#include "vilma/eval/trajectory.h"
#include "vilma/mapping/from_poses/map_from_poses.h"
#include "vilma/mapstore/consistency.h"
#include "vilma/mapstore/map_io.h"

namespace vilma::console {
namespace {

namespace fs = std::filesystem;

void PrintHelp(std::ostream& out) {
  const mapping::MapFromPosesOptions d;
  out << "usage: vilma map-from-poses DATASET --out MAP_DIR [--poses TRAJ | --poses gt]\n"
         "                              [--rig RIG.yaml] [--every N] [--max-frames N]\n"
         "                              [--perturb METERS,DEGREES] [--seed N] [--name NAME]\n"
         "\n"
         "Builds a one-mission VI-map from an ASL dataset and a given trajectory of the IMU\n"
         "(body) frame: BRISK features per image, stereo matches checked by the rig's epipolar\n"
         "geometry, wide-baseline matches between vertices checked by an essential-matrix\n"
         "RANSAC, tracks, landmarks triangulated with the given poses (quality by the elq\n"
         "rules), IMU edges from the dataset's IMU. Frames need not be consecutive video\n"
         "(docs/map-from-poses.md). The mission frame M is the trajectory's world frame.\n"
         "\n"
         "  --poses TRAJ     TUM or EuRoC CSV trajectory of the IMU frame; `gt` (default): the\n"
         "                   dataset's mav0/state_groundtruth_estimate0/data.csv\n"
         "  --rig RIG.yaml   sensor rig (default: imported from the dataset's sensor.yaml files)\n"
         "  --every N        every N-th frame (default " << d.every_nth_frame << ")\n"
         "  --max-frames N   at most N vertices (default: all)\n"
         "  --perturb M,D    move each vertex by M meters and D degrees in random directions\n"
         "                   (seeded; the optimization benchmarks start from ground truth so\n"
         "                   perturbed; default 0,0)\n"
         "  --seed N         seed of the perturbation and of RANSAC (default " << d.seed << ")\n"
         "  --name NAME      mission name (default: the dataset folder's name)\n"
         "  --out MAP_DIR    the map folder (must not hold a map yet)\n"
         "\n"
         "exit codes: 0 ok, 1 input error, 2 usage error\n";
}

}  // namespace

int RunMapFromPosesCommand(const std::vector<std::string>& args, std::ostream& out,
                           std::ostream& err) {
  std::string dataset, poses = "gt", rig_path, out_dir;
  mapping::MapFromPosesOptions options;
  try {
    for (ArgCursor arg(args); arg.Next();) {
      const std::string& name = arg.name();
      if (name == "--help" || name == "-h") {
        PrintHelp(out);
        return kExitOk;
      } else if (name == "--poses") {
        poses = arg.Value();
      } else if (name == "--rig") {
        rig_path = arg.Value();
      } else if (name == "--out") {
        out_dir = arg.Value();
      } else if (name == "--every") {
        options.every_nth_frame = arg.IntValue();
      } else if (name == "--max-frames") {
        options.max_frames = arg.IntValue();
      } else if (name == "--seed") {
        options.seed = static_cast<uint64_t>(arg.Int64Value(0));
      } else if (name == "--name") {
        options.mission_name = arg.Value();
      } else if (name == "--perturb") {
        const std::string v = arg.Value();
        const std::size_t comma = v.find(',');
        if (comma == std::string::npos) throw UsageError("--perturb: expected METERS,DEGREES");
        try {
          options.perturb_translation_m = ParseStrictDouble(v.substr(0, comma));
          options.perturb_rotation_deg = ParseStrictDouble(v.substr(comma + 1));
        } catch (const std::invalid_argument&) {
          throw UsageError("--perturb: expected METERS,DEGREES (two numbers), got '" + v + "'");
        }
      } else if (arg.is_option()) {
        throw UsageError("unknown option " + arg.word());
      } else if (dataset.empty()) {
        dataset = arg.word();
      } else {
        throw UsageError("unexpected argument " + arg.word());
      }
    }
    if (dataset.empty()) throw UsageError("expected a DATASET folder");
    if (out_dir.empty()) throw UsageError("--out: expected the map folder to write");
    const std::string problem = options.Validate();
    if (!problem.empty()) throw UsageError(problem);
  } catch (const UsageError& e) {
    err << "vilma map-from-poses: " << e.what() << " (see --help)\n";
    return kExitUsage;
  }
  try {
    std::error_code ec;
    if (fs::exists(out_dir, ec) && !fs::is_empty(out_dir, ec)) {
      throw InputError(FormatInputError(out_dir, "--out", "a folder that does not exist yet or is empty"));
    }
    const SensorRig rig = rig_path.empty() ? ImportEurocRig(dataset) : LoadSensorRig(rig_path);
    const std::string poses_path =
        poses == "gt" ? dataset + "/mav0/state_groundtruth_estimate0/data.csv" : poses;
    const Trajectory trajectory = ReadTrajectoryFile(poses_path);
    mapping::MapFromPosesSummary summary;
    const mapstore::VIMap map =
        mapping::BuildMapFromPoses(dataset, rig, trajectory, options, &summary);
    const mapstore::ConsistencyReport report = mapstore::CheckMapConsistency(map);
    if (!report.ok()) {
      err << "vilma map-from-poses: internal error, the map is not consistent:\n"
          << report.FullReport();
      return kExitInputError;
    }
    mapstore::SaveMap(map, out_dir);
    out << summary.FullReport() << "saved to " << out_dir << "\n";
    return kExitOk;
  } catch (const InputError& e) {
    err << "vilma map-from-poses: " << e.what() << "\n";
    return kExitInputError;
  }
}

}  // namespace vilma::console
