// Trajectory evaluation against ground truth, following rpg_trajectory_evaluation (Zhang and
// Scaramuzza, "A Tutorial on Quantitative Trajectory Evaluation for Visual(-Inertial)
// Odometry", IROS 2018) and evo (Grupp 2017). The conventions and where they differ from those
// tools are written down in docs/evaluation.md.
//
//   1. Associate: evo's rule (sync.associate_trajectories): each pose of the shorter
//      trajectory takes the nearest stamp of the longer one within max_dt; or TUM's one-to-one
//      rule (AssociationRule::kUnique); or by index without stamps.
//   2. Align: find S_G_E (rotation R, translation t, scale s) mapping the estimate's world E
//      onto the ground truth's world G from ALL matched positions: p_G = s R p_E + t; or, for
//      kFirst, the yaw + translation that puts the FIRST matched pose onto its ground truth;
//      or, for kFixed, a given S_G_E (e.g. written by an earlier evaluation), nothing fitted.
//   3. ATE: per matched pose, |p_gt - p_est'| [m] and angle(R_gt^T R_est') [deg] of the aligned
//      estimate; RMSE, mean, median, max.
//   4. RPE: distance-based segments along the ground-truth path; per start pose i the first pose
//      j with path(j) - path(i) >= d; error E = (T_gt_i^-1 T_gt_j)^-1 (T_est_i^-1 T_est_j),
//      translation |t_E| [m] and 100 |t_E| / d [%], rotation angle(R_E) [deg].
//   5. Within: per distance D, how many matched poses have an ATE translation error <= D.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "vilma/core/geometry.h"
#include "vilma/eval/alignment.h"
#include "vilma/eval/association.h"
#include "vilma/eval/metrics.h"
#include "vilma/eval/trajectory.h"

namespace vilma {

// ---- evaluation ----

struct EvalOptions {
  AlignmentType alignment = AlignmentType::kPosYaw;  // the VIO default (see docs/evaluation.md)
  // RPE segment lengths [m] along the ground-truth path; each > 0.
  std::vector<double> segment_lengths_m = {10.0, 20.0, 30.0, 40.0, 50.0};
  AssociationOptions association;
  // Distances D [m] (each finite, >= 0) for the "within" counts: matched poses whose ATE
  // translation error is <= D. Empty: none computed.
  std::vector<double> within_m;
  // The S_G_E applied as is when alignment == kFixed (its type is ignored: the result's
  // alignment has type kFixed); scale finite > 0, translation finite. Unused otherwise.
  Alignment fixed_alignment;
  std::string Validate() const;
};

struct EvalResult {
  Association association;
  Alignment alignment;
  // Matched poses in association order: stamps (estimate's), ground truth T_G_B and the
  // aligned estimate S_G_E T_E_B.
  std::vector<int64_t> t_ns;
  std::vector<Transformation> T_G_B_gt;
  std::vector<Transformation> T_G_B_est;
  double gt_path_length_m = 0.0;  // along the matched ground-truth poses
  AbsoluteError ate;
  std::vector<RelativeError> rpe;  // one per options.segment_lengths_m, same order
  std::vector<WithinCount> within; // one per options.within_m, same order
};

// The whole pipeline. Throws InputError when too few poses match for the alignment (message
// says how many matched and how many are needed), std::invalid_argument for invalid options.
EvalResult EvaluateTrajectory(const Trajectory& gt, const Trajectory& est,
                              const EvalOptions& options);

}  // namespace vilma
