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

// Pose block <-> Transformation.
void PoseToBlock(const Transformation& T, double* block);
Transformation BlockToPose(const double* block);

}  // namespace vilma::mapping
