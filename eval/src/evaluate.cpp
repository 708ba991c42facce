#include "vilma/core/trajectory_eval.h"

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

// ---- association ----

std::string AssociationOptions::Validate() const {
  if (!std::isfinite(max_dt_s) || max_dt_s < 0.0) {
    return "max_dt_s: expected a finite time difference >= 0 [s]";
  }
  return "";
}

const char* AssociationRuleName(AssociationRule rule) {
  switch (rule) {
    case AssociationRule::kEvo:
      return "evo";
    case AssociationRule::kUnique:
      return "unique";
  }
  return "unknown";
}

bool ParseAssociationRule(const std::string& name, AssociationRule* rule) {
  for (AssociationRule r : {AssociationRule::kEvo, AssociationRule::kUnique}) {
    if (name == AssociationRuleName(r)) {
      *rule = r;
      return true;
    }
  }
  return false;
}

namespace {

// evo's sync.associate_trajectories (evo/core/sync.py, matching_time_indices): for each stamp
// of the shorter trajectory, argmin |t_long - t_short| over the longer one, kept if <= max_dt.
// Both stamp vectors are strictly increasing, so the nearest is one of the two neighbours of
// the lower bound; on a tie the earlier one wins (argmin returns the first minimum).
Association AssociateEvo(const Trajectory& gt, const Trajectory& est, int64_t max_dt_ns) {
  Association result;
  const bool est_longer = est.size() > gt.size();
  const std::vector<int64_t>& walked = est_longer ? gt.t_ns : est.t_ns;
  const std::vector<int64_t>& searched = est_longer ? est.t_ns : gt.t_ns;
  for (std::size_t s = 0; s < walked.size(); ++s) {
    const int64_t t = walked[s];
    const auto it = std::lower_bound(searched.begin(), searched.end(), t);
    std::size_t best = searched.size();
    if (it != searched.end()) best = static_cast<std::size_t>(it - searched.begin());
    if (it != searched.begin()) {
      const std::size_t before = static_cast<std::size_t>(it - searched.begin()) - 1;
      if (best == searched.size() || t - searched[before] <= searched[best] - t) best = before;
    }
    if (best == searched.size() || std::abs(searched[best] - t) > max_dt_ns) continue;
    result.gt_index.push_back(est_longer ? s : best);
    result.est_index.push_back(est_longer ? best : s);
  }
  return result;
}

}  // namespace

Association AssociateTrajectories(const Trajectory& gt, const Trajectory& est,
                                  const AssociationOptions& options) {
  Association result;
  if (!gt.has_timestamps || !est.has_timestamps) {
    result.by_index = true;
    const std::size_t n = std::min(gt.size(), est.size());
    for (std::size_t k = 0; k < n; ++k) {
      result.gt_index.push_back(k);
      result.est_index.push_back(k);
    }
    return result;
  }
  const int64_t max_dt_ns = SecondsToNs(options.max_dt_s);
  if (options.rule == AssociationRule::kEvo) return AssociateEvo(gt, est, max_dt_ns);
  // Candidates (|dt|, est, gt): the gt stamps within the window of each estimate stamp, found
  // by binary search (both stamp vectors are strictly increasing).
  std::vector<std::tuple<int64_t, std::size_t, std::size_t>> candidates;
  for (std::size_t e = 0; e < est.size(); ++e) {
    const int64_t t = est.t_ns[e];
    auto it = std::lower_bound(gt.t_ns.begin(), gt.t_ns.end(), t - max_dt_ns);
    for (; it != gt.t_ns.end() && *it <= t + max_dt_ns; ++it) {
      const std::size_t g = static_cast<std::size_t>(it - gt.t_ns.begin());
      candidates.emplace_back(std::abs(*it - t), e, g);
    }
  }
  std::sort(candidates.begin(), candidates.end());
  std::vector<bool> gt_used(gt.size(), false);
  std::vector<long> est_match(est.size(), -1);
  for (const auto& [dt, e, g] : candidates) {
    (void)dt;
    if (est_match[e] >= 0 || gt_used[g]) continue;
    est_match[e] = static_cast<long>(g);
    gt_used[g] = true;
  }
  for (std::size_t e = 0; e < est.size(); ++e) {
    if (est_match[e] < 0) continue;
    result.est_index.push_back(e);
    result.gt_index.push_back(static_cast<std::size_t>(est_match[e]));
  }
  return result;
}

