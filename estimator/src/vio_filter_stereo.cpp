// VioFilter with a second camera (docs/estimator.md, "Stereo"): features stay anchored in the
// VIO camera C1; at a stereo frame each feature is also updated photometrically in camera C2,
// and a new feature takes its inverse distance from a match in C2's image.
#include <Eigen/Cholesky>
#include <cmath>

#include "vilma/estimator/stereo.h"
#include "vilma/estimator/vio_filter.h"

namespace vilma::estimator {

bool VioFilter::UpdateFeatureInSecond(int slot) {
  const std::size_t i = static_cast<std::size_t>(slot);
  const int k = FeatureIndex(slot);
  Track& track = tracks_[i];
  const UpdateOptions& uo = options_.update;
  const PhotometricOptions& po = options_.features.photometric;
  const Camera& camera2 = second_camera_.camera;

  // Columns of the measurement: the bearing tangent (2), rho (1), td (1).
  const int cols[4] = {k, k + 1, k + 2, kIdxTd};
  for (int c = 0; c < 4; ++c) Pcols4_.col(c) = P_.col(cols[c]);
  Eigen::Matrix4d P_sub;
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) P_sub(r, c) = P_(cols[r], cols[c]);
  }

  // Prediction at state x: the bearing moved to the image time (mu + mu_dot td, as in the
  // anchor camera), then into C2: pixel = pi2(R mu_t + rho p). d pixel / d (d, rho, td) with
  // d mu_t / d d = B(mu) to first order.
  auto predict = [&](const FilterState& x, const Eigen::Vector3d& mu_basis_at,
                     OtherCameraPrediction* pr, Eigen::Matrix<double, 2, 4>* J) -> bool {
    const FeatureState& f = x.features[i];
    const Eigen::Vector3d mu_dot = BearingRate(x, slot);
    const Eigen::Vector3d mu_t = (f.mu_C + mu_dot * x.td).normalized();
    const Transformation& T21 = T_C2_C1_;
    if (!PredictInOtherCamera(camera2, T21, mu_t, f.rho, pr)) return false;
    if (J != nullptr) {
      const Eigen::Matrix<double, 2, 3> J_mu = pr->J_pixel_m * T21.rotationMatrix();
      // Tangent columns: d mu / d d of mu = mu0 (+) d at the current mu is
      // (I - mu mu^T) B(mu0) (the basis of the linearization point, as in UpdateFeature).
      const Eigen::Matrix3d proj = Eigen::Matrix3d::Identity() - f.mu_C * f.mu_C.transpose();
      J->leftCols<2>() = J_mu * proj * BearingBasis(mu_basis_at);
      J->col(2) = pr->J_pixel_rho;
      J->col(3) = J_mu * mu_dot;
    }
    return true;
  };

  const Eigen::Vector3d mu0 = x_.features[i].mu_C;
  OtherCameraPrediction pr;
  Eigen::Matrix<double, 2, 4> J0;
  if (!predict(x_, mu0, &pr, &J0)) return false;  // not in C2's view: no update, kept
  const Eigen::Matrix2d W = OtherCameraWarp(pr, track.A, track.D);
  if (!W.allFinite() || std::abs(W.determinant()) < 0.05 || std::abs(W.determinant()) > 20.0) {
    return false;
  }

  // 1. Outlier check in C2: patch alignment from the prediction, Mahalanobis gate.
  const AlignmentResult aligned =
      AlignPatch(track.patch, pyramid2_, pr.pixel, W, po, uo.align_iterations);
  const Eigen::Matrix2d S_pix = J0 * P_sub * J0.transpose() +
                                uo.pixel_sigma * uo.pixel_sigma * Eigen::Matrix2d::Identity() +
                                Eigen::Matrix2d::Identity() * 0.25;  // alignment precision
  const Eigen::Vector2d e = aligned.pixel - pr.pixel;
  if (!aligned.converged || aligned.mean_abs_error > uo.max_mean_abs_error ||
      !(e.dot(S_pix.ldlt().solve(e)) < uo.mahalanobis_threshold)) {
    return false;
  }

  // 2. Iterated EKF on the photometric error in C2, as UpdateFeature (IJRR 2017, sec. 5),
  //    with rho among the measured columns: x_{j+1} = x0 [+] K_j (-y_j + H_j (x_j [-] x0)).
  x0_ = x_;
  PHt_.noalias() = Pcols4_ * J0.transpose();
  K_.noalias() = PHt_ * S_pix.inverse();
  dx_.noalias() = K_ * e;
  BoxPlus(x0_, dx_, &x_iter_);

  Eigen::Matrix2d S = Eigen::Matrix2d::Identity();
  bool have_gain = false;
  Eigen::Vector2d last_pixel = aligned.pixel;
  for (int it = 0; it < uo.max_iterations; ++it) {
    OtherCameraPrediction pr_it;
    Eigen::Matrix<double, 2, 4> J_it;
    if (!predict(x_iter_, mu0, &pr_it, &J_it)) break;
    if (!ComputePhotometricResidual(track.patch, pyramid2_, pr_it.pixel, W, po, &residual_,
                                    &J_residual_pixel_)) {
      break;
    }
    for (Eigen::Index r = 0; r < residual_.size(); ++r) {  // Huber weights
      const double a = std::abs(residual_[r]);
      if (a > uo.huber_threshold) {
        const double sw = std::sqrt(uo.huber_threshold / a);
        residual_[r] *= sw;
        J_residual_pixel_.row(r) *= sw;
      }
    }
    // QR reduction to 2 rows through the normal matrix (see UpdateFeature).
    const Eigen::Matrix2d JtJ = J_residual_pixel_.transpose() * J_residual_pixel_;
    const Eigen::LLT<Eigen::Matrix2d> llt(JtJ);
    if (llt.info() != Eigen::Success) break;
    const Eigen::Matrix2d L = llt.matrixL();
    const Eigen::Matrix2d R_qr = L.transpose();
    const Eigen::Vector2d y =
        L.triangularView<Eigen::Lower>().solve(J_residual_pixel_.transpose() * residual_);
    const Eigen::Matrix<double, 2, 4> H = R_qr * J_it;
    S = H * P_sub * H.transpose() +
        uo.intensity_sigma * uo.intensity_sigma * Eigen::Matrix2d::Identity() +
        uo.pixel_sigma * uo.pixel_sigma * R_qr * R_qr.transpose();
    const FeatureState& f = x_iter_.features[i];
    Eigen::Vector4d d_cur;
    d_cur << BearingBoxMinus(f.mu_C, mu0), f.rho - x0_.features[i].rho, x_iter_.td - x0_.td;
    PHt_.noalias() = Pcols4_ * H.transpose();
    K_.noalias() = PHt_ * S.inverse();
    dx_.noalias() = K_ * (-y + H * d_cur);
    BoxPlus(x0_, dx_, &x_iter_);
    have_gain = true;
    OtherCameraPrediction pr_new;
    if (!predict(x_iter_, mu0, &pr_new, nullptr)) break;
    const bool converged = (pr_new.pixel - last_pixel).norm() < uo.convergence_px;
    last_pixel = pr_new.pixel;
    if (converged) break;
  }
  if (!have_gain || !x_iter_.features[i].mu_C.allFinite() ||
      !std::isfinite(x_iter_.features[i].rho)) {
    return false;
  }
  x_ = x_iter_;
  KS_.noalias() = K_ * S;
  P_.noalias() -= KS_ * K_.transpose();
  return true;
}

