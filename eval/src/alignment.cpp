#include "vilma/eval/alignment.h"

#include <cmath>
#include <sstream>
#include <stdexcept>
#include <string>

#include <Eigen/SVD>

namespace vilma {

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

}  // namespace vilma
