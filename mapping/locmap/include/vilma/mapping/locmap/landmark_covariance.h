// Calibrated landmark covariances for the localization map (docs/localizer.md, "Calibrated
// landmark covariances"; issue 17 part 2).
//
// Why: a VI-map landmark's covariance comes from its triangulation, sigma_tri^2 (sum J_k^T
// J_k)^-1 with J_k = d pi_k / d p (mapping/triangulation.h), and sigma_tri is an assumed
// keypoint noise (1 px by default). The real keypoint noise of the detector (integer FAST/ORB
// corners, no sub-pixel refinement) is smaller: measured 0.5-0.6 px on the simulated and real
// maps, so the stored covariances were 3-4x too large in variance, and every covariance-based
// acceptance gate either let wrong poses through or cost recall.
//
// How: the map measures its own keypoint noise. For a landmark at its estimate p_G (the
// maximum-likelihood point of its N observations), the residuals r_k = pi_k(T_C_G,k p_G) -
// uv_k have 2N - 3 degrees of freedom, so |r_k|^2 2N / (2N - 3) estimates 2 sigma^2 per
// observation. The estimate is robust: the median of those values over all observations of
// the map divided by the median of chi^2 with 2 dof (2 ln 2 = 1.386) — a few wrong track
// associations (residuals of many pixels) must not inflate the noise of every landmark.
// The covariance is then recomputed with it, Sigma_G = sigma^2 (sum_k J_k^T J_k)^-1 over the
// landmark's valid observations, J_k = d pi / d p_C R_C_G (the vertices' poses taken as exact:
// for maps from ground-truth poses their error is in the residuals and so in sigma).
#pragma once

#include <Eigen/Core>
#include <vector>

#include "vilma/mapstore/vi_map.h"

namespace vilma::mapping {

// Pixel residual and Jacobian of one observation of p_G; false when the observation's camera
// is not in the mission's rig or p_G does not project into it.
bool ObservationResidual(const mapstore::VIMap& map, const mapstore::LandmarkObservation& obs,
                         const Eigen::Vector3d& p_G, Eigen::Vector2d* residual_px,
                         Eigen::Matrix<double, 2, 3>* d_r_d_p_G);

struct KeypointNoiseEstimate {
  int landmarks = 0;          // with >= 2 observations that project
  int observations = 0;
  double sigma_px = -1.0;     // robust per-axis keypoint noise; -1: not measurable
};

// The keypoint noise of `observations[l]` (the valid observations of landmark l at p_G[l]).
KeypointNoiseEstimate EstimateKeypointNoise(
    const mapstore::VIMap& map,
    const std::vector<std::vector<const mapstore::LandmarkObservation*>>& observations,
    const std::vector<Eigen::Vector3d>& p_G);

// sigma_px^2 (sum J_k^T J_k)^-1 over the observations that project; false when fewer than 2
// do or the information matrix is singular.
bool TriangulationCovariance_G(const mapstore::VIMap& map,
                               const std::vector<const mapstore::LandmarkObservation*>& observations,
                               const Eigen::Vector3d& p_G, double sigma_px,
                               Eigen::Matrix3d* covariance_G);

}  // namespace vilma::mapping
