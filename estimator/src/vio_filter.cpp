#include "vilma/estimator/vio_filter.h"

#include <Eigen/Cholesky>
#include <algorithm>
#include <cmath>
#include <utility>

#include "vilma/core/error.h"
#include "vilma/core/imu.h"
#include "vilma/estimator/feature_detector.h"

namespace vilma::estimator {

VioFilter::VioFilter(const SensorRig& rig, int camera_index, const FilterOptions& options)
    : rig_(rig),
      options_(options),
      initializer_(rig.cameras.empty() ? CameraConfig() : rig.cameras.front(),
                   rig.imu.gravity_magnitude, options.init.dynamic) {
  ThrowIfInvalid(options.Validate(), "filter options");
  if (camera_index < 0 || camera_index >= static_cast<int>(rig.cameras.size())) {
    throw InputError(FormatInputError("sensor rig", "cameras",
                                      "a camera with index " + std::to_string(camera_index)));
  }
  const std::string rig_error = rig.Validate();
  if (!rig_error.empty()) throw InputError(FormatInputError("sensor rig", "", rig_error));
  camera_ = rig.cameras[static_cast<std::size_t>(camera_index)];
  if (options.stereo.enabled) {
    if (options.stereo.camera == camera_index ||
        options.stereo.camera >= static_cast<int>(rig.cameras.size())) {
      throw InputError(FormatInputError(
          "filter options", "stereo.camera",
          "a camera of the rig other than the VIO camera " + std::to_string(camera_index)));
    }
    stereo_ = true;
    second_camera_ = rig.cameras[static_cast<std::size_t>(options.stereo.camera)];
    T_C2_C1_ = second_camera_.T_I_C.inverse() * camera_.T_I_C;
    // stereo.max_features / detect_below replace the mono counts (0: kept).
    const StereoOptions& so = options.stereo;
    if (so.max_features > 0) options_.features.max_features = so.max_features;
    if (so.detect_below > 0) options_.features.detect_below = so.detect_below;
  }
  initializer_ = VisualInertialInitializer(camera_, rig.imu.gravity_magnitude, options.init.dynamic);
  // The detector ranks candidates with the tracker's own patch.
  options_.features.detector.patch = options_.features.patch;

  const double s = options.noise.imu_noise_scale;
  noise_.gyro_noise_density = s * rig.imu.noise.gyroscope_noise_density;
  noise_.accel_noise_density = s * rig.imu.noise.accelerometer_noise_density;
  noise_.gyro_random_walk = s * rig.imu.noise.gyroscope_random_walk;
  noise_.accel_random_walk = s * rig.imu.noise.accelerometer_random_walk;
  noise_.bearing = options.noise.bearing;
  noise_.inverse_depth = options.noise.inverse_depth;
  if (options.estimate_extrinsics) {
    noise_.extrinsic_rotation = options.noise.extrinsic_rotation;
    noise_.extrinsic_translation = options.noise.extrinsic_translation;
  }
  if (options.estimate_time_offset) noise_.time_offset = options.noise.time_offset;

  const int slots = options_.features.max_features;
  x_.features.assign(static_cast<std::size_t>(slots), FeatureState());
  x_.q_I_C = camera_.T_I_C.rotation();
  x_.p_I_C = camera_.T_I_C.translation();
  P_ = Eigen::MatrixXd::Zero(x_.dim(), x_.dim());
  tracks_.assign(static_cast<std::size_t>(slots), Track());
  jacobians_.Resize(slots);
  x0_ = x_;
  x_iter_ = x_;
  dx_ = Eigen::VectorXd::Zero(x_.dim());
  PHt_.resize(x_.dim(), 2);
  K_.resize(x_.dim(), 2);
  KS_.resize(x_.dim(), 2);
  Pcols_.resize(x_.dim(), 3);
  if (stereo_) {
    Pcols4_.resize(x_.dim(), 4);
    PHt4_.resize(x_.dim(), 4);
    K4_.resize(x_.dim(), 4);
    KS4_.resize(x_.dim(), 4);
  }
  occupied_.reserve(static_cast<std::size_t>(slots));
  imu_.reserve(4096);
}

void VioFilter::AddImu(const ImuSample& sample) {
  if (!imu_.empty() && sample.t_ns <= imu_.back().t_ns) {
    ++stats_.imu_duplicates;  // duplicated or out of order: never integrate twice
    return;
  }
  if (!sample.omega_I.allFinite() || !sample.a_I.allFinite()) {
    ++stats_.imu_duplicates;
    return;
  }
  if (!imu_.empty()) {
    const double nominal_ns = 1e9 / rig_.imu.rate_hz;
    if (static_cast<double>(sample.t_ns - imu_.back().t_ns) > 5.0 * nominal_ns) ++stats_.imu_gaps;
  }
  ++stats_.imu_samples;
  imu_.push_back(sample);
  if (!initialized_) initializer_.AddImu(sample);
  if (!initialized_ && imu_.size() > 4000) {
    // Before initialization only the last window matters.
    imu_.erase(imu_.begin(), imu_.begin() + 2000);
  }
}

void VioFilter::Propagate(int64_t t_target) {
  if (imu_.empty()) {
    x_.t_ns = std::max(x_.t_ns, t_target);
    return;
  }
  auto measurement_at = [&](int64_t t, Eigen::Vector3d* omega, Eigen::Vector3d* a) {
    // Linear interpolation; held constant outside the buffered samples.
    auto it = std::upper_bound(imu_.begin(), imu_.end(), t,
                               [](int64_t v, const ImuSample& s) { return v < s.t_ns; });
    if (it == imu_.begin()) {
      *omega = it->omega_I;
      *a = it->a_I;
    } else if (it == imu_.end()) {
      *omega = imu_.back().omega_I;
      *a = imu_.back().a_I;
    } else {
      const ImuSample s = InterpolateImu(*(it - 1), *it, t);
      *omega = s.omega_I;
      *a = s.a_I;
    }
  };
  while (x_.t_ns < t_target) {
    auto next = std::upper_bound(imu_.begin(), imu_.end(), x_.t_ns,
                                 [](int64_t v, const ImuSample& s) { return v < s.t_ns; });
    const int64_t t1 = next == imu_.end() ? t_target : std::min(next->t_ns, t_target);
    const int64_t t0 = x_.t_ns;
    Eigen::Vector3d omega, a;
    measurement_at(t0 + (t1 - t0) / 2, &omega, &a);  // midpoint of the interval
    last_omega_m_ = omega;
    const double dt = static_cast<double>(t1 - t0) * 1e-9;
    PropagateMean(omega, a, dt, rig_.imu.gravity_magnitude, &x_, &jacobians_);
    if (options_.yaw_observability_constraint) {
      ConstrainYawNullspace(yaw_anchor_p_, yaw_anchor_v_, yaw_anchor_q_, x_, &jacobians_);
      yaw_anchor_p_ = x_.p_M_I;
      yaw_anchor_v_ = x_.v_M;
      yaw_anchor_q_ = x_.q_M_I;
    }
    for (std::size_t i = 0; i < x_.features.size(); ++i) {
      if (x_.features[i].active) {
        tracks_[i].A = jacobians_.F_feature_self[i].topLeftCorner<2, 2>() * tracks_[i].A;
      }
    }
    PropagateCovariance(jacobians_, noise_, dt, x_.features, &P_, &workspace_);
    x_.t_ns = t1;
  }
  // Keep the last init window of samples (for a re-initialization after a reset).
  const int64_t keep_from = x_.t_ns - static_cast<int64_t>(options_.init.window_s * 1e9);
  auto first_kept = std::lower_bound(imu_.begin(), imu_.end(), keep_from,
                                     [](const ImuSample& s, int64_t v) { return s.t_ns < v; });
  if (first_kept != imu_.begin()) --first_kept;
  imu_.erase(imu_.begin(), first_kept);
}

Eigen::Matrix2d VioFilter::Warp(int slot, const Eigen::Matrix<double, 2, 3>& J_pixel_p_C) const {
  // d pixel(now) / d pixel(extraction) = d pixel/d tangent(now) * A * d tangent/d pixel (ext.):
  // the affine patch warp from the bearing-vector Jacobians (IJRR 2017, sec. 4.2).
  const std::size_t i = static_cast<std::size_t>(slot);
  return J_pixel_p_C * BearingBasis(x_.features[i].mu_C) * tracks_[i].A * tracks_[i].D;
}

Eigen::Vector3d VioFilter::BearingRate(const FilterState& x, int slot) const {
  // mu_dot = -omega_C x mu - rho (I - mu mu^T) v_C (IJRR 2017, eq. 12), with the camera rates
  // of the last IMU measurement.
  const FeatureState& f = x.features[static_cast<std::size_t>(slot)];
  const Eigen::Matrix3d R_C_I = x.q_I_C.toRotationMatrix().transpose();
  const Eigen::Vector3d omega_I = last_omega_m_ - x.b_g;
  const Eigen::Vector3d omega_C = R_C_I * omega_I;
  const Eigen::Vector3d v_C =
      R_C_I * (x.q_M_I.conjugate() * x.v_M + omega_I.cross(x.p_I_C));
  return -omega_C.cross(f.mu_C) - f.rho * (v_C - f.mu_C.dot(v_C) * f.mu_C);
}

bool VioFilter::PredictPixel(const FilterState& x, int slot, Eigen::Vector2d* pixel,
                             Eigen::Matrix<double, 2, 3>* J_pixel_mu,
                             Eigen::Vector2d* J_pixel_td) const {
  // The image was taken td after the state's time: mu(t + td) ~ mu + mu_dot td.
  const Eigen::Vector3d mu_dot = BearingRate(x, slot);
  const Eigen::Vector3d mu_t =
      (x.features[static_cast<std::size_t>(slot)].mu_C + mu_dot * x.td).normalized();
  Eigen::Matrix<double, 2, 3> Jp;
  if (camera_.camera.Project(mu_t, pixel, &Jp) != Camera::ProjectionResult::kValid) return false;
  if (J_pixel_mu != nullptr) *J_pixel_mu = Jp;
  if (J_pixel_td != nullptr) *J_pixel_td = Jp * mu_dot;
  return true;
}

bool VioFilter::UpdateFeature(int slot) {
  const std::size_t i = static_cast<std::size_t>(slot);
  const int k = FeatureIndex(slot);
  Track& track = tracks_[i];
  const UpdateOptions& uo = options_.update;
  const PhotometricOptions& po = options_.features.photometric;

  // The measurement depends on the feature's bearing (2 columns) and on the time-offset
  // correction td (1 column): gather those columns of P once.
  const int cols[3] = {k, k + 1, kIdxTd};
  for (int c = 0; c < 3; ++c) Pcols_.col(c) = P_.col(cols[c]);
  Eigen::Matrix3d P_sub;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) P_sub(r, c) = P_(cols[r], cols[c]);
  }

  Eigen::Vector2d pixel, J_td;
  Eigen::Matrix<double, 2, 3> Jp;
  if (!PredictPixel(x_, slot, &pixel, &Jp, &J_td)) {
    track.failures = options_.features.max_failures;  // left the image: drop
    return false;
  }
  const Eigen::Matrix2d W = Warp(slot, Jp);
  if (!W.allFinite() || std::abs(W.determinant()) < 0.05 || std::abs(W.determinant()) > 20.0) {
    track.failures = options_.features.max_failures;  // degenerate perspective: drop
    return false;
  }

  // 1. Outlier check: align the patch from the prediction and gate the aligned pixel by the
  //    predicted pixel covariance (Mahalanobis, 2 DoF).
  const AlignmentResult aligned =
      AlignPatch(track.patch, pyramid_, pixel, W, po, uo.align_iterations);
  const Eigen::Matrix<double, 3, 2> B0 = BearingBasis(x_.features[i].mu_C);
  Eigen::Matrix<double, 2, 3> J0;  // d pixel / d (dmu, dtd)
  J0 << Jp * B0, J_td;
  const double persistent = PersistentPixelVariance(slot);
  const Eigen::Matrix2d S_pix =
      J0 * P_sub * J0.transpose() +
      (uo.pixel_sigma * uo.pixel_sigma + persistent) * Eigen::Matrix2d::Identity() +
      Eigen::Matrix2d::Identity() * 0.25;  // alignment precision [px^2]
  const Eigen::Vector2d e = aligned.pixel - pixel;
  last_nis_ = e.dot(S_pix.ldlt().solve(e));
  if (!aligned.converged || aligned.mean_abs_error > uo.max_mean_abs_error ||
      !(last_nis_ < uo.mahalanobis_threshold)) {
    ++track.failures;
    return false;
  }

  // 2. Iterated EKF on the photometric error (IJRR 2017, sec. 5). The iteration starts at the
  //    state that explains the aligned pixel (a better first linearization point; the IEKF
  //    result depends only on the last one): x_{j+1} = x0 [+] K_j (-y_j + H_j (x_j [-] x0)).
  x0_ = x_;
  const Eigen::Vector3d mu0 = x0_.features[i].mu_C;
  PHt_.noalias() = Pcols_ * J0.transpose();
  K_.noalias() = PHt_ * S_pix.inverse();
  dx_.noalias() = K_ * e;
  BoxPlus(x0_, dx_, &x_iter_);

  Eigen::Matrix2d S = Eigen::Matrix2d::Identity();
  bool have_gain = false;
  Eigen::Vector2d last_pixel = aligned.pixel;
  for (int it = 0; it < uo.max_iterations; ++it) {
    const Eigen::Vector3d& mu = x_iter_.features[i].mu_C;
    Eigen::Vector2d pixel_it, J_td_it;
    Eigen::Matrix<double, 2, 3> Jp_it;
    if (!PredictPixel(x_iter_, slot, &pixel_it, &Jp_it, &J_td_it)) break;
    if (!ComputePhotometricResidual(track.patch, pyramid_, pixel_it, W, po, &residual_,
                                    &J_residual_pixel_)) {
      break;
    }
    // Huber weights: rows scaled by sqrt(w), w = min(1, c / |r|).
    for (Eigen::Index r = 0; r < residual_.size(); ++r) {
      const double a = std::abs(residual_[r]);
      if (a > uo.huber_threshold) {
        const double sw = std::sqrt(uo.huber_threshold / a);
        residual_[r] *= sw;
        J_residual_pixel_.row(r) *= sw;
      }
    }
    // QR reduction J = Q R to 2 rows: with L L^T = J^T J (R = L^T), Q1^T r = L^-1 J^T r.
    const Eigen::Matrix2d JtJ = J_residual_pixel_.transpose() * J_residual_pixel_;
    const Eigen::LLT<Eigen::Matrix2d> llt(JtJ);
    if (llt.info() != Eigen::Success) break;
    const Eigen::Matrix2d L = llt.matrixL();
    const Eigen::Matrix2d R_qr = L.transpose();
    const Eigen::Vector2d y =
        L.triangularView<Eigen::Lower>().solve(J_residual_pixel_.transpose() * residual_);
    // d pixel / d (tangent at mu0, td), evaluated at the current state.
    Eigen::Matrix<double, 2, 3> J_it;
    J_it << Jp_it * (Eigen::Matrix3d::Identity() - mu * mu.transpose()) * B0, J_td_it;
    const Eigen::Matrix<double, 2, 3> H = R_qr * J_it;
    S = H * P_sub * H.transpose() +
        uo.intensity_sigma * uo.intensity_sigma * Eigen::Matrix2d::Identity() +
        (uo.pixel_sigma * uo.pixel_sigma + persistent) * R_qr * R_qr.transpose();
    Eigen::Vector3d d_cur;
    d_cur << BearingBoxMinus(mu, mu0), x_iter_.td - x0_.td;
    PHt_.noalias() = Pcols_ * H.transpose();
    K_.noalias() = PHt_ * S.inverse();
    dx_.noalias() = K_ * (-y + H * d_cur);
    BoxPlus(x0_, dx_, &x_iter_);
    have_gain = true;
    Eigen::Vector2d pixel_new;
    if (!PredictPixel(x_iter_, slot, &pixel_new, nullptr, nullptr)) break;
    const bool converged = (pixel_new - last_pixel).norm() < uo.convergence_px;
    last_pixel = pixel_new;
    if (converged) break;
  }
  if (!have_gain || !x_iter_.features[i].mu_C.allFinite()) {
    ++track.failures;
    return false;
  }
  x_ = x_iter_;
  // P = P0 - K S K^T (K is the gain of S at the last linearization).
  KS_.noalias() = K_ * S;
  P_.noalias() -= KS_ * K_.transpose();
  track.failures = 0;
  ++track.age;
  ++track.template_updates;
  track.updated = true;
  return true;
}

