#include "vilma/eval/trajectory_evaluation.h"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <sstream>

#include "vilma/core/error.h"
#include "vilma/core/json.h"
#include "vilma/core/timing.h"
#include "vilma/eval/alignment_json.h"

namespace vilma {
namespace {

// Below this ground-truth path length [m] the alignment's rotation is not determined.
constexpr double kMinPathForRotationAlignment = 0.5;

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

void WriteStatsJson(std::ostream& out, const char* prefix, const char* unit,
                    const ErrorStats& s) {
  const std::string p = std::string("\"") + prefix + "_";
  const std::string u = std::string("_") + unit + "\": ";
  out << p << "rmse" << u << JsonNumber(s.rmse) << ", " << p << "mean" << u << JsonNumber(s.mean)
      << ", " << p << "median" << u << JsonNumber(s.median) << ", " << p << "std" << u
      << JsonNumber(s.std_dev) << ", " << p << "min" << u << JsonNumber(s.min) << ", " << p
      << "max" << u << JsonNumber(s.max);
}

void WriteTrajectoryJson(std::ostream& out, const std::string& path, TrajectoryFormat format,
                         std::size_t poses) {
  out << "{\"path\": " << JsonString(path) << ", \"format\": "
      << JsonString(TrajectoryFormatName(format)) << ", \"poses\": " << poses << "}";
}

}  // namespace

std::string TrajectoryEvalOptions::Validate() const {
  if (gt_path.empty()) return "gt_path: expected a ground-truth trajectory file";
  if (est_path.empty()) return "est_path: expected an estimated trajectory file";
  if ((eval.alignment == AlignmentType::kFixed) != !align_from_path.empty()) {
    return "align_from_path: expected a file exactly when the alignment is fixed";
  }
  // (The fixed transform itself is read and checked by ReadTrajectoryEvalInputs.)
  return eval.Validate();
}

TrajectoryEvalInputs ReadTrajectoryEvalInputs(const TrajectoryEvalOptions& options) {
  const std::string problem = options.Validate();
  if (!problem.empty()) throw std::invalid_argument("TrajectoryEvalOptions: " + problem);
  const auto t0 = std::chrono::steady_clock::now();
  TrajectoryEvalInputs in;
  if (!options.align_from_path.empty()) {
    in.fixed_alignment = ReadAlignmentJson(options.align_from_path);
  }
  in.gt = ReadTrajectoryFile(options.gt_path, &in.gt_read);
  in.est = ReadTrajectoryFile(options.est_path, &in.est_read);
  in.read_time_s = MsSince(t0) * 1e-3;
  return in;
}

TrajectoryEvalSummary EvaluateTrajectoryInputs(const TrajectoryEvalOptions& options,
                                               const TrajectoryEvalInputs& inputs) {
  const Trajectory& gt = inputs.gt;
  const Trajectory& est = inputs.est;
  if ((!gt.has_timestamps || !est.has_timestamps) && gt.size() != est.size()) {
    throw InputError(FormatInputError(
        options.est_path, "",
        "expected " + std::to_string(gt.size()) + " poses like " + options.gt_path +
            " (a KITTI file has no time stamps, so poses are associated by index), got " +
            std::to_string(est.size())));
  }
  TrajectoryEvalSummary s;
  s.gt_path = options.gt_path;
  s.est_path = options.est_path;
  s.align_from_path = options.align_from_path;
  s.association = options.eval.association;
  s.gt_format = gt.format;
  s.est_format = est.format;
  s.gt_poses = gt.size();
  s.est_poses = est.size();
  s.read_time_s = inputs.read_time_s;
  EvalOptions eval = options.eval;
  if (eval.alignment == AlignmentType::kFixed) eval.fixed_alignment = inputs.fixed_alignment;
  const auto t0 = std::chrono::steady_clock::now();
  try {
    s.result = EvaluateTrajectory(gt, est, eval);
  } catch (const InputError& e) {
    throw InputError(options.est_path + " vs " + options.gt_path + ": " + e.what());
  }
  s.evaluate_time_s = MsSince(t0) * 1e-3;
  s.matched_poses = s.result.association.size();
  return s;
}

std::string TrajectoryEvalSummary::BriefReport() const {
  std::ostringstream out;
  out << "ATE " << Fixed(result.ate.translation_m.rmse, 4) << " m / "
      << Fixed(result.ate.rotation_deg.rmse, 3) << " deg rmse ("
      << AlignmentTypeName(result.alignment.type) << ")";
  for (const RelativeError& e : result.rpe) {
    if (e.pairs == 0) continue;  // the first segment with pairs: the shortest asked for
    out << ", RPE@" << FormatDistance(e.length_m) << "m " << Fixed(e.translation_percent.mean, 3)
        << " %";
    break;
  }
  out << ", " << matched_poses << " of " << est_poses << " poses matched, read "
      << Fixed(read_time_s * 1e3, 0) << " ms, evaluated " << Fixed(evaluate_time_s * 1e3, 0)
      << " ms";
  return out.str();
}

std::string TrajectoryEvalSummary::FullReport() const {
  std::ostringstream out;
  const Alignment& a = result.alignment;
  const Eigen::Vector3d p = a.T_G_E.translation();
  const Eigen::Vector3d rpy = LogSO3(a.T_G_E.rotation()) * (180.0 / 3.14159265358979323846);
  out << "ground truth:  " << gt_path << " (" << TrajectoryFormatName(gt_format) << ", "
      << gt_poses << " poses)\n";
  out << "estimate:      " << est_path << " (" << TrajectoryFormatName(est_format) << ", "
      << est_poses << " poses)\n";
  out << "matched poses: " << result.association.size();
  if (result.association.by_index) {
    out << " (by index: no time stamps)\n";
  } else {
    out << " (max dt " << association.max_dt_s << " s, " << AssociationRuleName(association.rule)
        << " rule)\n";
  }
  out << "alignment:     " << AlignmentTypeName(a.type);
  if (a.type == AlignmentType::kFixed) out << " (from " << align_from_path << ")";
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
  return out.str();
}

void WriteTrajectoryEvalJson(std::ostream& out, const TrajectoryEvalSummary& summary) {
  const EvalResult& result = summary.result;
  const Alignment& a = result.alignment;
  const Eigen::Vector3d p = a.T_G_E.translation();
  const Eigen::Quaterniond& q = a.T_G_E.rotation();
  out << "{\n";
  out << "  \"schema_version\": 1,\n";
  out << "  \"ground_truth\": ";
  WriteTrajectoryJson(out, summary.gt_path, summary.gt_format, summary.gt_poses);
  out << ",\n  \"estimate\": ";
  WriteTrajectoryJson(out, summary.est_path, summary.est_format, summary.est_poses);
  out << ",\n  \"association\": {\"method\": "
      << JsonString(result.association.by_index ? "index" : "time")
      << ", \"max_dt_s\": " << JsonNumber(summary.association.max_dt_s)
      << ", \"rule\": " << JsonString(AssociationRuleName(summary.association.rule)) << "},\n";
  out << "  \"matched_poses\": " << result.association.size() << ",\n";
  out << "  \"alignment\": " << JsonString(AlignmentTypeName(a.type)) << ",\n";
  out << "  \"scale\": " << JsonNumber(a.scale) << ",\n";
  out << "  \"alignment_from\": "
      << (summary.align_from_path.empty() ? std::string("null")
                                          : JsonString(summary.align_from_path))
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

}  // namespace vilma
