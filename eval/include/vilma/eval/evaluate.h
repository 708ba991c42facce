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

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "vilma/core/geometry.h"
#include "vilma/core/trajectory.h"

namespace vilma {

// ---- association ----

enum class AssociationRule {
  // evo's sync.associate_trajectories: the SHORTER trajectory (the estimate when both are
  // equally long) is walked; each of its poses takes the nearest stamp of the other (ties: the
  // earlier) when |dt| <= max_dt. A pose of the longer one may be matched more than once.
  kEvo,
  // TUM's associate.py: all pairs within max_dt, accepted in increasing |dt| while neither
  // pose is used yet: one-to-one (vilma's rule before issue 17).
  kUnique,
};
// "evo", "unique".
const char* AssociationRuleName(AssociationRule rule);
// Parses the names above; false for anything else.
bool ParseAssociationRule(const std::string& name, AssociationRule* rule);

struct AssociationOptions {
  // Largest |t_gt - t_est| [s] of a matched pair: 10 ms, as evo's default --t_max_diff 0.01 and
  // TUM's associate.py 0.02 (here tighter, ground truth usually comes at >= 100 Hz).
  double max_dt_s = 0.01;
  // Which pairs are made (docs/evaluation.md, "1. Association"); evo's, so that ATE equals
  // evo_ape's on the same files.
  AssociationRule rule = AssociationRule::kEvo;
  // Empty when valid, else what is wrong.
  std::string Validate() const;
};

// Matched pairs, ordered by time (both index lists non-decreasing; strictly increasing with
// kUnique): gt.T_W_B[gt_index[k]] <-> est.T_W_B[est_index[k]].
struct Association {
  std::vector<std::size_t> gt_index;
  std::vector<std::size_t> est_index;
  // True when one of the trajectories has no time stamps (KITTI): pairs are (k, k) for
  // k < min(gt.size(), est.size()); the caller decides whether a size mismatch is an error.
  bool by_index = false;
  std::size_t size() const { return gt_index.size(); }
};

// Time association by options.rule. kEvo: walk the shorter trajectory (est when sizes are
// equal), pair each pose with the nearest stamp of the other (ties: the earlier stamp, as
// numpy's argmin) if |dt| <= max_dt; O(n log m). Stamps are compared as exact integer ns (evo
// compares doubles in seconds: only a pair exactly max_dt apart may differ). kUnique (TUM's
// associate.py): all pairs with |t_gt - t_est| <= max_dt are candidates, accepted in increasing
// |dt| (ties: earlier estimate, then earlier gt) when neither pose is used yet; O((n + m) log +
// candidates).
Association AssociateTrajectories(const Trajectory& gt, const Trajectory& est,
                                  const AssociationOptions& options);

// ---- alignment ----

enum class AlignmentType {
  kPosYaw,  // 4-DoF: yaw about gravity (z) + translation; VIO's unobservable directions
  kSe3,     // 6-DoF rigid: Umeyama without scale
  kSim3,    // 7-DoF: Umeyama with scale; monocular VO
  kNone,    // identity
  kFirst,   // 4-DoF from the first matched pose only: VIO started at a known pose
  kFixed,   // given S_G_E (EvalOptions::fixed_alignment), nothing fitted to the estimate:
            // sessions localized in a map frame, evaluated with the map session's alignment
};
// "posyaw", "se3", "sim3", "none", "first", "fixed".
const char* AlignmentTypeName(AlignmentType type);
// Parses the names above; false for anything else.
bool ParseAlignmentType(const std::string& name, AlignmentType* type);

// The similarity S_G_E: p_G = scale * (R_G_E p_E) + p_G_E, and R_G_B = R_G_E R_E_B.
struct Alignment {
  AlignmentType type = AlignmentType::kNone;
  Transformation T_G_E;  // rotation R_G_E and translation p_G_E
  double scale = 1.0;    // 1 unless kSim3