// ---- alignment ----

const char* AlignmentTypeName(AlignmentType type) {
  switch (type) {
    case AlignmentType::kPosYaw:
      return "posyaw";
    case AlignmentType::kSe3:
      return "se3";
    case AlignmentType::kSim3:
      return "sim3";
    case AlignmentType::kNone:
      return "none";
    case AlignmentType::kFirst:
      return "first";
    case AlignmentType::kFixed:
      return "fixed";
  }
  return "unknown";
}

bool ParseAlignmentType(const std::string& name, AlignmentType* type) {
  for (AlignmentType t : {AlignmentType::kPosYaw, AlignmentType::kSe3, AlignmentType::kSim3,
                          AlignmentType::kNone, AlignmentType::kFirst, AlignmentType::kFixed}) {
    if (name == AlignmentTypeName(t)) {
      *type = t;
      return true;
    }
  }
  return false;
}

Transformation Alignment::Apply(const Transformation& T_E_B) const {
  return Transformation(T_G_E.rotation() * T_E_B.rotation(),
                        scale * (T_G_E.rotation() * T_E_B.translation()) + T_G_E.translation());
}

std::size_t MinimumPosesForAlignment(AlignmentType type) {
  switch (type) {
    case AlignmentType::kPosYaw:
      return 2;
    case AlignmentType::kSe3:
    case AlignmentType::kSim3:
      return 3;
    case AlignmentType::kNone:
    case AlignmentType::kFixed:
      return 0;
    case AlignmentType::kFirst:
      return 1;
  }
  return 0;
}

namespace {

void CheckSizes(const std::vector<Eigen::Vector3d>& p_G, const std::vector<Eigen::Vector3d>& p_E,
                std::size_t minimum, const char* what) {
  if (p_G.size() != p_E.size() || p_G.size() < minimum) {
    std::ostringstream msg;
    msg << what << ": expected two equally long point sets of at least " << minimum
        << " points, got " << p_G.size() << " and " << p_E.size();
    throw std::invalid_argument(msg.str());
  }
}

Eigen::Vector3d Mean(const std::vector<Eigen::Vector3d>& p) {
  Eigen::Vector3d sum = Eigen::Vector3d::Zero();
  for (const auto& x : p) sum += x;
  return sum / static_cast<double>(p.size());
}

}  // namespace

