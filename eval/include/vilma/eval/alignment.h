// Alignment of an estimate's world E onto the ground truth's world G: the similarity S_G_E
// fitted to matched positions (posyaw, se3, sim3), taken from the first pose (first) or given
// (fixed). docs/evaluation.md, "2. Alignment".
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "vilma/core/geometry.h"

namespace vilma {

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

}  // namespace vilma
