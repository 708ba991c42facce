// Reprojection residual with a camera-IMU time offset (docs/optimization.md "Time offset").
//
// Clock model (core/rig.h, Kalibr's sign): t_imu = t_cam + t_d. A vertex sits at its image's
// stamp mapped with the rig's offset known when the map was built; δ is what that offset is
// still off by, so the image was exposed at t_vertex + δ. The body pose then is the vertex's
// propagated over δ at its own velocity and angular rate (first order in δ, which is a few
// milliseconds; the neglected ½aδ² is 0.1 mm at 10 m/s², 5 ms):
//   ω_I  = ω_m − b_g                     (gyroscope at the vertex time, minus the vertex's bias)
//   R'   = R_M_I Exp(ω_I δ),  t' = t_M_I + v_M δ
//   p_M  = R_G_Mᵀ (p_G − t_G_M),  p_I = R'ᵀ (p_M − t'),  p_C = R_I_Cᵀ (p_I − t_I_C)
//   r    = (π(p_C) − uv) / σ_px
// Jacobians of p_I (then through R_I_Cᵀ and ∂π/∂p_C), right perturbations as
// reprojection_residual.h, q = R_M_Iᵀ (p_M − t'), E = Exp(ω_I δ), J_r the SO(3) right Jacobian:
//   ∂/∂(δp, δθ)_M_I = [−R'ᵀ, Eᵀ [q]×]       ∂/∂v_M = −R'ᵀ δ
//   ∂/∂b_g          = −δ [p_I]× J_r(ω_I δ)   (∂(Exp(φ)ᵀq)/∂φ = [Exp(φ)ᵀq]× J_r(φ))
//   ∂/∂δ            = −[ω_I]× p_I − R'ᵀ v_M   ∂/∂p_G = R'ᵀ R_G_Mᵀ
//   ∂/∂(δp, δθ)_G_M = R'ᵀ [−R_G_Mᵀ, [p_M]×]  ∂p_C/∂(δp, δθ)_I_C = [−R_I_Cᵀ, [p_C]×]
// Blocks: vertex pose T_M_I [7], vertex speed and biases [v_M, b_g, b_a] [9], landmark p_G [3],
// baseframe T_G_M [7], extrinsics T_I_C [7], time offset δ [1, seconds]. A point behind the
// camera gives zero residual and Jacobians, as ReprojectionCostFunction.
#pragma once

#include <ceres/sized_cost_function.h>

#include <Eigen/Core>

#include "vilma/core/camera.h"

namespace vilma::mapping {

class TimeOffsetReprojectionCostFunction : public ceres::SizedCostFunction<2, 7, 9, 3, 7, 7, 1> {
 public:
  // omega_m_I: the gyroscope's reading at the vertex time [rad/s] (bias not removed).
  TimeOffsetReprojectionCostFunction(const Camera* camera, const Eigen::Vector2d& uv,
                                     double sigma_px, const Eigen::Vector3d& omega_m_I)
      : camera_(camera), uv_(uv), inverse_sigma_(1.0 / sigma_px), omega_m_I_(omega_m_I) {}
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

  // p_C of the model above (for error figures); false when a block is not finite.
  static Eigen::Vector3d PointInCamera(const double* pose_M_I, const double* speed_bias,
                                       const double* p_G, const double* pose_G_M,
                                       const double* pose_I_C, double delta_s,
                                       const Eigen::Vector3d& omega_m_I);

 private:
  const Camera* camera_;
  Eigen::Vector2d uv_;
  double inverse_sigma_;
  Eigen::Vector3d omega_m_I_;
};

}  // namespace vilma::mapping
