// Reprojection residual of one landmark observation (docs/optimization.md "Residuals"):
//   p_M = R_G_Mᵀ (p_G - t_G_M),  p_I = R_M_Iᵀ (p_M - t_M_I),  p_C = R_I_Cᵀ (p_I - t_I_C)
//   r = (π(p_C) - uv) / σ_px                                    [2, whitened pixels]
// Blocks (pose_manifold.h): vertex pose T_M_I [7], landmark p_G [3], baseframe T_G_M [7],
// extrinsics T_I_C [7] — the last two usually held constant. Analytic Jacobians with right
// perturbations (R ⊞ δθ = R Exp(δθ), so ∂(Rᵀx)/∂δθ = [Rᵀx]×):
//   ∂p_C/∂p_G = R_I_Cᵀ R_M_Iᵀ R_G_Mᵀ
//   ∂p_C/∂(δp, δθ)_M_I = R_I_Cᵀ [-R_M_Iᵀ, [p_I]×]
//   ∂p_C/∂(δp, δθ)_G_M = R_I_Cᵀ R_M_Iᵀ [-R_G_Mᵀ, [p_M]×]
//   ∂p_C/∂(δp, δθ)_I_C = [-R_I_Cᵀ, [p_C]×]
// times ∂π/∂p_C from the camera model (core/camera.h: pinhole radtan, equidistant).
// A point behind the camera (or not finite) gives a zero residual and zero Jacobians: it adds
// nothing; the optimizer's outlier rejection removes such observations between solver rounds.
//
// Robust loss (ReprojectionLoss): it acts on the whitened residual, so a scale of k turns it
// robust at k sigma of the observation's own keypoint noise, i.e. at k * sigma_px pixels
// (Huber: rho(s) = s for s <= k^2, 2k sqrt(s) - k^2 beyond; Cauchy: k^2 log(1 + s / k^2),
// s = |r|^2). A scale given in pixels instead (the same for every observation) is scale_px /
// sigma_px on the whitened residual.
//
// To add: problem.AddResidualBlock(new ReprojectionCostFunction(&camera, uv, sigma_px),
//                                  loss, pose_M_I, p_G, pose_G_M, pose_I_C);
#pragma once

#include <ceres/loss_function.h>
#include <ceres/sized_cost_function.h>

#include <Eigen/Core>
#include <memory>
#include <string>

#include "vilma/core/camera.h"

namespace vilma::mapping {

class ReprojectionCostFunction : public ceres::SizedCostFunction<2, 7, 3, 7, 7> {
 public:
  ReprojectionCostFunction(const Camera* camera, const Eigen::Vector2d& uv, double sigma_px)
      : camera_(camera), uv_(uv), inverse_sigma_(1.0 / sigma_px) {}
  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override;

 private:
  const Camera* camera_;
  Eigen::Vector2d uv_;
  double inverse_sigma_;
};

// The robust loss of a reprojection residual whitened by sigma_px: `type` "huber", "cauchy"
// or "none" (nullptr). It turns robust at scale_sigma sigma (scale_sigma on the whitened
// residual), or, when scale_px > 0, at scale_px pixels (scale_px / sigma_px whitened).
// Throws std::invalid_argument for an unknown type or a scale or sigma that is not > 0.
std::unique_ptr<ceres::LossFunction> ReprojectionLoss(const std::string& type, double scale_sigma,
                                                      double scale_px, double sigma_px);

}  // namespace vilma::mapping