  // Applies S_G_E to a pose T_E_B: (R_G_E R_E_B, s R_G_E p_E_B + p_G_E).
  Transformation Apply(const Transformation& T_E_B) const;
};

// Minimum number of matched positions each alignment needs: none and fixed 0 (but evaluation
// needs 1), posyaw 2, se3 and sim3 3 (non-collinear for a unique rotation), first 1.
std::size_t MinimumPosesForAlignment(AlignmentType type);

// Umeyama 1991 ("Least-squares estimation of transformation parameters between two point
// patterns", PAMI 13(4)): minimizes sum_i |p_G_i - (s R p_E_i + t)|^2 in closed form via the
// SVD of the cross-covariance, with the reflection fix (eq. 39-43). with_scale false -> s = 1.
// Requires p_G.size() == p_E.size() >= 3 (std::invalid_argument otherwise).
Alignment AlignUmeyama(const std::vector<Eigen::Vector3d>& p_G,
                       const std::vector<Eigen::Vector3d>& p_E, bool with_scale);

// Position + yaw: minimizes sum_i |p_G_i - (Rz(theta) p_E_i + t)|^2 over theta and t, closed
// form: with centred points, theta = atan2(sum (x_E y_G - y_E x_G), sum (x_E x_G + y_E y_G)),
// t = mean_G - Rz(theta) mean_E. Requires >= 2 points (std::invalid_argument otherwise).
Alignment AlignPositionYaw(const std::vector<Eigen::Vector3d>& p_G,
                           const std::vector<Eigen::Vector3d>& p_E);

// Yaw about the gravity axis z of a rotation R: the theta minimizing the angle of
// Rz(theta)^T R, i.e. the twist angle of R's swing-twist decomposition about z,
// theta = atan2(R(1,0) - R(0,1), R(0,0) + R(1,1)) (derivation in the .cpp). A rotation about
// any horizontal axis (a pure roll/pitch) has yaw 0; Rz(a) S and S Rz(a) with such an S have
// yaw a. 0 when undetermined (R a half turn about a horizontal axis).
double GravityYaw(const Eigen::Quaterniond& R);

// kFirst: the yaw + translation S_G_E that maps the estimate's first matched pose T_E_B0 onto
// the ground truth's T_G_B0: R_G_E = Rz(GravityYaw(R_G_B0 R_E_B0^T)), p_G_E = p_G_B0 -
// R_G_E p_E_B0. So the first positions coincide exactly and the first headings agree; a roll or
// pitch difference stays in the errors (for VIO it is observable, as for posyaw). This is
// "aligned only at the start": a robot whose VIO was started at a known pose.
Alignment AlignFirstPose(const Transformation& T_G_B0, const Transformation& T_E_B0);

// Dispatches on type (kNone -> identity). kFirst needs poses: use AlignFirstPose
// (std::invalid_argument here).
Alignment AlignPositions(AlignmentType type, const std::vector<Eigen::Vector3d>& p_G,
                         const std::vector<Eigen::Vector3d>& p_E);

// ---- statistics ----

struct ErrorStats {
  std::size_t count = 0;
  double rmse = 0.0;
  double mean = 0.0;
  double median = 0.0;  // mean of the two middle values for an even count
  double std_dev = 0.0; // population standard deviation
  double min = 0.0;
  double max = 0.0;
};
// All zeros for an empty input.
ErrorStats ComputeErrorStats(const std::vector<double>& values);

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

struct AbsoluteError {
  ErrorStats translation_m;
  ErrorStats rotation_deg;
  // Roll/pitch error: the angle between the gravity axis seen in the body frame by the ground
  // truth and by the aligned estimate, angle(R_gt^T e_z, R_est^T e_z). Yaw does not enter, so
  // for posyaw (and none/first) it does not depend on the alignment: the VIO attitude error
  // that gravity makes observable.
  ErrorStats roll_pitch_deg;
  // Per matched pose, in association order.
  std::vector<double> translation_errors_m;
  std::vector<double> rotation_errors_deg;
  std::vector<double> roll_pitch_errors_deg;
};

struct RelativeError {
  double length_m = 0.0;
  std::size_t pairs = 0;  // 0 when the ground-truth path is shorter than length_m
  ErrorStats translation_m;
  ErrorStats translation_percent;  // 100 * translation / length_m
  ErrorStats rotation_deg;
};

// Matched poses whose aligned position error is <= distance_m (the boundary counts as within),
// e.g. a localization benchmark's recall = (results within 0.5 m) / attempts.
struct WithinCount {
  double distance_m = 0.0;
  std::size_t poses = 0;          // matched poses with translation error <= distance_m
  std::size_t matched_poses = 0;  // all matched poses
  double fraction = 0.0;          // poses / matched_poses (0 when nothing matched)
};
// One WithinCount per distance, same order.
std::vector<WithinCount> CountWithin(const std::vector<double>& translation_errors_m,
                                     const std::vector<double>& distances_m);

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

// Distance-based RPE over matched, aligned poses (see the header comment). Exposed for tests.
RelativeError ComputeRelativeError(const std::vector<Transformation>& T_G_B_gt,
                                   const std::vector<Transformation>& T_G_B_est, double length_m);

// The whole pipeline. Throws InputError when too few poses match for the alignment (message
// says how many matched and how many are needed), std::invalid_argument for invalid options.
EvalResult EvaluateTrajectory(const Trajectory& gt, const Trajectory& est,
                              const EvalOptions& options);

}  // namespace vilma
