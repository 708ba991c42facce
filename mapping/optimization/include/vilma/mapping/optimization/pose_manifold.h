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
// "Gauge"). fix_position drops δp; fix_yaw drops the rotation about the frame's z axis (gravity,
// up): the body-frame perturbation is restricted to the plane orthogonal to R_A_Bᵀ e_z, so the
// yaw of R_A_B does not change to first order (roll and pitch stay free). Its PlusJacobian lifts
// the reduced tangent into the first six columns, as PoseManifold's.
// With a non-zero fixed_direction (unit, frame A) and a free position, the position moves only
// orthogonally to that direction: the visual-only scale gauge (the distance to a held vertex
// along that direction is kept to first order).
class GaugePoseManifold : public ceres::Manifold {
 public:
  GaugePoseManifold(bool fix_position, bool fix_yaw,
                    const Eigen::Vector3d& fixed_direction = Eigen::Vector3d::Zero())
      : fix_position_(fix_position), fix_yaw_(fix_yaw), fixed_direction_(fixed_direction) {}
  int AmbientSize() const override { return 7; }
  int TangentSize() const override {
    const int position = fix_position_ ? 0 : fixed_direction_.isZero() ? 3 : 2;
    return position + (fix_yaw_ ? 2 : 3);
  }
  bool Plus(const double* x, const double* delta, double* x_plus_delta) const override;
  bool PlusJacobian(const double* x, double* jacobian) const override;
  bool Minus(const double* y, const double* x, double* y_minus_x) const override;
  bool MinusJacobian(const double* x, double* jacobian) const override;

 private:
  // The 6 x TangentSize() matrix from the reduced tangent to [δp, δθ] at x.
  Eigen::Matrix<double, 6, Eigen::Dynamic> Basis(const double* x) const;
  bool fix_position_, fix_yaw_;
  Eigen::Vector3d fixed_direction_;
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
// S10 − S01 = 0); 0 when undetermined (β = 180°). The gauge's held yaw.
double YawAboutZ(const Eigen::Quaterniond& q);

// Pose block <-> Transformation.
void PoseToBlock(const Transformation& T, double* block);
Transformation BlockToPose(const double* block);

}  // namespace vilma::mapping