void VioFilter::InitializeDepthFromStereo(int slot) {
  const std::size_t i = static_cast<std::size_t>(slot);
  const StereoOptions& so = options_.stereo;
  StereoMatchOptions mo;
  mo.max_inverse_depth = so.max_inverse_depth;
  mo.search_step_px = so.search_step_px;
  mo.max_match_error = so.max_match_error;
  mo.max_epipolar_px = so.max_epipolar_px;
  mo.pixel_sigma = so.match_pixel_sigma;
  mo.min_inverse_depth_sigma = so.min_inverse_depth_sigma;
  mo.min_uniqueness_ratio = so.min_uniqueness_ratio;
  mo.align_iterations = options_.update.align_iterations;
  mo.photometric = options_.features.photometric;
  FeatureState& f = x_.features[i];
  const StereoMatch match = MatchInOtherCamera(tracks_[i].patch, tracks_[i].D, pyramid2_,
                                               second_camera_.camera, T_C2_C1_, f.mu_C, mo);
  if (!match.found) {
    ++stats_.stereo_match_failures;
    ++stats_.stereo_match_failure_reasons[static_cast<std::size_t>(match.failure)];
    return;
  }
  ++stats_.stereo_matches;
  f.rho = match.rho;
  const int k = FeatureIndex(slot);
  P_(k + 2, k + 2) = match.rho_sigma * match.rho_sigma;
}

}  // namespace vilma::estimator
