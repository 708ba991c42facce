// `vilma vio`: runs the visual-inertial odometry filter (estimator/vio_filter.h) offline over
// an ASL dataset folder, single-threaded and deterministically.
//
//   vilma vio DATASET [--config FILE] [--rig RIG.yaml] [--camera INDEX] --out TRAJ.txt
//             [--log-timing FILE] [--log-state FILE] [--save-map DIR [--map-config FILE]]
//             [--initial-state GT_FILE] [--stereo [--stereo-camera INDEX]]
//
// Rig: --rig, else DATASET/rig.yaml if present (the simulator writes one), else the EuRoC
// sensor.yaml files of DATASET. Writes T_M_I of every frame as TUM text (t in seconds, IMU
// clock) and prints a timing summary (ms per frame p50/p99, real-time factor).
// --save-map DIR also builds a VI-map mission while the filter runs (mapping/map_builder.h:
// vertices with the filter's state at the vertex rate, keyframe features of every rig camera
// whose images the dataset has, IMU edges, landmarks at the end), saves it as a map folder and
// prints the builder's statistics and the consistency check.
#pragma once

#include <ostream>
#include <string>
#include <vector>

#include "vilma/console/command.h"

namespace vilma::console {

struct VioCommandOptions {
  std::string dataset;          // positional, required
  std::string config_path;      // --config over the profile below (absent keys: the profile's)
  // --profile: built-in filter options (estimator::FilterOptionsProfile), the base of --config:
  // "auto" = "euroc" for a dataset whose rig comes from its EuRoC sensor.yaml files (a real
  // EuRoC/ASL recording: no rig.yaml, no --rig), else "default".
  std::string profile = "auto";
  std::string rig_path;         // --rig
  int camera = 0;               // --camera
  std::string out_path;         // --out, required
  std::string timing_path;      // --log-timing, empty: none
  std::string state_path;       // --log-state, empty: none
  bool print_config = false;    // --print-config: print the effective options
  std::string save_map_dir;     // --save-map, empty: no map
  // --map-config, empty: built-in defaults (= config/map_builder.yaml)
  std::string map_config_path;
  // --initial-state, empty: initialize from the sensors (static or moving start)
  std::string initial_state_path;
  bool stereo = false;           // --stereo: stereo.enabled = true
  int stereo_camera = -1;        // --stereo-camera, -1: the config's stereo.camera
  bool help = false;
};

// Throws UsageError.
VioCommandOptions ParseVioArgs(const std::vector<std::string>& args);
void PrintVioHelp(std::ostream& out);
int RunVioCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace vilma::console
