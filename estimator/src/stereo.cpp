#include "vilma/estimator/stereo.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <vector>

#include "vilma/estimator/filter_state.h"

namespace vilma::estimator {

Eigen::Matrix4d StereoJointNoise(const Eigen::Matrix2d& R1, const Eigen::Matrix2d& R2,
                                 double intensity_sigma, double pixel_sigma, double correlation) {
  const double sI2 = intensity_sigma * intensity_sigma;
  const double sp2 = pixel_sigma * pixel_sigma;
  Eigen::Matrix4d N;
  N.topLeftCorner<2, 2>() = sI2 * Eigen::Matrix2d::Identity() + sp2 * R1 * R1.transpose();
  N.bottomRightCorner<2, 2>() = sI2 * Eigen::Matrix2d::Identity() + sp2 * R2 * R2.transpose();
  N.topRightCorner<2, 2>() = correlation * sp2 * R1 * R2.transpose();
  N.bottomLeftCorner<2, 2>() = N.topRightCorner<2, 2>().transpose();
  return N;
}

bool PredictInOtherCamera(const Camera& camera2, const Transformation& T_C2_C1,
                          const Eigen::Vector3d& mu_C1, double rho,
                          OtherCameraPrediction* prediction) {
  const Eigen::Matrix3d R_C2_C1 = T_C2_C1.rotationMatrix();
  // m = R mu + rho p: p_C2 scaled by rho > 0 (the projection is scale invariant).
  const Eigen::Vector3d m = R_C2_C1 * mu_C1 + rho * T_C2_C1.translation();
  if (camera2.Project(m, &prediction->pixel, &prediction->J_pixel_m) !=
      Camera::ProjectionResult::kValid) {
    return false;
  }
  prediction->J_pixel_bearing = prediction->J_pixel_m * R_C2_C1 * BearingBasis(mu_C1);
  prediction->J_pixel_rho = prediction->J_pixel_m * T_C2_C1.translation();
  return true;
}

namespace {

double MeanAbsResidual(const MultilevelPatch& patch, const ImagePyramid& pyramid,
                       const Eigen::Vector2d& pixel, const Eigen::Matrix2d& warp,
                       const PhotometricOptions& options, Eigen::VectorXd* r,
                       Eigen::Matrix<double, Eigen::Dynamic, 2>* J) {
  if (!ComputePhotometricResidual(patch, pyramid, pixel, warp, options, r, J) || r->size() == 0) {
    return std::numeric_limits<double>::infinity();
  }
  return r->cwiseAbs().mean();
}

// 2. and 3. for one candidate sample of the curve: 2D alignment from it (sub-pixel, corrects
// small calibration errors), then rho of the curve point nearest to the aligned pixel
// (Gauss-Newton on min_rho |pi2(R mu + rho p) - pixel|^2, step (J_rho^T e) / (J_rho^T J_rho)).
StereoMatch RefineCandidate(const MultilevelPatch& patch, const Eigen::Matrix2d& D,
                            const ImagePyramid& pyramid2, const Camera& camera2,
                            const Transformation& T_C2_C1, const Eigen::Vector3d& mu_C1,
                            const StereoMatchOptions& options, double sample_rho) {
  StereoMatch match;
  OtherCameraPrediction p;
  if (!PredictInOtherCamera(camera2, T_C2_C1, mu_C1, sample_rho, &p)) {
    match.failure = StereoMatchFailure::kNoSample;
    return match;
  }
  const Eigen::Matrix2d W = p.J_pixel_bearing * D;
  const AlignmentResult aligned =
      AlignPatch(patch, pyramid2, p.pixel, W, options.photometric, options.align_iterations);
  match.pixel = aligned.pixel;
  match.mean_abs_error = aligned.mean_abs_error;
  if (!aligned.converged) {
    match.failure = StereoMatchFailure::kNotConverged;
    return match;
  }
  if (aligned.mean_abs_error > options.max_match_error) {
    match.failure = StereoMatchFailure::kResidual;
    return match;
  }
  match.failure = StereoMatchFailure::kNoDepth;
  double rho = sample_rho;
  for (int it = 0; it < 10; ++it) {
    if (!PredictInOtherCamera(camera2, T_C2_C1, mu_C1, rho, &p)) return match;
    const double jj = p.J_pixel_rho.squaredNorm();
    if (jj < 1e-12) return match;  // no baseline along the view: rho unobservable
    const double step = p.J_pixel_rho.dot(aligned.pixel - p.pixel) / jj;
    rho += step;
    if (std::abs(step) * std::sqrt(jj) < 1e-3) break;
  }
  if (!(rho >= 0.0) || !PredictInOtherCamera(camera2, T_C2_C1, mu_C1, rho, &p)) return match;
  match.rho = rho;
  if ((aligned.pixel - p.pixel).norm() > options.max_epipolar_px) {
    match.failure = StereoMatchFailure::kEpipolar;
    return match;
  }
  match.found = true;
  match.failure = StereoMatchFailure::kNone;
  match.rho_sigma =
      std::max(options.min_inverse_depth_sigma, options.pixel_sigma / p.J_pixel_rho.norm());
  return match;
}

}  // namespace

StereoMatch MatchInOtherCamera(const MultilevelPatch& patch, const Eigen::Matrix2d& D,
                               const ImagePyramid& pyramid2, const Camera& camera2,
                               const Transformation& T_C2_C1, const Eigen::Vector3d& mu_C1,
                               const StereoMatchOptions& options) {
  StereoMatch match;
  // The epipolar curve from infinity (rho = 0) to the nearest searched point, sampled at
  // about search_step_px: the pixel speed |d pixel / d rho| at either end (the nearer end may
  // be outside the image) sets the number of samples.
  OtherCameraPrediction far, near;
  const bool far_ok = PredictInOtherCamera(camera2, T_C2_C1, mu_C1, 0.0, &far);
  const bool near_ok =
      PredictInOtherCamera(camera2, T_C2_C1, mu_C1, options.max_inverse_depth, &near);
  const double speed = std::max(far_ok ? far.J_pixel_rho.norm() : 0.0,
                                near_ok ? near.J_pixel_rho.norm() : 0.0);
  const double length_px = speed > 0.0 ? speed * options.max_inverse_depth
                                        : 4.0 * options.search_step_px;
  const int steps = std::clamp(static_cast<int>(std::ceil(length_px / options.search_step_px)), 1, 400);

  // 1. Coarse search along the curve: the mean |residual| of every sample; its local minima
  //    are the candidates, lowest first. Measured on the simulator's perfect renders
  //    (tests/estimator/stereo_sim_test.cpp, docs/estimator-stereo-history.md "Why stereo matches
  //    fail"): taking only the global minimum lost most matches to a false minimum at the near end
  //    (rho 1.4..4.3 1/m, where the curve sweeps fast over repetitive texture); the 2D
  //    alignment from there slid along the texture, off the curve, and was rejected.
  Eigen::VectorXd r;
  Eigen::Matrix<double, Eigen::Dynamic, 2> J;
  std::vector<double> errors(static_cast<std::size_t>(steps) + 1,
                             std::numeric_limits<double>::infinity());
  OtherCameraPrediction p;
  for (int k = 0; k <= steps; ++k) {
    const double rho = options.max_inverse_depth * static_cast<double>(k) / steps;
    if (!PredictInOtherCamera(camera2, T_C2_C1, mu_C1, rho, &p)) continue;
    const Eigen::Matrix2d W = p.J_pixel_bearing * D;  // A = I at extraction
    errors[static_cast<std::size_t>(k)] =
        MeanAbsResidual(patch, pyramid2, p.pixel, W, options.photometric, &r, &J);
  }
  std::vector<int> candidates;
  for (int k = 0; k <= steps; ++k) {
    const double e = errors[static_cast<std::size_t>(k)];
    if (!std::isfinite(e)) continue;
    const bool left_ok = k == 0 || !(errors[static_cast<std::size_t>(k - 1)] < e);
    const bool right_ok = k == steps || !(errors[static_cast<std::size_t>(k + 1)] <= e);
    if (left_ok && right_ok) candidates.push_back(k);
  }
  if (candidates.empty()) {
    match.failure = StereoMatchFailure::kNoSample;
    return match;
  }
  std::sort(candidates.begin(), candidates.end(), [&](int a, int b) {
    return errors[static_cast<std::size_t>(a)] < errors[static_cast<std::size_t>(b)];
  });
  const std::size_t tries =
      std::min(candidates.size(), static_cast<std::size_t>(std::max(options.max_candidates, 1)));
  // Minima closer than 4 px along the curve are the same match (texture noise around it).
  const double sample_px = length_px / steps;
  const int same_match_samples = static_cast<int>(std::ceil(4.0 / std::max(sample_px, 1e-9)));
  StereoMatch first_failure;
  for (std::size_t c = 0; c < tries; ++c) {
    const double sample_rho = options.max_inverse_depth * candidates[c] / steps;
    StereoMatch m = RefineCandidate(patch, D, pyramid2, camera2, T_C2_C1, mu_C1, options,
                                    sample_rho);
    if (m.found && options.min_uniqueness_ratio > 0.0) {
      // 4. Uniqueness (docs/estimator-stereo-history.md "False stereo matches and the filter's
      //    consistency"): on repetitive texture a false minimum can align and converge on
      //    the curve as well as the true one; its
      //    rho is then wrong by up to the whole search range while its sigma says 2 %. Every
      //    other minimum of the coarse search is aligned as well (the coarse residuals alone
      //    depend on where the 2 px samples fall on a sharp minimum: 2.2 vs 3.4 grey levels
      //    for two identical places in tests/estimator/stereo_test.cpp); the match is kept
      //    only when no other place on the curve is accepted with a mean |residual| below
      //    min_uniqueness_ratio times the match's. Minima that are coarsely much worse
      //    (2 x ratio) are skipped: they cannot align to a comparable residual.
      const double e_coarse = errors[static_cast<std::size_t>(candidates[c])];
      for (int other : candidates) {
        if (std::abs(other - candidates[c]) <= same_match_samples) continue;
        const double e_other = errors[static_cast<std::size_t>(other)];
        if (e_other > 2.0 * options.min_uniqueness_ratio * e_coarse) continue;
        const StereoMatch rival =
            RefineCandidate(patch, D, pyramid2, camera2, T_C2_C1, mu_C1, options,
                            options.max_inverse_depth * other / steps);
        if (rival.found && std::abs(rival.rho - m.rho) * std::abs(speed) > 4.0 &&
            rival.mean_abs_error < options.min_uniqueness_ratio * m.mean_abs_error) {
          m.found = false;
          m.failure = StereoMatchFailure::kAmbiguous;
          break;
        }
      }
      return m;  // accepted or ambiguous: a later candidate would be ambiguous with this one
    }
    if (m.found) return m;
    if (c == 0) first_failure = m;
  }
  return first_failure;
}

}  // namespace vilma::estimator
