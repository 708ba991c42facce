// Parameter blocks of the visual-inertial problem (docs/optimization.md "Problem"):
//   pose        double[7] = [p (3), q (x y z w, Eigen's coefficient order)]: T_A_B with
//               rotation q and translation p — vertex T_M_I, baseframe T_G_M, extrinsics T_I_C;
//   speed_bias  double[9] = [v_M (3), b_g (3), b_a (3)] of a vertex;
//   landmark    double[3] = p_G.
// PoseManifold: tangent [δp, δθ] with p ⊞ δp = p + δp and q ⊞ δθ = q ⊗ Exp(δθ) (a rotation
// perturbation in the body frame B). Its PlusJacobian is the 7x6 "lift" [I 0; 0 I; 0 0]: the
// cost functions of this module write their Jacobians with respect to the tangent directly into
// the first six columns of the 7-column block (the last column zero), so Ceres' product
// J_ambient * PlusJacobian gives exactly the tangent Jacobian (the convention of VINS-Mono and
// OKVIS; only this module's cost functions may be attached to a PoseManifold block).
#pragma once

#include <ceres/manifold.h>

#include "vilma/core/geometry.h"

namespace vilma::mapping {

class PoseManifold : public ceres::Manifold {
 public:
  int AmbientSize() const override { return 7; }
  int TangentSize() const override { return 6; }
  bool Plus(const double* x, const double* delta, double* x_plus_delta) const override;
  bool PlusJacobian(const double* x, double* jacobian) const override;
  bool Minus(const double* y, const double* x, double* y_minus_x) const override;
  bool MinusJacobian(const double* x, double* jacobian) const override;
};

// A pose with part of its tangent held: the gauge of the problem (docs/optimization.md
// "Gauge"). Two kinds:
//  - position (if fix_position) and heading held: the rotation moves only by rotations about
//    horizontal axes of the frame A (z is up, gravity), applied on A's side, so the heading of
//    the body in A, ψ(R_A_B R_A_B_heldᵀ) = 0 with ψ = YawAboutZ, is held exactly while roll and
//    pitch move (maplab's JplRollPitchQuaternionParameterization). Holding the body's own yaw
//    ψ(R_A_B) instead turns a tilt correction into a heading change of the whole map whenever
//    B's z is not up (a camera-like IMU mount: tan(β/2) per radian of tilt for a swing β;
//    1.2 for the simulator's 99°).
//    Held set: R = M R_held with M about a horizontal axis (quaternion z = 0). Plus: h =
//    (δ0, δ1, 0) in A, R1 = Exp(h) R, then R' = Rz(−c) R1 with c = ψ(R1 R_heldᵀ) (back on the
//    set). To first order c = g·h with g = (m_y, −m_x, 0) / m_w from M's quaternion, so the
//    tangent direction of δ is the A-frame rotation h − e_z (g·h), in the body R_A_Bᵀ (h − e_z
//    (g·h)) (g = 0 at R_held).
//  - rotation free, position free or (non-zero fixed_direction, unit, frame A) moving only
//    orthogonally to it: the visual-only scale gauge (the distance to a held vertex along that
//    direction is kept to first order).
// Its PlusJacobian lifts the reduced tangent into the first six columns, as PoseManifold's.
class GaugePoseManifold : public ceres::Manifold {
 public:
  // Heading held relative to q_A_B_held (the block's rotation when the problem is set up).
  GaugePoseManifold(bool fix_position, const Eigen::Quaterniond& q_A_B_held)
      : fix_position_(fix_position), fix_heading_(true), q_A_B_held_(q_A_B_held.normalized()) {}
  // Rotation free; the position moves orthogonally to fixed_direction (all of it when zero).
  explicit GaugePoseManifold(const Eigen::Vector3d& fixed_direction)
      : fix_position_(false), fix_heading_(false), fixed_direction_(fixed_direction) {}
  int AmbientSize() const override { return 7; }
  int TangentSize() const override {
    const int position = fix_position_ ? 0 : fixed_direction_.isZero() ? 3 : 2;
    return position + (fix_heading_ ? 2 : 3);
  }
  bool Plus(const double* x, const double* delta, double* x_plus_delta) const override;
  bool PlusJacobian(const double* x, double* jacobian) const override;
  bool Minus(const double* y, const double* x, double* y_minus_x) const override;
  bool MinusJacobian(const double* x, double* jacobian) const override;

 private:
  // The 6 x TangentSize() matrix from the reduced tangent to [δp, δθ] at x.
  Eigen::Matrix<double, 6, Eigen::Dynamic> Basis(const double* x) const;
  // Least-squares inverse of Basis(x) (TangentSize() x 6).
  Eigen::Matrix<double, Eigen::Dynamic, 6> BasisInverse(const double* x) const;
  bool fix_position_, fix_heading_;
  Eigen::Quaterniond q_A_B_held_ = Eigen::Quaterniond::Identity();
  Eigen::Vector3d fixed_direction_ = Eigen::Vector3d::Zero();
};

// A baseframe T_G_M whose position and yaw are held and whose tilt moves: the body-frame
// perturbation q ⊗ Exp(δθ) with δθ = (δθx, δθy, 0) in M, i.e. the direction of gravity (M's z)
// seen in G. For maps whose frame G is not gravity aligned but fixed by held landmarks (a
// calibration target's frame): the IMU sees gravity along M's z, the landmarks fix G, and
// only this tilt ties the two (docs/optimization.md "Gauge"). Tangent size 2, lifted into the
// 7 columns as PoseManifold's.
class BaseframeTiltManifold : public ceres::Manifold {
 public:
  int AmbientSize() const override { return 7; }
  int TangentSize() const override { return 2; }
  bool Plus(const double* x, const double* delta, double* x_plus_delta) const override;
  bool PlusJacobian(const double* x, double* jacobian) const override;
  bool Minus(const double* y, const double* x, double* y_minus_x) const override;
  bool MinusJacobian(const double* x, double* jacobian) const override;
};

// The yaw ψ of R = Rz(ψ) S, S a rotation about a horizontal axis (the swing-twist split about
// z): ψ = atan2(R10 − R01, R00 + R11), exact for any swing (S00 + S11 = 1 + cos β and
// S10 − S01 = 0); 0 when undetermined (β = 180°). The gauge holds ψ(R R_heldᵀ) = 0.
double YawAboutZ(const Eigen::Quaterniond& q);

// Pose block <-> Transformation.
void PoseToBlock(const Transformation& T, double* block);
Transformation BlockToPose(const double* block);

}  // namespace vilma::mapping
