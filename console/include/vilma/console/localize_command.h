// `vilma localize`: offline check of a localization map against a recorded session
// (docs/localizer.md, "Command line").
//
//   vilma localize DATASET MAP [--every N] [--camera C] [--rig RIG.yaml]
//                  [--config localizer.yaml] [--features FEATURES.yaml]
//                  [--align none|posyaw|se3 | --align-from ALIGNMENT.json] [--out RESULTS.csv]
//                  [--quiet]
//
// Every Nth image of camera C of an ASL dataset is localized against MAP (a .vlocmap file or a
// VI-map folder) with the query feature profile of vilma-estimatord; prints one line per query
// and a summary (status counts, recall, errors against ground truth when the dataset has it,
// query times). Single-threaded and deterministic (timings aside).
#pragma once

#include <ostream>
#include <string>
#include <vector>

#include "vilma/console/command.h"
#include "vilma/eval/evaluate.h"

namespace vilma::console {

struct LocalizeCommandOptions {
  std::string dataset;
  std::string map;            // .vlocmap file or VI-map folder
  std::string rig_path;       // "": DATASET/rig.yaml, else the EuRoC sensor.yaml files
  std::string config_path;    // "": built-in localizer defaults
  std::string features_path;  // "": localizer::LocalizationQueryFeatureOptions()
  std::string out_path;       // CSV, "" for none
  int every = 10;             // query every Nth frame (>= 1)
  int camera = 0;
  // How the map frame G relates to the dataset's ground-truth frame W: kNone (G = W, e.g. a map
  // from vilma-locmap-gt or an anchored map), or kPosYaw / kSe3 fitted to the localized
  // positions themselves (a map built by VIO has G = that run's odometry frame).
  AlignmentType align = AlignmentType::kNone;
  std::string align_from_path;  // --align-from: a fixed S_W_G from `vilma eval --json`
  bool quiet = false;  // no per-query lines
  bool help = false;
};

// Throws UsageError for a bad command line.
LocalizeCommandOptions ParseLocalizeArgs(const std::vector<std::string>& args);


void PrintLocalizeHelp(std::ostream& out);

// The whole command; returns kExitOk (whatever the recall), kExitInputError or kExitUsage.
int RunLocalizeCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace vilma::console
