// `vilma`: the offline command, a dispatcher over subcommands (`vilma <subcommand> ...`).
// New subcommands are one row in kSubcommands; each one parses its own arguments and returns
// an exit code (console/command.h: 0 ok, 1 input error, 2 usage error).
#include <algorithm>
#include <cstring>
#include <exception>
#include <iostream>
#include <string>
#include <vector>

#include "vilma/console/command.h"
#include "vilma/console/console_main.h"
#include "vilma/console/eval_command.h"
#include "vilma/console/dense_kitti_command.h"
#include "vilma/console/kitti_command.h"
#include "vilma/console/localize_command.h"
#include "vilma/console/locmap_command.h"
#include "vilma/console/map_from_poses_command.h"
#include "vilma/console/rig_command.h"
#include "vilma/console/vio_command.h"

namespace {

using vilma::console::CommandFunction;

struct Subcommand {
  const char* name;
  const char* summary;  // one line for `vilma --help`
  CommandFunction run;
};

const Subcommand kSubcommands[] = {
    {"console", "the map console: load, merge, optimize, keyframe, export maps (interactive or batch)",
     &vilma::console::RunConsoleCommand},
    {"dense-kitti", "dense reconstruction of a KITTI stereo slice with its poses (SGBM, TSDF, PLY mesh)",
     &vilma::console::RunDenseKittiCommand},
    {"eval", "trajectory error (ATE, RPE) of an estimate against ground truth",
     &vilma::console::RunEvalCommand},
    {"localize", "offline map check: localize every Nth frame of a dataset against a map",
     &vilma::console::RunLocalizeCommand},
    {"localize-kitti", "localization check on a KITTI stereo slice (map: even frames, query: odd)",
     &vilma::console::RunKittiCommand},
    {"locmap", "localization maps: build a .vlocmap from a VI-map folder, print a file's summary",
     &vilma::console::RunLocmapCommand},
    {"map-from-poses", "a VI-map from an ASL dataset and given poses (keyframes, stereo, wide baselines)",
     &vilma::console::RunMapFromPosesCommand},
    {"rig", "sensor rig files: import EuRoC/Kalibr calibrations, check a rig YAML",
     &vilma::console::RunRigCommand},
    {"vio", "visual-inertial odometry (ROVIO-style filter) over an ASL dataset folder",
     &vilma::console::RunVioCommand},
};

void PrintUsage(std::ostream& out) {
  out << "usage: vilma <subcommand> [options]\n"
         "       vilma <subcommand> --help\n"
         "\n"
         "subcommands:\n";
  for (const Subcommand& s : kSubcommands) {
    std::string name = s.name;
    name.resize(std::max<std::size_t>(name.size() + 2, 12), ' ');
    out << "  " << name << s.summary << "\n";
  }
  out << "\nexit codes: 0 ok, 1 input error, 2 usage error\n";
}

const Subcommand* Find(const std::string& name) {
  for (const Subcommand& s : kSubcommands) {
    if (name == s.name) return &s;
  }
  return nullptr;
}

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    PrintUsage(std::cerr);
    return vilma::console::kExitUsage;
  }
  const std::string first = argv[1];
  if (first == "--help" || first == "-h") {
    PrintUsage(std::cout);
    return vilma::console::kExitOk;
  }
  std::vector<std::string> args(argv + 2, argv + argc);
  std::string name = first;
  if (first == "help") {  // `vilma help eval` == `vilma eval --help`
    if (args.empty()) {
      PrintUsage(std::cout);
      return vilma::console::kExitOk;
    }
    name = args[0];
    args = {"--help"};
  }
  const Subcommand* command = Find(name);
  if (command == nullptr) {
    std::cerr << "vilma: unknown subcommand '" << name << "'\n\n";
    PrintUsage(std::cerr);
    return vilma::console::kExitUsage;
  }
  try {
    return command->run(args, std::cout, std::cerr);
  } catch (const std::exception& e) {  // subcommands catch their own; this is the backstop
    std::cerr << "vilma " << name << ": error: " << e.what() << "\n";
    return vilma::console::kExitInputError;
  }
}
