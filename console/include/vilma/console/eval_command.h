// `vilma eval`: absolute and relative trajectory error of an estimate against ground truth.
//
//   vilma eval --gt GT --est EST [--align posyaw|se3|sim3|none|first | --align-from MAP.json]
//              [--segments 10,20,30,40,50] [--within 0.5,1] [--max-dt 0.01] [--json OUT.json]
//              [--plot OUT.png]
//
// GT and EST may each be TUM, EuRoC CSV or KITTI (told apart by content). The report goes to
// stdout; --json writes the same numbers with the stable schema of docs/evaluation.md; --plot
// renders a PNG through scripts/plot_trajectory.py (python3 + matplotlib). --align-from applies
// the alignment_transform of an earlier --json output instead of fitting one (multi-session
// evaluation in a map frame: every session with the map session's transform).
#pragma once

#include <ostream>
#include <string>
#include <vector>

#include "vilma/console/alignment_json.h"
#include "vilma/console/command.h"
#include "vilma/core/trajectory.h"
#include "vilma/core/trajectory_eval.h"

namespace vilma::console {

struct EvalCommandOptions {
  std::string gt_path;    // --gt, required
  std::string est_path;   // --est, required
  EvalOptions eval;       // --align, --segments, --within, --max-dt
  // --align-from, empty: none. Sets eval.alignment to kFixed; RunEvalCommand reads the file
  // into eval.fixed_alignment.
  std::string align_from_path;
  std::string json_path;  // --json, empty: no JSON
  std::string plot_path;  // --plot, empty: no plot
  bool help = false;      // --help / -h
  // Empty when valid (required paths given and eval options valid), else what is wrong.
  std::string Validate() const;
};

// Parses the words after "eval". Accepts "--opt value" and "--opt=value". Throws UsageError
// (unknown option, missing value, bad number, invalid options).
EvalCommandOptions ParseEvalArgs(const std::vector<std::string>& args);

void PrintEvalHelp(std::ostream& out);

// Human-readable report (what `vilma eval` prints).
void WriteEvalReport(std::ostream& out, const EvalCommandOptions& options, const Trajectory& gt,
                     const Trajectory& est, const EvalResult& result);

// JSON document, schema_version 1 (docs/evaluation.md lists the keys).
void WriteEvalJson(std::ostream& out, const EvalCommandOptions& options, const Trajectory& gt,
                   const Trajectory& est, const EvalResult& result);

// Writes the matched, aligned trajectories as CSV for the plot script:
// t_s,gt_x,gt_y,gt_z,est_x,est_y,est_z,translation_error_m,rotation_error_deg (t_s relative to
// the first matched pose; index when there are no time stamps).
void WritePlotCsv(std::ostream& out, const EvalResult& result);

// The whole command; returns kExitOk, kExitInputError or kExitUsage.
int RunEvalCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace vilma::console