double VioFilter::PersistentPixelVariance(int slot) const {
  // A template error e_T that is the same in every frame, taken by the update as independent
  // per frame: with variance s^2 n at the n-th update made with the template, the information
  // the updates draw from it grows as sum 1/(s^2 n) ~ ln(N) / s^2 instead of N / s^2.
  const double s = options_.update.persistent_pixel_sigma;
  return s * s * static_cast<double>(tracks_[static_cast<std::size_t>(slot)].template_updates + 1);
}

void VioFilter::RefreshPatch(int slot) {
  // ROVIO (ImgUpdate, after a frame): a tracked feature's multilevel patch is re-extracted at
  // its updated estimate and kept if its Shi-Tomasi score is good enough (absolute or relative
  // to the old patch's); the warp starts again from the identity.
  const std::size_t i = static_cast<std::size_t>(slot);
  Track& track = tracks_[i];
  const FeatureOptions& fo = options_.features;
  Eigen::Vector2d pixel;
  Eigen::Vector3d mu;
  Eigen::Matrix<double, 3, 2> J_mu_px;
  if (!PredictPixel(x_, slot, &pixel, nullptr, nullptr) ||
      !camera_.camera.Unproject(pixel, &mu, &J_mu_px) ||
      !refreshed_patch_.Extract(pyramid_, pixel, Eigen::Matrix2d::Identity(), fo.patch)) {
    ++stats_.patch_refresh_rejections;
    return;
  }
  const double score = refreshed_patch_.ShiTomasiScore();
  if (!(score >= fo.min_shi_tomasi && score >= fo.refresh_min_relative_score * track.score)) {
    ++stats_.patch_refresh_rejections;
    return;
  }
  std::swap(track.patch, refreshed_patch_);
  track.score = score;
  track.A.setIdentity();
  // d tangent / d pixel at the new extraction, in the basis of the feature's bearing (Warp
  // multiplies B(mu) A D).
  track.D = BearingBasis(x_.features[i].mu_C).transpose() * J_mu_px;
  track.template_updates = 0;
  ++stats_.patch_refreshes;
}

