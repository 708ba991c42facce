#include "vilma/console/eval_command.h"

#include <sstream>
#include <stdexcept>

#include "vilma/core/atomic_file.h"
#include "vilma/core/error.h"
#include "vilma/core/strict_parse.h"
#include "vilma/eval/plot.h"

namespace vilma::console {
namespace {

// A finite number (core/strict_parse.h) or a UsageError naming the option.
double ParseNumber(const std::string& option, const std::string& text) {
  try {
    return ParseStrictDouble(text);
  } catch (const std::invalid_argument&) {
    throw UsageError(option + ": expected a number, got '" + text + "'");
  }
}

std::vector<double> ParseSegments(const std::string& text) {
  std::vector<double> lengths;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = text.find(',', start);
    const double d = ParseNumber("--segments", text.substr(start, comma - start));
    if (d <= 0.0) throw UsageError("--segments: expected lengths > 0 [m], got " + text);
    lengths.push_back(d);
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return lengths;
}

// "--within 0.5,1,2": distances [m] >= 0, in the given order.
std::vector<double> ParseWithin(const std::string& text) {
  std::vector<double> distances;
  std::size_t start = 0;
  while (true) {
    const std::size_t comma = text.find(',', start);
    const std::string word = text.substr(start, comma - start);
    if (word.empty()) {
      throw UsageError("--within: expected comma-separated distances [m], got '" + text + "'");
    }
    const double d = ParseNumber("--within", word);
    if (d < 0.0) throw UsageError("--within: expected distances >= 0 [m], got " + word);
    distances.push_back(d);
    if (comma == std::string::npos) break;
    start = comma + 1;
  }
  return distances;
}

// TrajectoryEvalOptions::Validate in the words of the flags.
std::string FlagProblem(const EvalCommandOptions& o) {
  if (o.gt_path.empty()) return "--gt: expected a ground-truth trajectory file";
  if (o.est_path.empty()) return "--est: expected an estimated trajectory file";
  if ((o.eval.alignment == AlignmentType::kFixed) != !o.align_from_path.empty()) {
    return "--align-from: expected a file exactly when the alignment is fixed";
  }
  // (The fixed transform itself is read and checked by ReadTrajectoryEvalInputs.)
  return o.eval.Validate();
}

}  // namespace

EvalCommandOptions ParseEvalArgs(const std::vector<std::string>& args) {
  EvalCommandOptions o;
  bool align_given = false;
  for (ArgCursor arg(args); arg.Next();) {
    const std::string& name = arg.name();
    if (name == "--help" || name == "-h") {
      o.help = arg.Flag();
      continue;
    }
    const bool known = name == "--gt" || name == "--est" || name == "--align" ||
                       name == "--segments" || name == "--max-dt" || name == "--json" ||
                       name == "--plot" || name == "--within" || name == "--align-from" ||
                       name == "--association";
    if (!known && name.rfind("-", 0) != 0) {
      throw UsageError("unexpected argument '" + arg.word() + "' (files go after --gt and --est)");
    }
    if (!known) throw UsageError("unknown option '" + arg.word() + "'");
    const std::string value = arg.Value();
    if (value.empty()) throw UsageError(name + ": expected a non-empty value");
    if (name == "--gt") {
      o.gt_path = value;
    } else if (name == "--est") {
      o.est_path = value;
    } else if (name == "--align") {
      align_given = true;
      if (value == AlignmentTypeName(AlignmentType::kFixed)) {
        throw UsageError("--align fixed: give the transform with --align-from FILE.json");
      }
      if (!ParseAlignmentType(value, &o.eval.alignment)) {
        throw UsageError("--align: expected posyaw, se3, sim3, none or first, got '" + value +
                         "'");
      }
    } else if (name == "--segments") {
      o.eval.segment_lengths_m = ParseSegments(value);
    } else if (name == "--within") {
      o.eval.within_m = ParseWithin(value);
    } else if (name == "--max-dt") {
      o.eval.association.max_dt_s = ParseNumber("--max-dt", value);
    } else if (name == "--association") {
      if (!ParseAssociationRule(value, &o.eval.association.rule)) {
        throw UsageError("--association: expected evo or unique, got '" + value + "'");
      }
    } else if (name == "--align-from") {
      o.align_from_path = value;
    } else if (name == "--json") {
      o.json_path = value;
    } else if (name == "--plot") {
      o.plot_path = value;
    }
  }
  if (!o.align_from_path.empty()) {
    if (align_given) {
      throw UsageError(
          "--align and --align-from exclude each other (--align-from applies the "
          "file's transform, nothing is fitted)");
    }
    o.eval.alignment = AlignmentType::kFixed;
  }
  if (!o.help) {
    const std::string e = FlagProblem(o);
    if (!e.empty()) throw UsageError(e);
  }
  return o;
}

void PrintEvalHelp(std::ostream& out) {
  out << "usage: vilma eval --gt GT --est EST [options]\n"
         "\n"
         "Absolute (ATE) and relative (RPE) trajectory error of EST against GT.\n"
         "GT and EST: TUM text (t[s] x y z qx qy qz qw), EuRoC CSV (t[ns],p,q_wxyz[,v,bw,ba])\n"
         "or KITTI (12 numbers, 3x4 row-major, no time: associated by index); the format is\n"
         "told from the content; quirks of other systems' files (header rows, commas or\n"
         "spaces, stamps in ns or s, CRLF, ...) are accepted and reported on stderr, and a\n"
         "repeated time stamp keeps the first pose (a warning names the lines).\n"
         "\n"
         "options:\n"
         "  --gt FILE             ground-truth trajectory (required)\n"
         "  --est FILE            estimated trajectory (required)\n"
         "  --align TYPE          posyaw (default, VIO: yaw + translation), se3, sim3\n"
         "                        (monocular: with scale) or none: fitted to all matched\n"
         "                        poses; first: the yaw + translation that puts the first\n"
         "                        matched pose onto the ground truth (VIO aligned only at the\n"
         "                        start)\n"
         "  --align-from FILE     apply the alignment_transform S_G_E of an earlier\n"
         "                        `vilma eval --json FILE` instead of fitting one (alignment\n"
         "                        'fixed'): sessions localized in a map frame G evaluated\n"
         "                        with the map session's --align first transform\n"
         "  --segments D1,D2,...  RPE segment lengths [m] along the ground-truth path\n"
         "                        (default 10,20,30,40,50); a length longer than the path\n"
         "                        gets 0 pairs\n"
         "  --within D1,D2,...    count the matched poses whose aligned position error is\n"
         "                        <= D [m] (e.g. 0.5 for localization recall), per D\n"
         "  --max-dt S            largest time difference [s] of a matched pair (default 0.01)\n"
         "  --association RULE    evo (default: each pose of the shorter file takes the\n"
         "                        nearest stamp of the other within --max-dt, as evo_ape) or\n"
         "                        unique (one-to-one, nearest pairs first, as TUM's\n"
         "                        associate.py)\n"
         "  --json FILE           also write the results as JSON (docs/evaluation.md)\n"
         "  --plot FILE.png       top-down trajectories + error over time (python3 +\n"
         "                        matplotlib; scripts from $VILMA_SCRIPTS_DIR, interpreter\n"
         "                        from $VILMA_PYTHON)\n"
         "  -h, --help            this help\n"
         "\n"
         "exit codes: 0 ok, 1 input error (message names the file), 2 usage error\n";
}

int RunEvalCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  EvalCommandOptions options;
  try {
    options = ParseEvalArgs(args);
  } catch (const UsageError& e) {
    err << "vilma eval: " << e.what() << "\n(see 'vilma eval --help')\n";
    return kExitUsage;
  }
  if (options.help) {
    PrintEvalHelp(out);
    return kExitOk;
  }
  try {
    const TrajectoryEvalInputs inputs = ReadTrajectoryEvalInputs(options);
    // What was read and every quirk met, once per file (after both read: an error stays the
    // only stderr output).
    for (const TrajectoryReadReport* r : {&inputs.gt_read, &inputs.est_read}) {
      err << "vilma eval: " << TrajectoryReadSummary(*r) << "\n";
      for (const std::string& w : TrajectoryReadWarnings(*r)) {
        err << "vilma eval: warning: " << w << "\n";
      }
    }
    const TrajectoryEvalSummary summary = EvaluateTrajectoryInputs(options, inputs);
    out << summary.FullReport();
    if (!options.json_path.empty()) {
      std::ostringstream json;
      WriteTrajectoryEvalJson(json, summary);
      WriteFileAtomically(options.json_path, json.str());
      out << "\nwrote " << options.json_path << "\n";
    }
    if (!options.plot_path.empty()) {
      RenderTrajectoryPlot(summary, options.plot_path);
      out << "wrote " << options.plot_path << "\n";
    }
  } catch (const InputError& e) {
    err << "vilma eval: error: " << e.what() << "\n";
    return kExitInputError;
  } catch (const std::exception& e) {
    err << "vilma eval: error: " << e.what() << "\n";
    return kExitInputError;
  }
  return kExitOk;
}

}  // namespace vilma::console
