// VioFilter with a second camera (docs/estimator.md, "Stereo"): features stay anchored in the
// VIO camera C1; at a stereo frame each feature is also updated photometrically in camera C2,
// and a new feature takes its inverse distance from a match in C2's image.
#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>

#include "vilma/estimator/stereo.h"
#include "vilma/estimator/vio_filter.h"

namespace vilma::estimator {

bool VioFilter::PredictInSecond(const FilterState& x, int slot,
                                const Eigen::Vector3d& mu_basis_at,
                                OtherCameraPrediction* prediction,
                                Eigen::Matrix<double, 2, 4>* J) const {
  // The bearing moved to the image time (mu + mu_dot td, as in the anchor camera), then into
  // C2: pixel = pi2(R mu_t + rho p). d pixel / d (d, rho, td) with d mu_t / d d = B(mu) to
  // first order.
  const FeatureState& f = x.features[static_cast<std::size_t>(slot)];
  const Eigen::Vector3d mu_dot = BearingRate(x, slot);
  const Eigen::Vector3d mu_t = (f.mu_C + mu_dot * x.td).normalized();
  if (!PredictInOtherCamera(second_camera_.camera, T_C2_C1_, mu_t, f.rho, prediction)) {
    return false;
  }
  if (J != nullptr) {
    const Eigen::Matrix<double, 2, 3> J_mu = prediction->J_pixel_m * T_C2_C1_.rotationMatrix();
    // Tangent columns: d mu / d d of mu = mu0 (+) d at the current mu is
    // (I - mu mu^T) B(mu0) (the basis of the linearization point, as in UpdateFeature).
    const Eigen::Matrix3d proj = Eigen::Matrix3d::Identity() - f.mu_C * f.mu_C.transpose();
    J->leftCols<2>() = J_mu * proj * BearingBasis(mu_basis_at);
    J->col(2) = prediction->J_pixel_rho;
    J->col(3) = J_mu * mu_dot;
  }
  return true;
}

bool VioFilter::UpdateFeatureInSecond(int slot) {
  const std::size_t i = static_cast<std::size_t>(slot);
  const int k = FeatureIndex(slot);
  Track& track = tracks_[i];
  const UpdateOptions& uo = options_.update;
  const PhotometricOptions& po = options_.features.photometric;

  // Columns of the measurement: the bearing tangent (2), rho (1), td (1).
  const int cols[4] = {k, k + 1, k + 2, kIdxTd};
  for (int c = 0; c < 4; ++c) Pcols4_.col(c) = P_.col(cols[c]);
  Eigen::Matrix4d P_sub;
  for (int r = 0; r < 4; ++r) {
    for (int c = 0; c < 4; ++c) P_sub(r, c) = P_(cols[r], cols[c]);
  }

  const Eigen::Vector3d mu0 = x_.features[i].mu_C;
  OtherCameraPrediction pr;
  Eigen::Matrix<double, 2, 4> J0;
  if (!PredictInSecond(x_, slot, mu0, &pr, &J0)) return false;  // not in C2's view: no update, kept
  const Eigen::Matrix2d W = OtherCameraWarp(pr, track.A, track.D);
  if (!W.allFinite() || std::abs(W.determinant()) < 0.05 || std::abs(W.determinant()) > 20.0) {
    return false;
  }

  // 1. Outlier check in C2: patch alignment from the prediction, Mahalanobis gate.
  const AlignmentResult aligned =
      AlignPatch(track.patch, pyramid2_, pr.pixel, W, po, uo.align_iterations);
  // The template's persistent error and C2's own (stereo.persistent_disparity_sigma).
  const double persistent = PersistentPixelVariance(slot) + PersistentDisparityVariance(slot);
  const Eigen::Matrix2d S_pix =
      J0 * P_sub * J0.transpose() +
      (uo.pixel_sigma * uo.pixel_sigma + persistent) * Eigen::Matrix2d::Identity() +
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
    if (!PredictInSecond(x_iter_, slot, mu0, &pr_it, &J_it)) break;
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
        (uo.pixel_sigma * uo.pixel_sigma + persistent) * R_qr * R_qr.transpose();
    const FeatureState& f = x_iter_.features[i];
    Eigen::Vector4d d_cur;
    d_cur << BearingBoxMinus(f.mu_C, mu0), f.rho - x0_.features[i].rho, x_iter_.td - x0_.td;
    PHt_.noalias() = Pcols4_ * H.transpose();
    K_.noalias() = PHt_ * S.inverse();
    dx_.noalias() = K_ * (-y + H * d_cur);
    BoxPlus(x0_, dx_, &x_iter_);
    have_gain = true;
    OtherCameraPrediction pr_new;
    if (!PredictInSecond(x_iter_, slot, mu0, &pr_new, nullptr)) break;
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

namespace {

// Huber weights (rows scaled by sqrt(w), w = min(1, c / |r|)) and the QR reduction of the
// photometric residual to two rows, as in VioFilter::UpdateFeature: with L L^T = J^T J,
// R = L^T and y = Q1^T r = L^-1 J^T r. False if J^T J is singular.
bool ReduceResidual(double huber_threshold, Eigen::VectorXd* residual,
                    Eigen::Matrix<double, Eigen::Dynamic, 2>* J, Eigen::Matrix2d* R,
                    Eigen::Vector2d* y) {
  for (Eigen::Index r = 0; r < residual->size(); ++r) {
    const double a = std::abs((*residual)[r]);
    if (a > huber_threshold) {
      const double sw = std::sqrt(huber_threshold / a);
      (*residual)[r] *= sw;
      J->row(r) *= sw;
    }
  }
  const Eigen::Matrix2d JtJ = J->transpose() * *J;
  const Eigen::LLT<Eigen::Matrix2d> llt(JtJ);
  if (llt.info() != Eigen::Success) return false;
  const Eigen::Matrix2d L = llt.matrixL();
  *R = L.transpose();
  *y = L.triangularView<Eigen::Lower>().solve(J->transpose() * *residual);
  return true;
}

}  // namespace

VioFilter::JointUpdate VioFilter::UpdateFeatureJoint(int slot) {
  const std::size_t i = static_cast<std::size_t>(slot);
  const int k = FeatureIndex(slot);
  const Track& track = tracks_[i];
  const UpdateOptions& uo = options_.update;
  const PhotometricOptions& po = options_.features.photometric;
  const double c = options_.stereo.model_error_correlation;

  // Columns of the joint measurement: the bearing tangent (2), rho (1), td (1); the C1 rows
  // do not depend on rho (that column of their Jacobian is zero).
  const int cols[4] = {k, k + 1, k + 2, kIdxTd};
  for (int col = 0; col < 4; ++col) Pcols4_.col(col) = P_.col(cols[col]);
  Eigen::Matrix4d P_sub;
  for (int r = 0; r < 4; ++r) {
    for (int col = 0; col < 4; ++col) P_sub(r, col) = P_(cols[r], cols[col]);
  }
  const double px2 = uo.pixel_sigma * uo.pixel_sigma;
  // update.persistent_pixel_sigma: the template's persistent error is the same in both
  // cameras (correlation 1).
  const double persistent = PersistentPixelVariance(slot);
  const double persistent_sigma = std::sqrt(persistent);
  // stereo.persistent_disparity_sigma: C2's own persistent error, in C2's rows only.
  const double disparity = PersistentDisparityVariance(slot);
  const Eigen::Matrix2d Z2 = Eigen::Matrix2d::Zero();

  // 1. Each camera's outlier check exactly as in its separate update (alignment from the
  //    prediction, Mahalanobis gate on the aligned pixel).
  const Eigen::Vector3d mu0 = x_.features[i].mu_C;
  const Eigen::Matrix<double, 3, 2> B0 = BearingBasis(mu0);
  Eigen::Vector2d pixel1, J_td1;
  Eigen::Matrix<double, 2, 3> Jp1;
  if (!PredictPixel(x_, slot, &pixel1, &Jp1, &J_td1)) return JointUpdate::kC1Failed;
  const Eigen::Matrix2d W1 = Warp(slot, Jp1);
  if (!W1.allFinite() || std::abs(W1.determinant()) < 0.05 ||
      std::abs(W1.determinant()) > 20.0) {
    return JointUpdate::kC1Failed;
  }
  Eigen::Matrix<double, 4, 4> J0 = Eigen::Matrix4d::Zero();  // d (pixel1, pixel2) / d cols
  J0.block<2, 2>(0, 0) = Jp1 * B0;
  J0.block<2, 1>(0, 3) = J_td1;
  const AlignmentResult aligned1 =
      AlignPatch(track.patch, pyramid_, pixel1, W1, po, uo.align_iterations);
  const Eigen::Matrix2d S1 = J0.topRows<2>() * P_sub * J0.topRows<2>().transpose() +
                             (px2 + persistent + 0.25) * Eigen::Matrix2d::Identity();
  const Eigen::Vector2d e1 = aligned1.pixel - pixel1;
  if (!aligned1.converged || aligned1.mean_abs_error > uo.max_mean_abs_error ||
      !(e1.dot(S1.ldlt().solve(e1)) < uo.mahalanobis_threshold)) {
    return JointUpdate::kC1Failed;
  }
  OtherCameraPrediction pr2;
  Eigen::Matrix<double, 2, 4> J02;
  if (!PredictInSecond(x_, slot, mu0, &pr2, &J02)) return JointUpdate::kC2Failed;
  const Eigen::Matrix2d W2 = OtherCameraWarp(pr2, track.A, track.D);
  if (!W2.allFinite() || std::abs(W2.determinant()) < 0.05 ||
      std::abs(W2.determinant()) > 20.0) {
    return JointUpdate::kC2Failed;
  }
  J0.bottomRows<2>() = J02;
  const AlignmentResult aligned2 =
      AlignPatch(track.patch, pyramid2_, pr2.pixel, W2, po, uo.align_iterations);
  const Eigen::Matrix2d S2 =
      J02 * P_sub * J02.transpose() +
      (px2 + persistent + disparity + 0.25) * Eigen::Matrix2d::Identity();
  const Eigen::Vector2d e2 = aligned2.pixel - pr2.pixel;
  if (!aligned2.converged || aligned2.mean_abs_error > uo.max_mean_abs_error ||
      !(e2.dot(S2.ldlt().solve(e2)) < uo.mahalanobis_threshold)) {
    return JointUpdate::kC2Rejected;
  }

  // 2. Iterated EKF on both photometric errors at once (IJRR 2017, sec. 5, with the rows of
  //    both cameras): y = [y1; y2], H = [R1 J1; R2 J2] (4 x 4 over the columns above),
  //    noise N = StereoJointNoise(R1, R2, ...): the template's model error is shared.
  //    Start: one step with both aligned pixels.
  x0_ = x_;
  Eigen::Matrix4d N_pix = StereoJointNoise(Eigen::Matrix2d::Identity(),
                                           Eigen::Matrix2d::Identity(), 0.0, uo.pixel_sigma, c);
  N_pix += StereoJointNoise(Eigen::Matrix2d::Identity(), Eigen::Matrix2d::Identity(), 0.0,
                            persistent_sigma, 1.0);
  N_pix += StereoJointNoise(Z2, Eigen::Matrix2d::Identity(), 0.0, std::sqrt(disparity), 0.0);
  N_pix += 0.25 * Eigen::Matrix4d::Identity();  // alignment precision [px^2]
  Eigen::Vector4d e;
  e << e1, e2;
  PHt4_.noalias() = Pcols4_ * J0.transpose();
  K4_.noalias() = PHt4_ * (J0 * P_sub * J0.transpose() + N_pix).inverse();
  dx_.noalias() = K4_ * e;
  BoxPlus(x0_, dx_, &x_iter_);

  Eigen::Matrix4d S = Eigen::Matrix4d::Identity();
  bool have_gain = false;
  Eigen::Vector2d last1 = aligned1.pixel, last2 = aligned2.pixel;
  for (int it = 0; it < uo.max_iterations; ++it) {
    const Eigen::Vector3d& mu = x_iter_.features[i].mu_C;
    Eigen::Vector2d p1, Jtd1;
    Eigen::Matrix<double, 2, 3> Jp;
    OtherCameraPrediction p2;
    Eigen::Matrix<double, 2, 4> J2;
    if (!PredictPixel(x_iter_, slot, &p1, &Jp, &Jtd1)) break;
    if (!PredictInSecond(x_iter_, slot, mu0, &p2, &J2)) break;
    Eigen::Matrix2d R1, R2;
    Eigen::Vector2d y1, y2;
    if (!ComputePhotometricResidual(track.patch, pyramid_, p1, W1, po, &residual_,
                                    &J_residual_pixel_) ||
        !ReduceResidual(uo.huber_threshold, &residual_, &J_residual_pixel_, &R1, &y1)) {
      break;
    }
    if (!ComputePhotometricResidual(track.patch, pyramid2_, p2.pixel, W2, po, &residual2_,
                                    &J_residual_pixel2_) ||
        !ReduceResidual(uo.huber_threshold, &residual2_, &J_residual_pixel2_, &R2, &y2)) {
      break;
    }
    Eigen::Matrix<double, 2, 4> J1 = Eigen::Matrix<double, 2, 4>::Zero();
    J1.leftCols<2>() = Jp * (Eigen::Matrix3d::Identity() - mu * mu.transpose()) * B0;
    J1.col(3) = Jtd1;
    Eigen::Matrix4d H;
    H.topRows<2>() = R1 * J1;
    H.bottomRows<2>() = R2 * J2;
    Eigen::Vector4d y;
    y << y1, y2;
    S = H * P_sub * H.transpose() +
        StereoJointNoise(R1, R2, uo.intensity_sigma, uo.pixel_sigma, c) +
        StereoJointNoise(R1, R2, 0.0, persistent_sigma, 1.0) +
        StereoJointNoise(Z2, R2, 0.0, std::sqrt(disparity), 0.0);
    const FeatureState& f = x_iter_.features[i];
    Eigen::Vector4d d_cur;
    d_cur << BearingBoxMinus(f.mu_C, mu0), f.rho - x0_.features[i].rho, x_iter_.td - x0_.td;
    PHt4_.noalias() = Pcols4_ * H.transpose();
    K4_.noalias() = PHt4_ * S.inverse();
    dx_.noalias() = K4_ * (-y + H * d_cur);
    BoxPlus(x0_, dx_, &x_iter_);
    have_gain = true;
    Eigen::Vector2d n1;
    OtherCameraPrediction n2;
    if (!PredictPixel(x_iter_, slot, &n1, nullptr, nullptr) ||
        !PredictInSecond(x_iter_, slot, mu0, &n2, nullptr)) {
      break;
    }
    const bool converged = (n1 - last1).norm() < uo.convergence_px &&
                           (n2.pixel - last2).norm() < uo.convergence_px;
    last1 = n1;
    last2 = n2.pixel;
    if (converged) break;
  }
  if (!have_gain || !x_iter_.features[i].mu_C.allFinite() ||
      !std::isfinite(x_iter_.features[i].rho)) {
    return JointUpdate::kC2Failed;  // nothing applied; C1 alone is tried by the caller
  }
  x_ = x_iter_;
  KS4_.noalias() = K4_ * S;
  P_.noalias() -= KS4_ * K4_.transpose();
  tracks_[i].failures = 0;
  ++tracks_[i].age;
  ++tracks_[i].template_updates;
  tracks_[i].updated = true;
  return JointUpdate::kDone;
}

double VioFilter::PersistentDisparityVariance(int slot) const {
  // As PersistentPixelVariance (vio_filter.cpp), for the error of C2's alignment of the C1
  // template that persists from frame to frame: n updates draw ~ln(n) / s^2 of disparity
  // information from it instead of n / s^2.
  const double s = options_.stereo.persistent_disparity_sigma;
  return s * s * static_cast<double>(tracks_[static_cast<std::size_t>(slot)].template_updates + 1);
}

StereoMatch VioFilter::MatchInSecond(const MultilevelPatch& patch, const Eigen::Matrix2d& D,
                                     const Eigen::Vector3d& mu) const {
  const StereoOptions& so = options_.stereo;
  StereoMatchOptions mo;
  mo.max_inverse_depth = so.max_inverse_depth;
  mo.search_step_px = so.search_step_px;
  mo.max_match_error = so.max_match_error;
  mo.max_epipolar_px = so.max_epipolar_px;
  mo.pixel_sigma = so.match_pixel_sigma;
  mo.min_inverse_depth_sigma = so.min_inverse_depth_sigma;
  mo.min_uniqueness_ratio = so.min_uniqueness_ratio;
  mo.align_iterations = so.match_align_iterations > 0 ? so.match_align_iterations
                                                      : options_.update.align_iterations;
  mo.max_candidates = so.match_candidates;
  mo.photometric = options_.features.photometric;
  return MatchInOtherCamera(patch, D, pyramid2_, second_camera_.camera, T_C2_C1_, mu, mo);
}

void VioFilter::UpdateFeatureInBoth(int slot, FrameResult* result) {
  // Both cameras in one update; a camera that fails leaves the other's update alone.
  const JointUpdate j = UpdateFeatureJoint(slot);
  Track& track = tracks_[static_cast<std::size_t>(slot)];
  if (j == JointUpdate::kDone) {
    ++result->num_updated;
    ++result->num_stereo_updated;
    NoteSecondCameraUpdate(slot);
    track.disagreements = 0;
    return;
  }
  if (UpdateFeature(slot)) {
    ++result->num_updated;
    // C1 tracks the feature, C2 sees its predicted place but rejects it: counted, and after
    // stereo.max_disagreements frames in a row the feature is removed (AddImage).
    track.disagreements = j == JointUpdate::kC2Rejected ? track.disagreements + 1 : 0;
  } else {
    ++result->num_rejected;
  }
  if (j == JointUpdate::kC1Failed && UpdateFeatureInSecond(slot)) {
    ++result->num_stereo_updated;
    NoteSecondCameraUpdate(slot);
  } else {
    ++stats_.stereo_rejections;
  }
}

void VioFilter::UpdateFeaturesInSecond(FrameResult* result) {
  // The same features in the second camera (ROVIO's multi-camera update): one more iterated
  // update per feature, after all updates in the anchor camera.
  for (int slot = 0; slot < static_cast<int>(x_.features.size()); ++slot) {
    if (!x_.features[static_cast<std::size_t>(slot)].active) continue;
    if (tracks_[static_cast<std::size_t>(slot)].probation > 0) continue;  // C1 alone
    if (UpdateFeatureInSecond(slot)) {
      ++result->num_stereo_updated;
      NoteSecondCameraUpdate(slot);
    } else {
      ++stats_.stereo_rejections;
    }
  }
}

bool VioFilter::ProbeStereoCandidate(const FeatureCandidate& candidate) {
  const FeatureOptions& fo = options_.features;
  Eigen::Vector3d mu;
  Eigen::Matrix<double, 3, 2> J_mu_px;
  if (!probe_patch_.Extract(pyramid_, candidate.pixel, Eigen::Matrix2d::Identity(), fo.patch) ||
      probe_patch_.ShiTomasiScore() < fo.min_shi_tomasi ||
      !camera_.camera.Unproject(candidate.pixel, &mu, &J_mu_px)) {
    return true;  // not refused here: AddFeatures drops it as without the probe
  }
  const StereoMatch m = MatchInSecond(probe_patch_, BearingBasis(mu).transpose() * J_mu_px, mu);
  probed_matches_.emplace_back(candidate.pixel, m);
  return m.found;
}

void VioFilter::InitializeDepthFromStereo(int slot, const Eigen::Vector2d& pixel) {
  // A candidate matched while choosing (stereo.candidates_per_slot) keeps that match: the same
  // patch in the same images.
  const auto probed = std::find_if(probed_matches_.begin(), probed_matches_.end(),
                                   [&pixel](const auto& pm) { return pm.first == pixel; });
  if (probed != probed_matches_.end()) {
    ApplyInitialStereoMatch(slot, probed->second);
    return;
  }
  const std::size_t i = static_cast<std::size_t>(slot);
  ApplyInitialStereoMatch(slot, MatchInSecond(tracks_[i].patch, tracks_[i].D,
                                              x_.features[i].mu_C));
}

void VioFilter::ApplyInitialStereoMatch(int slot, const StereoMatch& match) {
  const std::size_t i = static_cast<std::size_t>(slot);
  if (!match.found) {
    ++stats_.stereo_match_failures;
    ++stats_.stereo_match_failure_reasons[static_cast<std::size_t>(match.failure)];
    return;
  }
  ++stats_.stereo_matches;
  tracks_[i].probation = options_.stereo.probation_frames;
  tracks_[i].probation_nis = 0.0;
  tracks_[i].depth_matched = true;
  tracks_[i].deferred_tries = 0;
  x_.features[i].rho = match.rho;
  const int k = FeatureIndex(slot);
  P_(k + 2, k + 2) = match.rho_sigma * match.rho_sigma;
}

void VioFilter::NoteSecondCameraUpdate(int slot) {
  Track& track = tracks_[static_cast<std::size_t>(slot)];
  if (track.c2_updates == 0 && !track.depth_matched) {
    ++stats_.unmatched_taking_c2;
    stats_.unmatched_c2_updates_before += track.age;
  }
  ++track.c2_updates;
}

void VioFilter::DeferredStereoMatches() {
  // A feature that started without a stereo depth (no match, or stereo.init_depth off) and has
  // not been caught by the second camera's update since: its C1 template (warped by the
  // tracked A: W2 = J_pixel_bearing A D, as in the update) is searched along the epipolar curve
  // of the current bearing. A match is a measurement of rho, z = rho_match with variance
  // sigma^2 (match_pixel_sigma through |d pixel / d rho|), applied as a scalar EKF update
  // (H = e_rho): K = P e_rho / s, s = P_rho,rho + sigma^2, x = x [+] K (z - rho), P -= K s K^T.
  // The feature keeps the cross-covariances it has gained with the pose since its detection
  // (an overwrite of rho and its variance would break them). Gated at
  // update.mahalanobis_threshold on (z - rho)^2 / s (a conservative gate for one DoF).
  for (int slot = 0; slot < static_cast<int>(x_.features.size()); ++slot) {
    const std::size_t i = static_cast<std::size_t>(slot);
    Track& track = tracks_[i];
    if (!x_.features[i].active || track.deferred_tries <= 0) continue;
    if (track.depth_matched || track.c2_updates > 0) {  // C2 has it already
      track.deferred_tries = 0;
      continue;
    }
    --track.deferred_tries;
    const StereoMatch match =
        MatchInSecond(track.patch, track.A * track.D, x_.features[i].mu_C);
    if (!match.found) {
      ++stats_.deferred_match_failures;
      continue;
    }
    const int k = FeatureIndex(slot) + 2;
    const double s = P_(k, k) + match.rho_sigma * match.rho_sigma;
    const double innovation = match.rho - x_.features[i].rho;
    if (!(s > 0.0) || !(innovation * innovation / s < options_.update.mahalanobis_threshold)) {
      ++stats_.deferred_match_gated;
      continue;
    }
    deferred_gain_ = P_.col(k) / s;
    BoxPlus(x_, deferred_gain_ * innovation, &x_iter_);
    x_ = x_iter_;
    P_.noalias() -= s * deferred_gain_ * deferred_gain_.transpose();
    track.depth_matched = true;
    track.deferred_tries = 0;
    ++stats_.deferred_matches;
  }
}

}  // namespace vilma::estimator
