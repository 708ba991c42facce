// Calibration check of the localizer's residual noise model on right poses (docs/localizer.md,
// "Calibrated landmark covariances"). An inlier's reprojection residual e = pi(T_C_G p_G) - uv
// is modelled as zero-mean with covariance
//   Sigma_r = sigma_px^2 I + J_l Sigma_l J_l^T        (J_l = d e / d p_G),
// sigma_px the query keypoint noise, Sigma_l the map's landmark covariance. If the model is
// right, chi^2 = sum e^T Sigma_r^-1 e over the inliers of a right pose has 2n - 6 degrees of
// freedom (n inliers, 6 pose parameters fitted), so chi^2 / dof ~ 1. To say WHICH component is
// off, the variance components are estimated from the same residuals (Helmert / Foerstner
// variance component estimation): with the unknown true model
//   E |e|^2 = 2 s_kp + alpha tr(J_l Sigma_l J_l^T)
// (s_kp the true keypoint variance per axis [px^2], alpha the factor by which the stored
// landmark covariances are too large (< 1) or too small (> 1)), s_kp and alpha are fitted by
// iteratively weighted least squares over all inliers of all right poses, weights
// 1 / Var|e|^2 ~ 1 / (predicted E|e|^2)^2 (for a 2-D Gaussian Var|e|^2 = 2 tr(Sigma^2) is close
// to (tr Sigma)^2 up to its anisotropy). |e|^2 is scaled by 2n / (2n - 6) per pose: the fitted
// pose absorbs 6 of the 2n residual dimensions.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "vilma/core/camera.h"
#include "vilma/core/geometry.h"
#include "vilma/localizer/localization_map.h"
#include "vilma/localizer/localizer.h"
#include "vilma/sim/world.h"

namespace vilma::eval {

// One inlier of a right pose.
struct ResidualSample {
  double squared_px2 = 0.0;         // |e|^2 [px^2], already scaled by 2n / (2n - 6)
  double landmark_trace_px2 = 0.0;  // tr(J_l Sigma_l J_l^T) [px^2] (0 without covariances)
  double chi2 = 0.0;                // e^T Sigma_r^-1 e with the model's sigma_px and Sigma_l
};

// The samples of `result`'s inliers at its pose T_G_C (map: the localizer's map; keypoint
// noise sigma_px). Empty when fewer than 4 inliers project.
std::vector<ResidualSample> InlierResidualSamples(const Camera& camera,
                                                  const localizer::LocalizationMap& map,
                                                  const std::vector<Eigen::Vector2d>& keypoints,
                                                  const localizer::LocalizationResult& result,
                                                  double sigma_px);

struct NoiseCalibration {
  int poses = 0;
  int residuals = 0;
  // sum chi^2 / sum (2n - 6) over the poses: 1 for a calibrated model.
  double chi2_per_dof = 0.0;
  // Fitted components: the keypoint noise sqrt(s_kp) [px] and alpha (1 = the map's landmark
  // covariances are right; -1 when the map has none or the fit is singular).
  double keypoint_sigma_px = -1.0;
  double landmark_scale = -1.0;
};

// Pools the samples of several right poses (`dof` = sum of 2n - 6 over them).
NoiseCalibration FitNoiseComponents(const std::vector<ResidualSample>& samples, double dof,
                                    int poses);

// Landmark covariances against the simulator's true surfaces (a map whose frame G is the
// world W, e.g. vilma-locmap-gt's). The true point of a landmark is not known, but the surface
// it lies on is: the signed distance d = n^T (p_G - o) to the nearest quad (normal n, any
// point o of it) is the error's component along n, with variance n^T Sigma_l n under the map's
// model. So d^2 / (n^T Sigma_l n) is chi^2 with 1 degree of freedom per landmark and its mean
// is 1 for calibrated covariances. Landmarks whose foot point is not inside the nearest quad
// (near an edge or corner, where the nearest surface is ambiguous) or without a covariance are
// skipped.
struct LandmarkSurfaceCheck {
  int landmarks = 0;            // checked
  double chi2_per_dof = 0.0;    // mean of d^2 / (n^T Sigma_l n)
  double median_chi2 = 0.0;     // 0.455 for a chi^2_1 variable
  double rms_distance_m = 0.0;  // sqrt(mean d^2)
  double rms_sigma_m = 0.0;     // sqrt(mean n^T Sigma_l n)
};
LandmarkSurfaceCheck CheckLandmarksAgainstWorld(const localizer::LocalizationMap& map,
                                                const sim::World& world);

}  // namespace vilma::eval
