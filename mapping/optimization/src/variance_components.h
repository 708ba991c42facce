// Variance component estimation for the visual-inertial problem (Förstner 1979; Koch,
// "Parameter Estimation and Hypothesis Testing in Linear Models", ch. 3.6; docs/optimization.md
// "Noise scales estimated from the data"). Private to mapping/optimization.
//
// The problem's residuals are whitened with a covariance that is a sum of components,
// Σ = Σ_k Σ_k: the reprojection residuals' keypoint noise (one component, its own rows) and,
// per IMU edge, the four parts of the preintegrated covariance from the gyroscope's and the
// accelerometer's white noise and random walk (ImuPreintegration::NoiseComponents; they share
// the edge's 15 rows). At a converged solution with residuals e (unwhitened), W = Σ⁻¹, the
// whitened Jacobian J̃ and N = J̃ᵀ J̃, the component's variance factor
//   f_k = eᵀ W Σ_k W e / tr(W Σ_k W Σ_e),   Σ_e = Σ − A N⁻¹ Aᵀ (the residuals' covariance)
// has expectation 1 when Σ_k is right; a component k times too small (in variance) gives
// f_k ≈ k. In whitened terms, with r = U e (Uᵀ U = W) and G_k = U Σ_k Uᵀ (Σ_k G_k = I):
//   numerator   = rᵀ G_k r,
//   denominator = tr(G_k) − tr(G_k H),  H = J̃ N⁻¹ J̃ᵀ (the hat matrix),
// the component's redundancy (the redundancies add up to rows − unknowns). For the
// reprojection component G = I on its rows: r_vᵀ r_v / (n_v − tr H_vv), Helmert's chi²/dof with
// the exact degrees of freedom. tr(G_k H) is estimated by Hutchinson's method: y = N⁻¹ᐟ² z for
// Rademacher probes z (a sparse Cholesky of N), u = J̃ y has covariance H, so
// E[u_eᵀ G_k u_e] = tr(G_k H_ee); probes from a fixed seed (deterministic runs). The Jacobian
// is in the tangent spaces, each reprojection row weighted by its loss's IRLS weight ρ'(s) (the
// information it gave the solve); the reprojection chi² is taken robustly, rows x (1.4826 MAD)²
// of the whitened components, so that outliers (down-weighted by the loss) do not inflate the
// keypoint noise and a Cauchy loss does not shrink it (its corrected residuals of Gaussian
// inliers have a mean square below 1: a fixed point below the true noise).
#pragma once

#include <ceres/ceres.h>

#include <array>
#include <vector>

#include "vilma/mapping/optimization/imu_preintegration.h"
#include "vilma/mapping/optimization/vi_optimization.h"

namespace vilma::mapping::vi_problem {

// One IMU edge's residual block and its preintegration (whose noise it is weighted by).
struct InertialBlock {
  ceres::ResidualBlockId residual;
  const ImuPreintegration* preintegration;
};

// Estimates the variance factors (NoiseFactors: visual, gyro_noise, accel_noise, gyro_walk,
// accel_walk, each a factor on the variance now in use) at the problem's current state.
// `probes`: Hutchinson probes. A component without rows, or whose redundancy is below
// `min_redundancy`, keeps factor 1 and is reported as not estimated.
NoiseFactors EstimateVarianceComponents(ceres::Problem* problem,
                                        const std::vector<InertialBlock>& inertial,
                                        const std::vector<ceres::ResidualBlockId>& visual,
                                        int probes = 32, double min_redundancy = 3.0);

}  // namespace vilma::mapping::vi_problem