void VioFilter::ProbationStep(int slot, double nis) {
  Track& track = tracks_[static_cast<std::size_t>(slot)];
  const StereoOptions& so = options_.stereo;
  track.probation_nis += nis;
  if (--track.probation > 0) return;
  if (track.probation_nis / static_cast<double>(so.probation_frames) > so.probation_max_mean_nis) {
    track.failures = options_.features.max_failures;  // removed after this frame's updates
    ++stats_.probation_removals;
  } else {
    ++stats_.probation_passes;
  }
}

void VioFilter::RemoveFeature(int slot) {
  const std::size_t i = static_cast<std::size_t>(slot);
  const int k = FeatureIndex(slot);
  x_.features[i].active = false;
  P_.middleRows<kFeatureDim>(k).setZero();
  P_.middleCols<kFeatureDim>(k).setZero();
  tracks_[i].failures = 0;
  tracks_[i].age = 0;
  tracks_[i].disagreements = 0;
  tracks_[i].template_updates = 0;
  tracks_[i].probation = 0;
  tracks_[i].probation_nis = 0.0;
  tracks_[i].deferred_tries = 0;
}

void VioFilter::AddFeatures() {
  const int active = x_.num_active();
  const FeatureOptions& fo = options_.features;
  if (active >= fo.detect_below && active > 0) return;
  occupied_.clear();
  for (const FeatureState& f : x_.features) {
    if (!f.active) continue;
    Eigen::Vector2d px;
    camera_.camera.Project(f.mu_C, &px);  // (td is far below a pixel's worth of motion here)
    occupied_.push_back(px);
  }
  const int free_slots = fo.max_features - active;
  // stereo.candidates_per_slot: candidates without a stereo match are passed over (up to that
  // many per free slot); the matches made while choosing are kept for the chosen ones.
  const bool prefer_matched = have_second_image_ && options_.stereo.init_depth &&
                              options_.stereo.candidates_per_slot > 0;
  probed_matches_.clear();
  auto matchable = [this](const FeatureCandidate& c) { return ProbeStereoCandidate(c); };
  int skipped = 0;
  const std::vector<FeatureCandidate> candidates =
      prefer_matched
          ? DetectFeatures(pyramid_, occupied_, free_slots, fo.detector, matchable,
                           options_.stereo.candidates_per_slot * free_slots, &skipped)
          : DetectFeatures(pyramid_, occupied_, free_slots, fo.detector);
  stats_.stereo_candidates_skipped += skipped;
  std::size_t slot = 0;
  for (const FeatureCandidate& c : candidates) {
    while (slot < x_.features.size() && x_.features[slot].active) ++slot;
    if (slot >= x_.features.size()) break;
    Track& track = tracks_[slot];
    if (!track.patch.Extract(pyramid_, c.pixel, Eigen::Matrix2d::Identity(), fo.patch)) continue;
    if (track.patch.ShiTomasiScore() < fo.min_shi_tomasi) continue;
    Eigen::Vector3d mu;
    Eigen::Matrix<double, 3, 2> J_mu_px;
    if (!camera_.camera.Unproject(c.pixel, &mu, &J_mu_px)) continue;
    FeatureState& f = x_.features[slot];
    // features.median_depth_init: the depths known now (the slot is still inactive, so not
    // its own), including the stereo matches of the features added before this one in this
    // detection (a first detection or a refill after a turn has few tracked depths but many
    // matched neighbours).
    f.rho = fo.init_inverse_depth;
    if (fo.median_depth_init &&
        MedianInverseDepth(x_, P_, fo.median_depth_max_ratio, fo.median_depth_min_features,
                           &f.rho)) {
      ++stats_.median_depth_inits;
    }
    f.active = true;
    f.mu_C = mu;
    track.A.setIdentity();
    track.D = BearingBasis(mu).transpose() * J_mu_px;
    track.failures = 0;
    track.age = 0;
    track.disagreements = 0;
    track.score = track.patch.ShiTomasiScore();
    track.template_updates = 0;
    track.updated = false;
    track.probation = 0;
    track.probation_nis = 0.0;
    track.depth_matched = false;
    track.c2_updates = 0;
    track.deferred_tries = have_second_image_ ? options_.stereo.deferred_match_frames : 0;
    track.id = next_feature_id_++;
    const int k = FeatureIndex(static_cast<int>(slot));
    P_.middleRows<kFeatureDim>(k).setZero();
    P_.middleCols<kFeatureDim>(k).setZero();
    const double sp = fo.init_bearing_sigma_px;
    P_.block<2, 2>(k, k) = sp * sp * track.D * track.D.transpose();
    P_(k + 2, k + 2) = fo.init_inverse_depth_sigma * fo.init_inverse_depth_sigma;
    if (have_second_image_ && options_.stereo.init_depth) {
      InitializeDepthFromStereo(static_cast<int>(slot), c.pixel);
    }
  }
}

