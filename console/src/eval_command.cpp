#include "vilma/console/eval_command.h"

#include <fcntl.h>
#include <spawn.h>
#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cerrno>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <cstring>
#include <fstream>
#include <sstream>

#include "vilma/core/atomic_file.h"
#include "vilma/core/error.h"
#include "vilma/core/json.h"

extern char** environ;


namespace vilma::console {
namespace {

// Below this ground-truth path length [m] the alignment's rotation is not determined.
constexpr double kMinPathForRotationAlignment = 0.5;


double ParseNumber(const std::string& option, const std::string& text) {
  char* end = nullptr;
  errno = 0;
  const double v = std::strtod(text.c_str(), &end);
  if (text.empty() || end != text.c_str() + text.size() || errno == ERANGE || !std::isfinite(v)) {
    throw UsageError(option + ": expected a number, got '" + text + "'");
  }
  return v;
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

// A --within distance for the report: two decimals ("0.50") unless that would round it.
std::string FormatDistance(double d) {
  char buf[48];
  std::snprintf(buf, sizeof(buf), "%.2f", d);
  if (std::strtod(buf, nullptr) == d) return buf;
  std::snprintf(buf, sizeof(buf), "%.6g", d);
  return buf;
}

std::string Fixed(double v, int decimals) {
  char buf[48];
  std::snprintf(buf, sizeof(buf), "%.*f", decimals, v);
  return buf;
}

// The plot script's folder: $VILMA_SCRIPTS_DIR, else share/vilma/scripts beside the running
// executable's bin/ folder — <prefix>/share/vilma/scripts when installed (cmake --install), and
// <build>/share/vilma/scripts in a build tree (CMake copies the script there), so that no path
// of the source tree is compiled in.
std::string ScriptsDir() {
  const char* env = std::getenv("VILMA_SCRIPTS_DIR");
  if (env != nullptr && env[0] != '\0') return env;
  char exe[4096];
  const ssize_t n = ::readlink("/proc/self/exe", exe, sizeof(exe) - 1);
  if (n <= 0) return "share/vilma/scripts";
  exe[n] = '\0';
  std::string dir(exe);
  dir = dir.substr(0, dir.find_last_of('/'));  // .../bin
  return dir + "/../share/vilma/scripts";
}

bool FileExists(const std::string& path) {
  struct stat st;
  return ::stat(path.c_str(), &st) == 0 && S_ISREG(st.st_mode);
}

// Runs argv (argv[0] looked up in PATH) and returns its exit status, -1 if it could not be
// started, -2 if it died from a signal.
// With quiet, its stdout and stderr go to /dev/null.
int RunProcess(const std::vector<std::string>& args, bool quiet) {
  std::vector<char*> argv;
  for (const auto& a : args) argv.push_back(const_cast<char*>(a.c_str()));
  argv.push_back(nullptr);
  posix_spawn_file_actions_t actions;
  posix_spawn_file_actions_init(&actions);
  if (quiet) {
    posix_spawn_file_actions_addopen(&actions, STDOUT_FILENO, "/dev/null", O_WRONLY, 0);
    posix_spawn_file_actions_addopen(&actions, STDERR_FILENO, "/dev/null", O_WRONLY, 0);
  }
  pid_t pid = 0;
  const int spawned = posix_spawnp(&pid, argv[0], &actions, nullptr, argv.data(), environ);
  posix_spawn_file_actions_destroy(&actions);
  if (spawned != 0) return -1;
  int status = 0;
  while (waitpid(pid, &status, 0) < 0) {
    if (errno != EINTR) return -1;
  }
  if (WIFEXITED(status)) {
    const int code = WEXITSTATUS(status);
    return code == 127 ? -1 : code;  // 127: the shell-style "command not found"
  }
  return -2;
}

// Renders the PNG. The interpreter: $VILMA_PYTHON if set, else python3 from PATH and then
// /usr/bin/python3 (a PATH python3 from pyenv/venv often lacks the Debian matplotlib).
void RenderPlot(const EvalCommandOptions& options, const EvalResult& result) {
  const std::string script = ScriptsDir() + "/plot_trajectory.py";
  if (!FileExists(script)) {
    throw InputError(FormatInputError(
        script, "",
        "expected the plot script, installed with the programs (share/vilma/scripts beside "
        "bin/), or set VILMA_SCRIPTS_DIR to the folder holding plot_trajectory.py"));
  }
  char tmp_template[] = "/tmp/vilma_eval_plot_XXXXXX";
  const char* tmpdir = std::getenv("TMPDIR");
  std::string tmp_path = (tmpdir != nullptr && tmpdir[0] != '\0')
                             ? std::string(tmpdir) + "/vilma_eval_plot_XXXXXX"
                             : std::string(tmp_template);
  std::vector<char> tmp_buf(tmp_path.begin(), tmp_path.end());
  tmp_buf.push_back('\0');
  const int fd = ::mkstemp(tmp_buf.data());
  if (fd < 0) throw InputError(FormatInputError(tmp_path, "", "expected a writable temp file"));
  ::close(fd);
  tmp_path = tmp_buf.data();
  {
    std::ofstream csv(tmp_path);
    WritePlotCsv(csv, result);
    if (!csv) {
      std::remove(tmp_path.c_str());
      throw InputError(FormatInputError(tmp_path, "", "expected a writable temp file"));
    }
  }
  std::ostringstream title;
  title << "align " << AlignmentTypeName(result.alignment.type) << ", ATE rmse "
        << Fixed(result.ate.translation_m.rmse, 3) << " m / "
        << Fixed(result.ate.rotation_deg.rmse, 2) << " deg, " << result.association.size()
        << " poses";

  std::vector<std::string> pythons;
  const char* env_python = std::getenv("VILMA_PYTHON");
  if (env_python != nullptr && env_python[0] != '\0') {
    pythons.push_back(env_python);
  } else {
    pythons = {"python3", "/usr/bin/python3"};
  }
  // Probe quietly for an interpreter that imports matplotlib, then run the script with it (its
  // own errors then reach the user's stderr).
  std::string tried;
  std::string python;
  for (const auto& candidate : pythons) {
    const int probe = RunProcess({candidate, "-c", "import matplotlib"}, true);
    if (!tried.empty()) tried += ", ";
    tried += candidate + (probe == -1 ? " (not found)" : " (no matplotlib)");
    if (probe == 0) {
      python = candidate;
      break;
    }
  }
  if (python.empty()) {
    std::remove(tmp_path.c_str());
    throw InputError(FormatInputError(
        options.plot_path, "--plot",
        "expected python3 with matplotlib (tried " + tried +
            "); install python3-matplotlib or set VILMA_PYTHON"));
  }
  const int status = RunProcess({python, script, "--input", tmp_path, "--output",
                                 options.plot_path, "--title", title.str()},
                                false);
  std::remove(tmp_path.c_str());
  if (status != 0) {
    throw InputError(FormatInputError(options.plot_path, "--plot",
                                      "expected " + script + " to succeed, it exited with " +
                                          std::to_string(status)));
  }
}

void WriteStatsJson(std::ostream& out, const char* prefix, const char* unit,
                    const ErrorStats& s) {
  const std::string p = std::string("\"") + prefix + "_";
  const std::string u = std::string("_") + unit + "\": ";
  out << p << "rmse" << u << JsonNumber(s.rmse) << ", " << p << "mean" << u << JsonNumber(s.mean)
      << ", " << p << "median" << u << JsonNumber(s.median) << ", " << p << "std" << u
      << JsonNumber(s.std_dev) << ", " << p << "min" << u << JsonNumber(s.min) << ", " << p
      << "max" << u << JsonNumber(s.max);
}

void WriteTrajectoryJson(std::ostream& out, const std::string& path, const Trajectory& t) {
  out << "{\"path\": " << JsonString(path) << ", \"format\": "
      << JsonString(TrajectoryFormatName(t.format)) << ", \"poses\": " << t.size() << "}";
}

}  // namespace

std::string EvalCommandOptions::Validate() const {
  if (gt_path.empty()) return "--gt: expected a ground-truth trajectory file";
  if (est_path.empty()) return "--est: expected an estimated trajectory file";
  if ((eval.alignment == AlignmentType::kFixed) != !align_from_path.empty()) {
    return "--align-from: expected a file exactly when the alignment is fixed";
  }
  // (The fixed transform itself is read and checked by RunEvalCommand.)
  const std::string e = eval.Validate();
  if (!e.empty()) return e;
  return "";
}

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
    const std::string e = o.Validate();
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

void WriteEvalReport(std::ostream& out, const EvalCommandOptions& options, const Trajectory& gt,
                     const Trajectory& est, const EvalResult& result) {
  const Alignment& a = result.alignment;
  const Eigen::Vector3d p = a.T_G_E.translation();
  const Eigen::Vector3d rpy = LogSO3(a.T_G_E.rotation()) * (180.0 / 3.14159265358979323846);
  out << "ground truth:  " << options.gt_path << " (" << TrajectoryFormatName(gt.format) << ", "
      << gt.size() << " poses)\n";
  out << "estimate:      " << options.est_path << " (" << TrajectoryFormatName(est.format)
      << ", " << est.size() << " poses)\n";
  out << "matched poses: " << result.association.size();
  if (result.association.by_index) {
    out << " (by index: no time stamps)\n";
  } else {
    out << " (max dt " << options.eval.association.max_dt_s << " s, "
        << AssociationRuleName(options.eval.association.rule) << " rule)\n";
  }
  out << "alignment:     " << AlignmentTypeName(a.type);
  if (a.type == AlignmentType::kFixed) out << " (from " << options.align_from_path << ")";
  out << "  rotation vector [deg] (" << Fixed(rpy.x(), 3) << ", " << Fixed(rpy.y(), 3) << ", "
      << Fixed(rpy.z(), 3) << ")  translation [m] (" << Fixed(p.x(), 4) << ", " << Fixed(p.y(), 4)
      << ", " << Fixed(p.z(), 4) << ")";
  if (a.type == AlignmentType::kSim3 || a.scale != 1.0) out << "  scale " << Fixed(a.scale, 6);
  out << "\n";
  out << "gt path:       " << Fixed(result.gt_path_length_m, 3) << " m\n";
  // Alignments fit the rotation to the positions: a (nearly) static trajectory leaves it
  // undetermined, and the rotation errors then hold an arbitrary yaw (or more).
  // (first takes its rotation from the first pose's orientation, not from the positions.)
  if (a.type != AlignmentType::kNone && a.type != AlignmentType::kFirst &&
      a.type != AlignmentType::kFixed && result.gt_path_length_m < kMinPathForRotationAlignment) {
    out << "note:          the ground-truth path is shorter than "
        << kMinPathForRotationAlignment
        << " m: the alignment cannot fix the rotation, so the rotation errors below include an "
           "arbitrary yaw; use --align none for a static sequence\n";
  }
  out << "\n";
  const ErrorStats& t = result.ate.translation_m;
  const ErrorStats& r = result.ate.rotation_deg;
  out << "ATE translation [m]:  rmse " << Fixed(t.rmse, 4) << "  mean " << Fixed(t.mean, 4)
      << "  median " << Fixed(t.median, 4) << "  max " << Fixed(t.max, 4) << "\n";
  out << "ATE rotation [deg]:   rmse " << Fixed(r.rmse, 4) << "  mean " << Fixed(r.mean, 4)
      << "  median " << Fixed(r.median, 4) << "  max " << Fixed(r.max, 4) << "\n";
  const ErrorStats& rp = result.ate.roll_pitch_deg;
  out << "roll/pitch [deg]:     rmse " << Fixed(rp.rmse, 4) << "  mean " << Fixed(rp.mean, 4)
      << "  median " << Fixed(rp.median, 4) << "  max " << Fixed(rp.max, 4)
      << "  (gravity axis in the body frame)\n";
  for (const WithinCount& w : result.within) {
    out << "within " << FormatDistance(w.distance_m) << " m: " << w.poses << " / "
        << w.matched_poses << " poses (" << Fixed(100.0 * w.fraction, 1) << " %)\n";
  }
  out << "\n";
  out << "RPE over distance along the ground truth:\n";
  char line[256];
  std::snprintf(line, sizeof(line), "%10s %7s %12s %12s %12s %12s %12s\n", "length[m]", "pairs",
                "t_rmse[m]", "t_mean[m]", "t_mean[%]", "t_med[%]", "r_rmse[deg]");
  out << line;
  for (const RelativeError& e : result.rpe) {
    std::snprintf(line, sizeof(line), "%10.3f %7zu %12.4f %12.4f %12.3f %12.3f %12.4f%s\n",
                  e.length_m, e.pairs, e.translation_m.rmse, e.translation_m.mean,
                  e.translation_percent.mean, e.translation_percent.median, e.rotation_deg.rmse,
                  e.pairs == 0 ? "  (path shorter than the segment)" : "");
    out << line;
  }
}

void WriteEvalJson(std::ostream& out, const EvalCommandOptions& options, const Trajectory& gt,
                   const Trajectory& est, const EvalResult& result) {
  const Alignment& a = result.alignment;
  const Eigen::Vector3d p = a.T_G_E.translation();
  const Eigen::Quaterniond& q = a.T_G_E.rotation();
  out << "{\n";
  out << "  \"schema_version\": 1,\n";
  out << "  \"ground_truth\": ";
  WriteTrajectoryJson(out, options.gt_path, gt);
  out << ",\n  \"estimate\": ";
  WriteTrajectoryJson(out, options.est_path, est);
  out << ",\n  \"association\": {\"method\": "
      << JsonString(result.association.by_index ? "index" : "time")
      << ", \"max_dt_s\": " << JsonNumber(options.eval.association.max_dt_s)
      << ", \"rule\": " << JsonString(AssociationRuleName(options.eval.association.rule))
      << "},\n";
  out << "  \"matched_poses\": " << result.association.size() << ",\n";
  out << "  \"alignment\": " << JsonString(AlignmentTypeName(a.type)) << ",\n";
  out << "  \"scale\": " << JsonNumber(a.scale) << ",\n";
  out << "  \"alignment_from\": "
      << (options.align_from_path.empty() ? std::string("null")
                                          : JsonString(options.align_from_path))
      << ",\n";
  out << "  \"alignment_transform\": {\"scale\": " << JsonNumber(a.scale)
      << ", \"translation_m\": [" << JsonNumber(p.x()) << ", " << JsonNumber(p.y()) << ", "
      << JsonNumber(p.z()) << "], \"quaternion_wxyz\": [" << JsonNumber(q.w()) << ", "
      << JsonNumber(q.x()) << ", " << JsonNumber(q.y()) << ", " << JsonNumber(q.z()) << "]},\n";
  out << "  \"gt_path_length_m\": " << JsonNumber(result.gt_path_length_m) << ",\n";
  out << "  \"ate\": {";
  WriteStatsJson(out, "translation", "m", result.ate.translation_m);
  out << ", ";
  WriteStatsJson(out, "rotation", "deg", result.ate.rotation_deg);
  out << ", ";
  WriteStatsJson(out, "roll_pitch", "deg", result.ate.roll_pitch_deg);
  out << "},\n";
  out << "  \"rpe\": [";
  for (std::size_t i = 0; i < result.rpe.size(); ++i) {
    const RelativeError& e = result.rpe[i];
    out << (i == 0 ? "\n" : ",\n") << "    {\"length_m\": " << JsonNumber(e.length_m)
        << ", \"pairs\": " << e.pairs << ", ";
    WriteStatsJson(out, "translation", "m", e.translation_m);
    out << ", ";
    WriteStatsJson(out, "translation", "percent", e.translation_percent);
    out << ", ";
    WriteStatsJson(out, "rotation", "deg", e.rotation_deg);
    out << "}";
  }
  out << (result.rpe.empty() ? "],\n" : "\n  ],\n");
  out << "  \"within\": [";
  for (std::size_t i = 0; i < result.within.size(); ++i) {
    const WithinCount& w = result.within[i];
    out << (i == 0 ? "\n" : ",\n") << "    {\"distance_m\": " << JsonNumber(w.distance_m)
        << ", \"poses\": " << w.poses << ", \"matched_poses\": " << w.matched_poses
        << ", \"fraction\": " << JsonNumber(w.fraction) << "}";
  }
  out << (result.within.empty() ? "]\n" : "\n  ]\n");
  out << "}\n";
}

void WritePlotCsv(std::ostream& out, const EvalResult& result) {
  out << "t_s,gt_x,gt_y,gt_z,est_x,est_y,est_z,translation_error_m,rotation_error_deg\n";
  char line[320];
  const bool by_index = result.association.by_index;
  for (std::size_t k = 0; k < result.t_ns.size(); ++k) {
    const double t = by_index ? static_cast<double>(k)
                              : static_cast<double>(result.t_ns[k] - result.t_ns.front()) * 1e-9;
    const Eigen::Vector3d& g = result.T_G_B_gt[k].translation();
    const Eigen::Vector3d& e = result.T_G_B_est[k].translation();
    std::snprintf(line, sizeof(line), "%.9f,%.9f,%.9f,%.9f,%.9f,%.9f,%.9f,%.9f,%.9f\n", t, g.x(),
                  g.y(), g.z(), e.x(), e.y(), e.z(), result.ate.translation_errors_m[k],
                  result.ate.rotation_errors_deg[k]);
    out << line;
  }
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
    if (!options.align_from_path.empty()) {
      options.eval.fixed_alignment = ReadAlignmentJson(options.align_from_path);
    }
    TrajectoryReadReport gt_read, est_read;
    const Trajectory gt = ReadTrajectoryFile(options.gt_path, &gt_read);
    const Trajectory est = ReadTrajectoryFile(options.est_path, &est_read);
    // What was read and every quirk met, once per file (after both read: an error stays the
    // only stderr output).
    for (const TrajectoryReadReport* r : {&gt_read, &est_read}) {
      err << "vilma eval: " << TrajectoryReadSummary(*r) << "\n";
      for (const std::string& w : TrajectoryReadWarnings(*r)) {
        err << "vilma eval: warning: " << w << "\n";
      }
    }
    if ((!gt.has_timestamps || !est.has_timestamps) && gt.size() != est.size()) {
      throw InputError(FormatInputError(
          options.est_path, "",
          "expected " + std::to_string(gt.size()) + " poses like " + options.gt_path +
              " (a KITTI file has no time stamps, so poses are associated by index), got " +
              std::to_string(est.size())));
    }
    EvalResult result;
    try {
      result = EvaluateTrajectory(gt, est, options.eval);
    } catch (const InputError& e) {
      throw InputError(options.est_path + " vs " + options.gt_path + ": " + e.what());
    }
    WriteEvalReport(out, options, gt, est, result);
    if (!options.json_path.empty()) {
      std::ostringstream json;
      WriteEvalJson(json, options, gt, est, result);
      WriteFileAtomically(options.json_path, json.str());
      out << "\nwrote " << options.json_path << "\n";
    }
    if (!options.plot_path.empty()) {
      RenderPlot(options, result);
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
