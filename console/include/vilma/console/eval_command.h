// `vilma eval`: absolute and relative trajectory error of an estimate against ground truth.
//
//   vilma eval --gt GT --est EST [--align posyaw|se3|sim3|none|first | --align-from MAP.json]
//              [--segments 10,20,30,40,50] [--within 0.5,1] [--max-dt 0.01]
//              [--association evo|unique] [--json OUT.json] [--plot OUT.png]
//
// A thin command: flags -> TrajectoryEvalOptions -> the eval library
// (eval/include/vilma/eval/trajectory_evaluation.h, plot.h) -> print. GT and EST may each be
// TUM, EuRoC CSV or KITTI (told apart by content). What was read goes to stderr, the report
// (TrajectoryEvalSummary::FullReport) to stdout; --json writes the same numbers with the stable
// schema of docs/evaluation.md; --plot renders a PNG through plot_trajectory.py (python3 +
// matplotlib). --align-from applies the alignment_transform of an earlier --json output instead
// of fitting one (multi-session evaluation in a map frame).
#pragma once

#include <ostream>
#include <string>
#include <vector>

#include "vilma/console/command.h"
#include "vilma/eval/trajectory_evaluation.h"

namespace vilma::console {

// The library's options plus the command's own --help.
struct EvalCommandOptions : TrajectoryEvalOptions {
  bool help = false;  // --help / -h
};

// Parses the words after "eval". Accepts "--opt value" and "--opt=value". Throws UsageError
// naming the flag (unknown option, missing value, bad number, invalid options).
EvalCommandOptions ParseEvalArgs(const std::vector<std::string>& args);

void PrintEvalHelp(std::ostream& out);

// The whole command; returns kExitOk, kExitInputError or kExitUsage.
int RunEvalCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err);

}  // namespace vilma::console