std::string VioFilter::CheckHealth() const {
  if (!x_.p_M_I.allFinite() || !x_.v_M.allFinite() || !x_.q_M_I.coeffs().allFinite() ||
      !x_.b_g.allFinite() || !x_.b_a.allFinite() || !P_.diagonal().allFinite()) {
    return "state or covariance not finite";
  }
  if (P_.diagonal().minCoeff() < -1e-9) return "covariance lost positive definiteness";
  if (x_.v_M.norm() > options_.health.max_speed) return "implausible velocity";
  const double max_sigma = options_.health.max_position_sigma;
  if (P_.block<3, 3>(kIdxP, kIdxP).diagonal().maxCoeff() > max_sigma * max_sigma) {
    return "position covariance blow-up";
  }
  if (frames_without_updates_ > options_.health.max_frames_without_features) {
    return "all features lost";
  }
  return "";
}

FrameResult VioFilter::AddImage(int64_t t_cam_ns, const cv::Mat& image_gray8) {
  return AddImage(t_cam_ns, image_gray8, cv::Mat());
}

FrameResult VioFilter::AddImage(int64_t t_cam_ns, const cv::Mat& image_gray8,
                                const cv::Mat& second_gray8) {
  ++stats_.frames;
  FrameResult result;
  const int64_t t_ns = t_cam_ns + camera_.time_offset_ns;
  result.t_ns = t_ns;
  if (!initialized_) {
    std::string why_not;
    if (!Initialize(t_ns, image_gray8, &why_not)) {
      ++stats_.frames_without_imu;
      return result;
    }
    result.initialized_now = true;
  } else {
    if (t_ns <= x_.t_ns) return result;  // duplicated or out-of-order frame: ignored
    Propagate(t_ns);
  }
  pyramid_.Build(image_gray8, options_.features.patch.num_levels);
  have_second_image_ = stereo_ && !second_gray8.empty();
  if (have_second_image_) pyramid2_.Build(second_gray8, options_.features.patch.num_levels);

  const bool joint = have_second_image_ && options_.stereo.update && options_.stereo.joint_update;
  for (Track& track : tracks_) track.updated = false;
  for (int slot = 0; slot < static_cast<int>(x_.features.size()); ++slot) {
    if (!x_.features[static_cast<std::size_t>(slot)].active) continue;
    if (tracks_[static_cast<std::size_t>(slot)].probation > 0) {
      // stereo.probation_frames: a stereo-matched feature in C1 alone until its depth has
      // been tested against C1's flow.
      if (UpdateFeature(slot)) {
        ++result.num_updated;
        ProbationStep(slot, last_nis_);
      } else {
        ++result.num_rejected;
      }
      continue;
    }
    if (joint) {
      UpdateFeatureInBoth(slot, &result);
      continue;
    }
    if (UpdateFeature(slot)) {
      ++result.num_updated;
    } else {
      ++result.num_rejected;
    }
  }
  if (joint) {
    stats_.stereo_updates += result.num_stereo_updated;
  } else if (have_second_image_ && options_.stereo.update) {
    UpdateFeaturesInSecond(&result);
    stats_.stereo_updates += result.num_stereo_updated;
  }
  // Symmetrize in place (no temporary).
  for (Eigen::Index c = 0; c < P_.cols(); ++c) {
    for (Eigen::Index r = c + 1; r < P_.rows(); ++r) {
      const double m = 0.5 * (P_(r, c) + P_(c, r));
      P_(r, c) = m;
      P_(c, r) = m;
    }
  }
  if (have_second_image_ && options_.stereo.deferred_match_frames > 0) DeferredStereoMatches();
  for (int slot = 0; slot < static_cast<int>(x_.features.size()); ++slot) {
    const FeatureState& f = x_.features[static_cast<std::size_t>(slot)];
    if (!f.active) continue;
    const Track& track = tracks_[static_cast<std::size_t>(slot)];
    const int max_disagreements = options_.stereo.max_disagreements;
    const bool disagrees = max_disagreements > 0 && track.disagreements >= max_disagreements;
    if (track.failures >= options_.features.max_failures ||
        f.rho < options_.features.min_inverse_depth || disagrees) {
      if (disagrees) ++stats_.stereo_disagreement_removals;
      RemoveFeature(slot);
    }
  }
  if (options_.features.refresh_patch_every > 0) {
    for (int slot = 0; slot < static_cast<int>(x_.features.size()); ++slot) {
      const Track& track = tracks_[static_cast<std::size_t>(slot)];
      if (x_.features[static_cast<std::size_t>(slot)].active && track.updated &&
          track.template_updates >= options_.features.refresh_patch_every) {
        RefreshPatch(slot);
      }
    }
  }
  stats_.updates += result.num_updated;
  stats_.rejections += result.num_rejected;
  frames_without_updates_ = result.num_updated > 0 || result.num_stereo_updated > 0 ||
                                    result.initialized_now
                                ? 0
                                : frames_without_updates_ + 1;
  const int before = x_.num_active();
  const int64_t matches_before = stats_.stereo_matches;
  AddFeatures();
  result.num_stereo_initialized = static_cast<int>(stats_.stereo_matches - matches_before);
  result.num_added = x_.num_active() - before;
  result.num_features = x_.num_active();

  std::string health = CheckHealth();
  if (health.empty() && !requested_reset_.empty()) health = requested_reset_;
  requested_reset_.clear();
  if (!health.empty()) {
    ++stats_.resets;
    result.reset = true;
    result.reset_reason = health;
    initialized_ = false;
    initializer_.Reset();
    // Restart from the last pose that was still finite, else from the origin.
    have_previous_reset_pose_ = x_.p_M_I.allFinite() && x_.q_M_I.coeffs().allFinite();
    if (have_previous_reset_pose_) reset_pose_ = T_M_I();
    return result;
  }
  result.pose_valid = true;
  result.T_M_I = T_M_I();
  return result;
}

}  // namespace vilma::estimator
