#include "vilma/eval/evaluate.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <stdexcept>
#include <tuple>

#include <Eigen/SVD>

#include "vilma/core/error.h"
#include "vilma/core/time.h"

namespace vilma {
namespace {

constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;

}  // namespace

// ---- evaluation ----

std::string EvalOptions::Validate() const {
  const std::string association_error = association.Validate();
  if (!association_error.empty()) return "association." + association_error;
  for (double d : segment_lengths_m) {
    if (!std::isfinite(d) || d <= 0.0) return "segment_lengths_m: expected lengths > 0 [m]";
  }
  for (double d : within_m) {
    if (!std::isfinite(d) || d < 0.0) return "within_m: expected distances >= 0 [m]";
  }
  if (alignment == AlignmentType::kFixed) {
    const double s = fixed_alignment.scale;
    if (!std::isfinite(s) || s <= 0.0) return "fixed_alignment.scale: expected a finite value > 0";
    if (!fixed_alignment.T_G_E.translation().allFinite()) {
      return "fixed_alignment.translation: expected finite values [m]";
    }
    if (!fixed_alignment.T_G_E.rotation().coeffs().allFinite()) {
      return "fixed_alignment.rotation: expected a finite quaternion";
    }
  }
  return "";
}

EvalResult EvaluateTrajectory(const Trajectory& gt, const Trajectory& est,
                              const EvalOptions& options) {
  const std::string options_error = options.Validate();
  if (!options_error.empty()) throw std::invalid_argument("EvalOptions: " + options_error);

  EvalResult result;
  result.association = AssociateTrajectories(gt, est, options.association);
  const Association& assoc = result.association;
  const std::size_t needed = std::max<std::size_t>(1, MinimumPosesForAlignment(options.alignment));
  if (assoc.size() < needed) {
    std::ostringstream msg;
    msg << "expected at least " << needed << " matched poses for alignment '"
        << AlignmentTypeName(options.alignment) << "', got " << assoc.size() << " of "
        << est.size() << " estimate poses";
    if (!assoc.by_index) {
      msg << " (max_dt " << options.association.max_dt_s
          << " s; do the two files use the same clock?)";
    }
    throw InputError(msg.str());
  }

  std::vector<Eigen::Vector3d> p_G, p_E;
  p_G.reserve(assoc.size());
  p_E.reserve(assoc.size());
  for (std::size_t k = 0; k < assoc.size(); ++k) {
    p_G.push_back(gt.T_W_B[assoc.gt_index[k]].translation());
    p_E.push_back(est.T_W_B[assoc.est_index[k]].translation());
  }
  try {
    if (options.alignment == AlignmentType::kFixed) {
      result.alignment = options.fixed_alignment;
      result.alignment.type = AlignmentType::kFixed;
    } else if (options.alignment == AlignmentType::kFirst) {
      // The first matched pose in association order, which is estimate time order (or index).
      result.alignment = AlignFirstPose(gt.T_W_B[assoc.gt_index.front()],
                                        est.T_W_B[assoc.est_index.front()]);
    } else {
      result.alignment = AlignPositions(options.alignment, p_G, p_E);
    }
  } catch (const std::invalid_argument& e) {
    throw InputError(std::string("alignment failed: ") + e.what());
  }

  for (std::size_t k = 0; k < assoc.size(); ++k) {
    const Transformation& T_gt = gt.T_W_B[assoc.gt_index[k]];
    const Transformation T_est = result.alignment.Apply(est.T_W_B[assoc.est_index[k]]);
    result.t_ns.push_back(est.t_ns[assoc.est_index[k]]);
    result.T_G_B_gt.push_back(T_gt);
    result.T_G_B_est.push_back(T_est);
    if (k > 0) {
      result.gt_path_length_m += (T_gt.translation() - result.T_G_B_gt[k - 1].translation()).norm();
    }
    result.ate.translation_errors_m.push_back((T_gt.translation() - T_est.translation()).norm());
    // angle(R_gt^T R_est), equal to rpg's angle(R_est R_gt^T) (conjugate rotations).
    result.ate.rotation_errors_deg.push_back(AngleBetween(T_gt.rotation(), T_est.rotation()) *
                                             kRadToDeg);
    const Eigen::Vector3d z_gt = T_gt.rotation().conjugate() * Eigen::Vector3d::UnitZ();
    const Eigen::Vector3d z_est = T_est.rotation().conjugate() * Eigen::Vector3d::UnitZ();
    result.ate.roll_pitch_errors_deg.push_back(
        std::atan2(z_gt.cross(z_est).norm(), z_gt.dot(z_est)) * kRadToDeg);
  }
  result.ate.translation_m = ComputeErrorStats(result.ate.translation_errors_m);
  result.ate.rotation_deg = ComputeErrorStats(result.ate.rotation_errors_deg);
  result.ate.roll_pitch_deg = ComputeErrorStats(result.ate.roll_pitch_errors_deg);

  for (double d : options.segment_lengths_m) {
    result.rpe.push_back(ComputeRelativeError(result.T_G_B_gt, result.T_G_B_est, d));
  }
  result.within = CountWithin(result.ate.translation_errors_m, options.within_m);
  return result;
}

}  // namespace vilma