Alignment AlignUmeyama(const std::vector<Eigen::Vector3d>& p_G,
                       const std::vector<Eigen::Vector3d>& p_E, bool with_scale) {
  CheckSizes(p_G, p_E, 3, "AlignUmeyama");
  const double n = static_cast<double>(p_G.size());
  const Eigen::Vector3d mu_G = Mean(p_G);
  const Eigen::Vector3d mu_E = Mean(p_E);
  // Cross-covariance Sigma_GE = 1/n sum (p_G - mu_G)(p_E - mu_E)^T (Umeyama eq. 38) and the
  // variance of the source points sigma_E^2 (eq. 36).
  Eigen::Matrix3d sigma_GE = Eigen::Matrix3d::Zero();
  double var_E = 0.0;
  for (std::size_t i = 0; i < p_G.size(); ++i) {
    const Eigen::Vector3d e = p_E[i] - mu_E;
    sigma_GE += (p_G[i] - mu_G) * e.transpose();
    var_E += e.squaredNorm();
  }
  sigma_GE /= n;
  var_E /= n;
  // Sigma = U D V^T; R = U S V^T with S = diag(1, 1, det(U) det(V)) so that R is a rotation,
  // not a reflection (eq. 39-40), s = tr(D S) / sigma_E^2 (eq. 42), t = mu_G - s R mu_E (eq.
  // 41).
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(sigma_GE, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Vector3d S(1.0, 1.0, 1.0);
  if (svd.matrixU().determinant() * svd.matrixV().determinant() < 0.0) S(2) = -1.0;
  const Eigen::Matrix3d R = svd.matrixU() * S.asDiagonal() * svd.matrixV().transpose();
  double scale = 1.0;
  if (with_scale) {
    if (!(var_E > 0.0)) {
      throw std::invalid_argument("AlignUmeyama: the estimate's points are all equal, no scale");
    }
    scale = svd.singularValues().dot(S) / var_E;
  }
  Alignment a;
  a.type = with_scale ? AlignmentType::kSim3 : AlignmentType::kSe3;
  a.scale = scale;
  a.T_G_E = Transformation(R, mu_G - scale * R * mu_E);
  return a;
}

Alignment AlignPositionYaw(const std::vector<Eigen::Vector3d>& p_G,
                           const std::vector<Eigen::Vector3d>& p_E) {
  CheckSizes(p_G, p_E, 2, "AlignPositionYaw");
  const Eigen::Vector3d mu_G = Mean(p_G);
  const Eigen::Vector3d mu_E = Mean(p_E);
  // sum_i g_i . Rz(theta) e_i = cos(theta) A + sin(theta) B for centred g, e, maximal at
  // theta = atan2(B, A); z does not depend on theta (rotation about the gravity axis).
  double A = 0.0;
  double B = 0.0;
  for (std::size_t i = 0; i < p_G.size(); ++i) {
    const Eigen::Vector3d g = p_G[i] - mu_G;
    const Eigen::Vector3d e = p_E[i] - mu_E;
    A += e.x() * g.x() + e.y() * g.y();
    B += e.x() * g.y() - e.y() * g.x();
  }
  const double theta = (A == 0.0 && B == 0.0) ? 0.0 : std::atan2(B, A);
  const Eigen::Quaterniond q(Eigen::AngleAxisd(theta, Eigen::Vector3d::UnitZ()));
  Alignment a;
  a.type = AlignmentType::kPosYaw;
  a.T_G_E = Transformation(q, mu_G - q * mu_E);
  return a;
}

double GravityYaw(const Eigen::Quaterniond& R_quat) {
  // We want the yaw theta that brings Rz(theta) closest to R: minimize the angle phi of
  // Rz(theta)^T R. Since trace(Q) = 1 + 2 cos(phi) for any rotation Q, that is maximizing
  //   f(theta) = trace(Rz(theta)^T R)
  //            = cos(theta) (R00 + R11) + sin(theta) (R10 - R01) + R22
  // (with Rz(theta) = [c -s 0; s c 0; 0 0 1]), whose maximum is at
  //   theta = atan2(R10 - R01, R00 + R11).
  // Write R = Rz(tau) S with S a rotation by beta about a horizontal unit axis u (swing-twist
  // decomposition about z). S = cos(beta) I + sin(beta) [u]x + (1 - cos(beta)) u u^T gives
  // S00 + S11 = 1 + cos(beta) and S10 - S01 = 2 sin(beta) u_z = 0, so
  //   R00 + R11 = cos(tau) (1 + cos(beta)),  R10 - R01 = sin(tau) (1 + cos(beta)),
  // and theta = tau exactly: a roll/pitch (the swing) never leaks into the yaw. The same holds
  // for R = S' Rz(tau) (S' = Rz(tau) S Rz(-tau) is again a horizontal-axis rotation).
  // Undetermined only when beta = 180 deg (both terms 0): then theta = 0.
  const Eigen::Matrix3d R = R_quat.normalized().toRotationMatrix();
  const double y = R(1, 0) - R(0, 1);
  const double x = R(0, 0) + R(1, 1);
  if (x == 0.0 && y == 0.0) return 0.0;
  return std::atan2(y, x);
}

Alignment AlignFirstPose(const Transformation& T_G_B0, const Transformation& T_E_B0) {
  // R_G_E should map R_E_B0 onto R_G_B0: R_G_E R_E_B0 = R_G_B0 <=> R_G_E = R_G_B0 R_E_B0^T.
  // Keep only its yaw (gravity is z in both worlds), then put the first positions together:
  // p_G_B0 = R_G_E p_E_B0 + p_G_E.
  const double yaw = GravityYaw(T_G_B0.rotation() * T_E_B0.rotation().conjugate());
  // (w, 0, 0, z) written out: AngleAxis would give x = y = -0.0 for a negative yaw.
  const Eigen::Quaterniond q_G_E(std::cos(0.5 * yaw), 0.0, 0.0, std::sin(0.5 * yaw));
  Alignment a;
  a.type = AlignmentType::kFirst;
  a.T_G_E = Transformation(q_G_E, T_G_B0.translation() - q_G_E * T_E_B0.translation());
  return a;
}

Alignment AlignPositions(AlignmentType type, const std::vector<Eigen::Vector3d>& p_G,
                         const std::vector<Eigen::Vector3d>& p_E) {
  switch (type) {
    case AlignmentType::kPosYaw:
      return AlignPositionYaw(p_G, p_E);
    case AlignmentType::kSe3:
      return AlignUmeyama(p_G, p_E, false);
    case AlignmentType::kSim3:
      return AlignUmeyama(p_G, p_E, true);
    case AlignmentType::kNone:
      break;
    case AlignmentType::kFirst:
      throw std::invalid_argument(
          "AlignPositions: alignment 'first' needs orientations, use AlignFirstPose");
    case AlignmentType::kFixed:
      throw std::invalid_argument(
          "AlignPositions: alignment 'fixed' is given, not fitted (EvalOptions::fixed_alignment)");
  }
  return Alignment{};
}

// ---- statistics ----

ErrorStats ComputeErrorStats(const std::vector<double>& values) {
  ErrorStats s;
  s.count = values.size();
  if (values.empty()) return s;
  double sum = 0.0;
  double sum_sq = 0.0;
  s.min = values.front();
  s.max = values.front();
  for (double v : values) {
    sum += v;
    sum_sq += v * v;
    s.min = std::min(s.min, v);
    s.max = std::max(s.max, v);
  }
  const double n = static_cast<double>(values.size());
  s.mean = sum / n;
  s.rmse = std::sqrt(sum_sq / n);
  double var = 0.0;
  for (double v : values) var += (v - s.mean) * (v - s.mean);
  s.std_dev = std::sqrt(var / n);
  std::vector<double> sorted = values;
  std::sort(sorted.begin(), sorted.end());
  const std::size_t mid = sorted.size() / 2;
  s.median = sorted.size() % 2 == 1 ? sorted[mid] : 0.5 * (sorted[mid - 1] + sorted[mid]);
  return s;
}

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

std::vector<WithinCount> CountWithin(const std::vector<double>& translation_errors_m,
                                     const std::vector<double>& distances_m) {
  std::vector<WithinCount> counts;
  counts.reserve(distances_m.size());
  for (double d : distances_m) {
    WithinCount c;
    c.distance_m = d;
    c.matched_poses = translation_errors_m.size();
    for (double e : translation_errors_m) {
      if (e <= d) ++c.poses;  // the boundary is within
    }
    c.fraction = c.matched_poses == 0
                     ? 0.0
                     : static_cast<double>(c.poses) / static_cast<double>(c.matched_poses);
    counts.push_back(c);
  }
  return counts;
}

RelativeError ComputeRelativeError(const std::vector<Transformation>& T_G_B_gt,
                                   const std::vector<Transformation>& T_G_B_est,
                                   double length_m) {
  if (T_G_B_gt.size() != T_G_B_est.size()) {
    throw std::invalid_argument("ComputeRelativeError: expected equally long pose lists");
  }
  RelativeError r;
  r.length_m = length_m;
  const std::size_t n = T_G_B_gt.size();
  // Travelled distance along the ground truth, path[i] = sum_{k<i} |p_k+1 - p_k|.
  std::vector<double> path(n, 0.0);
  for (std::size_t i = 1; i < n; ++i) {
    path[i] = path[i - 1] + (T_G_B_gt[i].translation() - T_G_B_gt[i - 1].translation()).norm();
  }
  std::vector<double> trans, percent, rot;
  for (std::size_t i = 0; i < n; ++i) {
    // First j with path[j] >= path[i] + d (path is non-decreasing).
    const auto it = std::lower_bound(path.begin() + static_cast<long>(i), path.end(),
                                     path[i] + length_m);
    if (it == path.end()) break;  // no later start can reach d either
    const std::size_t j = static_cast<std::size_t>(it - path.begin());
    const Transformation T_gt_ij = T_G_B_gt[i].inverse() * T_G_B_gt[j];
    const Transformation T_est_ij = T_G_B_est[i].inverse() * T_G_B_est[j];
    const Transformation E = T_gt_ij.inverse() * T_est_ij;
    const double t_err = E.translation().norm();
    trans.push_back(t_err);
    percent.push_back(100.0 * t_err / length_m);
    rot.push_back(AngleBetween(Eigen::Quaterniond::Identity(), E.rotation()) * kRadToDeg);
  }
  r.pairs = trans.size();
  r.translation_m = ComputeErrorStats(trans);
  r.translation_percent = ComputeErrorStats(percent);
  r.rotation_deg = ComputeErrorStats(rot);
  return r;
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
