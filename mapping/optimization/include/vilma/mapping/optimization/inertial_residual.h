// Inertial residual between consecutive vertices i, j of a mission (Forster et al. T-RO 2017,
// eq. 45; docs/optimization.md "Residuals"), with the bias random walk:
//   r_R  = Log(ΔR(b_g,i)ᵀ R_iᵀ R_j)
//   r_v  = R_iᵀ (v_j - v_i - g Δt) - Δv(b_i)
//   r_p  = R_iᵀ (p_j - p_i - v_i Δt - ½ g Δt²) - Δp(b_i)
//   r_bg = b_g,j - b_g,i,   r_ba = b_a,j - b_a,i
// whitened by the square root of the information: Σ_Δ⁻¹ of the preintegration for [r_R r_v
// r_p], 1/(σ_bw² Δt) for the random walks (the rig's densities). g = (0, 0, -|g|) in M (z up,
// the VIO's gravity-aligned mission frame). The preintegration's deltas are corrected to first
// order for the bias of vertex i (imu_preintegration.h); the problem re-integrates between
// solver rounds when the bias moved far.
// Blocks (pose_manifold.h): pose_i T_M_I [7], speed_bias_i [9], pose_j [7], speed_bias_j [9].
// Jacobians: with respect to the tangents (PoseManifold), by automatic differentiation of the
// residual at x ⊞ δ, δ = 0 (Jets over the 30 tangent directions), written into the first six
// columns of each pose block (the lift convention of PoseManifold).
//
// To add: problem.AddResidualBlock(new InertialCostFunction(&preintegration, gravity_m_s2),
//                                  nullptr, pose_i, speed_bias_i, pose_j, speed_bias_j);
// The preintegration must outlive the problem; re-integrating it changes the residual.
#pragma once

#include <ceres/sized_cost_function.h>

#include "vilma/mapping/optimization/imu_preintegration.h"

namespace vilma::mapping {

class InertialCostFunction : public ceres::SizedCostFunction<15, 7, 9, 7, 9> {
 public:
  InertialCostFunction(const ImuPreintegration* preintegration, double gravity_m_s2)
      : preintegration_(preintegration), gravity_m_s2_(gravity_m_s2) {}
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

  // The unwhitened residual [r_R r_v r_p r_bg r_ba] at the given blocks (tests, reports).
  Eigen::Matrix<double, 15, 1> RawResidual(double const* const* parameters) const;
  // The 15x15 upper-triangular square root of the information (Uᵀ U = Σ⁻¹).
  Eigen::Matrix<double, 15, 15> SqrtInformation() const;

 private:
  const ImuPreintegration* preintegration_;
  double gravity_m_s2_;
};

}  // namespace vilma::mapping
