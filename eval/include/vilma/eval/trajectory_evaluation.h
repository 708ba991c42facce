// One evaluation of an estimated trajectory file against a ground-truth file: what `vilma eval`
// runs (console/src/eval_command.cpp maps its flags onto TrajectoryEvalOptions and prints the
// Summary). Three steps so that a caller can report what was read before evaluating:
//
//   TrajectoryEvalInputs in = ReadTrajectoryEvalInputs(options);   // files, --align-from
//   TrajectoryEvalSummary s = EvaluateTrajectoryInputs(options, in); // associate, align, ATE/RPE
//   s.FullReport(), WriteTrajectoryEvalJson(out, s), RenderTrajectoryPlot(s, png) (plot.h)
//
// All errors are InputError naming the file (std::invalid_argument for invalid options).
#pragma once

#include <ostream>
#include <string>

#include "vilma/eval/evaluate.h"
#include "vilma/eval/trajectory.h"

namespace vilma {

struct TrajectoryEvalOptions {
  std::string gt_path;   // ground-truth trajectory (TUM, EuRoC CSV or KITTI), required
  std::string est_path;  // estimated trajectory, required
  EvalOptions eval;      // association, alignment, RPE segments, within distances
  // An earlier evaluation's JSON whose alignment_transform is applied (alignment kFixed),
  // exactly when eval.alignment == kFixed; empty otherwise.
  std::string align_from_path;
  // Where the JSON (schema_version 1, docs/evaluation.md) and the PNG plot go; empty: none.
  // Written by the caller (WriteTrajectoryEvalJson, RenderTrajectoryPlot).
  std::string json_path;
  std::string plot_path;
  // Empty when valid, else "field: expected ...".
  std::string Validate() const;
};

// What ReadTrajectoryEvalInputs read.
struct TrajectoryEvalInputs {
  Trajectory gt;
  Trajectory est;
  TrajectoryReadReport gt_read;   // layout and quirks of each file (TrajectoryReadSummary)
  TrajectoryReadReport est_read;
  Alignment fixed_alignment;      // from align_from_path (kFixed), else identity kNone
  double read_time_s = 0.0;       // wall time of reading all files
};

// Reads align_from_path (when given; first, so that a bad alignment file fails before the
// trajectories are read), then gt_path and est_path.
TrajectoryEvalInputs ReadTrajectoryEvalInputs(const TrajectoryEvalOptions& options);

// The result of one evaluation, shaped like Ceres's Solver::Summary: what went in, counts,
// times, the result, a one-line and a full report.
struct TrajectoryEvalSummary {
  // What went in.
  std::string gt_path;
  std::string est_path;
  std::string align_from_path;  // empty unless the alignment is fixed
  AssociationOptions association;
  TrajectoryFormat gt_format = TrajectoryFormat::kTum;
  TrajectoryFormat est_format = TrajectoryFormat::kTum;
  // Counts.
  std::size_t gt_poses = 0;
  std::size_t est_poses = 0;
  std::size_t matched_poses = 0;  // == result.association.size()
  // Times [s] (wall, steady clock).
  double read_time_s = 0.0;
  double evaluate_time_s = 0.0;
  // Association, alignment, ATE, RPE, within (evaluate.h).
  EvalResult result;

  // One line: "ATE 0.0102 m / 0.158 deg rmse (fixed), RPE@10m 0.159 %, 1186 of 1186 poses
  // matched, read 41 ms, evaluated 3 ms".
  std::string BriefReport() const;
  // The report `vilma eval` prints (docs/evaluation.md "Output"): inputs, association,
  // alignment, ATE, roll/pitch, within counts and the RPE table. Deterministic (no times), so
  // that two runs on the same files print the same text.
  std::string FullReport() const;
};

// Checks that a file without stamps (KITTI) has as many poses as the other one (poses are then
// associated by index), evaluates, and fills the summary. An InputError of the evaluation
// (too few matched poses) is prefixed with "EST vs GT: ".
TrajectoryEvalSummary EvaluateTrajectoryInputs(const TrajectoryEvalOptions& options,
                                               const TrajectoryEvalInputs& inputs);

// The JSON document of `vilma eval --json` (schema_version 1, docs/evaluation.md lists the keys;
// numbers with 10 significant digits).
void WriteTrajectoryEvalJson(std::ostream& out, const TrajectoryEvalSummary& summary);

}  // namespace vilma
