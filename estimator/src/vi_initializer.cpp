#include "vilma/estimator/vi_initializer.h"

#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <map>
#include <opencv2/imgproc.hpp>
#include <opencv2/video/tracking.hpp>

#include "vilma/core/error.h"
#include "vilma/core/geometry.h"
#include "vilma/estimator/imu_preintegration.h"
#include "vilma/estimator/filter_state.h"
#include "vilma/estimator/vi_alignment.h"

namespace vilma::estimator {
namespace {

constexpr int kKltWindowPx = 21;
constexpr int kKltLevels = 3;

}  // namespace

VisualInertialInitializer::VisualInertialInitializer(const CameraConfig& camera,
                                                     double gravity_magnitude,
                                                     const DynamicInitOptions& options)
    : camera_(camera), gravity_magnitude_(gravity_magnitude), options_(options) {
  ThrowIfInvalid(options.Validate(), "dynamic initialization options");
}

void VisualInertialInitializer::Reset() {
  frames_.clear();
  imu_.clear();
  previous_image_.release();
  first_t_ns_ = -1;
}

void VisualInertialInitializer::AddImu(const ImuSample& sample) {
  if (!imu_.empty() && sample.t_ns <= imu_.back().t_ns) return;
  imu_.push_back(sample);
  // Without frames only a short history is needed (the first frame's interpolation).
  if (frames_.empty() && imu_.size() > 64) imu_.erase(imu_.begin(), imu_.end() - 32);
}

double VisualInertialInitializer::waited_s() const {
  if (frames_.empty() || first_t_ns_ < 0) return 0.0;
  return static_cast<double>(frames_.back().t_ns - first_t_ns_) * 1e-9;
}

void VisualInertialInitializer::Track(int64_t t_ns, const cv::Mat& image) {
  Frame frame;
  frame.t_ns = t_ns;
  const Camera& cam = camera_.camera;
  if (!frames_.empty() && !previous_image_.empty() && !frames_.back().observations.empty()) {
    const Frame& prev = frames_.back();
    // Predict with the gyro (points at infinity): b_cur = R_C_I R_Icur_Iprev R_I_C b_prev.
    const std::vector<PreintegratedImu> pre = PreintegrateImu(
        imu_, {prev.t_ns, t_ns}, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
    const Eigen::Quaterniond q_I_C = camera_.T_I_C.rotation();
    const Eigen::Quaterniond q_Ccur_Cprev = q_I_C.conjugate() * pre[1].q_0_k.conjugate() * q_I_C;
    std::vector<cv::Point2f> previous, predicted;
    for (const Observation& o : prev.observations) {
      previous.emplace_back(static_cast<float>(o.pixel.x()), static_cast<float>(o.pixel.y()));
      Eigen::Vector2d px;
      if (cam.Project(q_Ccur_Cprev * o.bearing_C, &px) != Camera::ProjectionResult::kValid) {
        px = o.pixel;
      }
      predicted.emplace_back(static_cast<float>(px.x()), static_cast<float>(px.y()));
    }
    std::vector<uchar> status, back_status;
    std::vector<float> error;
    const cv::Size window(kKltWindowPx, kKltWindowPx);
    const cv::TermCriteria criteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 30, 0.01);
    cv::calcOpticalFlowPyrLK(previous_image_, image, previous, predicted, status, error, window,
                             kKltLevels, criteria, cv::OPTFLOW_USE_INITIAL_FLOW);
    std::vector<cv::Point2f> back = previous;
    cv::calcOpticalFlowPyrLK(image, previous_image_, predicted, back, back_status, error, window,
                             kKltLevels, criteria, cv::OPTFLOW_USE_INITIAL_FLOW);
    for (std::size_t i = 0; i < previous.size(); ++i) {
      if (!status[i] || !back_status[i]) continue;
      const cv::Point2f d = back[i] - previous[i];
      if (std::hypot(d.x, d.y) > options_.max_klt_error_px) continue;
      Observation o;
      o.id = prev.observations[i].id;
      o.pixel = Eigen::Vector2d(predicted[i].x, predicted[i].y);
      if (o.pixel.x() < 0 || o.pixel.y() < 0 || o.pixel.x() > image.cols - 1 ||
          o.pixel.y() > image.rows - 1 || !cam.Unproject(o.pixel, &o.bearing_C)) {
        continue;
      }
      frame.observations.push_back(o);
    }
  }
  // Top up with new corners away from the tracked ones.
  const int missing = options_.max_corners - static_cast<int>(frame.observations.size());
  if (missing > options_.max_corners / 4) {
    cv::Mat mask(image.size(), CV_8U, cv::Scalar(255));
    const int radius = static_cast<int>(std::lround(options_.min_corner_distance_px));
    for (const Observation& o : frame.observations) {
      cv::circle(mask, cv::Point(static_cast<int>(o.pixel.x()), static_cast<int>(o.pixel.y())),
                 radius, cv::Scalar(0), -1);
    }
    std::vector<cv::Point2f> corners;
    cv::goodFeaturesToTrack(image, corners, missing, 0.01, options_.min_corner_distance_px, mask,
                            3);
    for (const cv::Point2f& c : corners) {
      Observation o;
      o.id = next_id_++;
      o.pixel = Eigen::Vector2d(c.x, c.y);
      if (cam.Unproject(o.pixel, &o.bearing_C)) frame.observations.push_back(o);
    }
  }
  frames_.push_back(std::move(frame));
  image.copyTo(previous_image_);
}

bool VisualInertialInitializer::AddFrame(int64_t t_ns, const cv::Mat& image_gray8,
                                         InitialAlignment* result, std::string* why_not) {
  if (image_gray8.empty() || image_gray8.type() != CV_8UC1) {
    *why_not = "image is not 8-bit grayscale";
    return false;
  }
  if (!frames_.empty() && t_ns <= frames_.back().t_ns) {
    *why_not = "frame not after the previous one";
    return false;
  }
  if (first_t_ns_ < 0) first_t_ns_ = t_ns;
  Track(t_ns, image_gray8);
  // Slide: the window holds the newest window_s (1 ms slack for stamp jitter).
  const int64_t window_ns = static_cast<int64_t>(options_.window_s * 1e9);
  while (frames_.size() > 2 && frames_.front().t_ns < t_ns - window_ns - 1'000'000) {
    frames_.pop_front();
  }
  const int64_t keep_from = frames_.front().t_ns - 50'000'000;
  auto first_kept = std::lower_bound(imu_.begin(), imu_.end(), keep_from,
                                     [](const ImuSample& s, int64_t v) { return s.t_ns < v; });
  imu_.erase(imu_.begin(), first_kept);
  if (static_cast<double>(t_ns - frames_.front().t_ns) < 0.9 * static_cast<double>(window_ns)) {
    *why_not = "collecting frames";
    return false;
  }
  if (imu_.empty() || imu_.front().t_ns > frames_.front().t_ns || imu_.back().t_ns < t_ns) {
    *why_not = "IMU does not cover the window";
    return false;
  }
  ++stats_.attempts;
  if (!TryAlign(result, why_not)) return false;
  ++stats_.accepted;
  return true;
}

bool VisualInertialInitializer::TryAlign(InitialAlignment* result, std::string* why_not) {
  AlignmentInput input;
  input.T_I_C = camera_.T_I_C;
  input.gravity_magnitude = gravity_magnitude_;
  input.imu = imu_;
  for (const Frame& f : frames_) input.frame_t_ns.push_back(f.t_ns);
  // Features seen in at least 3 frames, numbered densely.
  std::map<int, int> seen;
  for (const Frame& f : frames_) {
    for (const Observation& o : f.observations) ++seen[o.id];
  }
  std::map<int, int> index;
  for (const auto& [id, n] : seen) {
    if (n >= 3) index.emplace(id, static_cast<int>(index.size()));
  }
  input.num_features = static_cast<int>(index.size());
  if (input.num_features < options_.min_features) {
    ++stats_.too_few_features;
    *why_not = "too few tracked features (" + std::to_string(input.num_features) + ")";
    return false;
  }
  std::vector<int> first_frame(index.size(), -1), last_frame(index.size(), -1);
  std::vector<Eigen::Vector3d> first_bearing(index.size()), last_bearing(index.size());
  std::vector<Eigen::Vector2d> last_pixel(index.size());
  for (int k = 0; k < static_cast<int>(frames_.size()); ++k) {
    for (const Observation& o : frames_[static_cast<std::size_t>(k)].observations) {
      const auto it = index.find(o.id);
      if (it == index.end()) continue;
      AlignmentObservation a;
      a.feature = it->second;
      a.frame = k;
      a.bearing_C = o.bearing_C;
      input.observations.push_back(a);
      const std::size_t f = static_cast<std::size_t>(it->second);
      if (first_frame[f] < 0) {
        first_frame[f] = k;
        first_bearing[f] = o.bearing_C;
      }
      last_frame[f] = k;
      last_bearing[f] = o.bearing_C;
      last_pixel[f] = o.pixel;
    }
  }
  // Parallax: the feature's motion from its first to its last frame after removing the
  // gyro-measured rotation (zero bias: a coarse gate; the alignment's covariance decides).
  const std::vector<PreintegratedImu> pre0 = PreintegrateImu(
      input.imu, input.frame_t_ns, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
  const Eigen::Quaterniond q_I_C = camera_.T_I_C.rotation();
  std::vector<double> parallax;
  for (std::size_t f = 0; f < index.size(); ++f) {
    const Eigen::Quaterniond q_Cb_Ca =
        q_I_C.conjugate() * pre0[static_cast<std::size_t>(last_frame[f])].q_0_k.conjugate() *
        pre0[static_cast<std::size_t>(first_frame[f])].q_0_k * q_I_C;
    Eigen::Vector2d px;
    if (camera_.camera.Project(q_Cb_Ca * first_bearing[f], &px) ==
        Camera::ProjectionResult::kValid) {
      parallax.push_back((px - last_pixel[f]).norm());
    }
  }
  double median_parallax = 0.0;
  if (!parallax.empty()) {
    std::nth_element(parallax.begin(), parallax.begin() + parallax.size() / 2, parallax.end());
    median_parallax = parallax[parallax.size() / 2];
  }
  if (median_parallax < options_.min_parallax_px) {
    ++stats_.low_parallax;
    *why_not = "low parallax (" + std::to_string(median_parallax) + " px)";
    return false;
  }

  AlignmentSolution solution;
  std::string reason;
  AlignmentOptions alignment;
  const double focal = camera_.camera.intrinsics()(0);
  alignment.bearing_sigma = options_.pixel_sigma / focal;
  alignment.gyro_bias_sigma = options_.gyro_bias_sigma;
  if (!SolveLinearAlignment(input, pre0, &solution, &reason) ||
      !RefineAlignment(input, alignment, &solution, &reason)) {
    ++stats_.solver_failed;
    *why_not = "alignment failed: " + reason;
    return false;
  }
  const double rms_px = solution.rms_inlier_rad * focal;
  const double inlier_ratio =
      static_cast<double>(solution.inliers) / std::max(1, solution.observations_used);
  if (rms_px > options_.max_rms_px || inlier_ratio < options_.min_inlier_ratio) {
    ++stats_.large_residual;
    *why_not = "large residuals (RMS " + std::to_string(rms_px) + " px, inliers " +
               std::to_string(inlier_ratio) + ")";
    return false;
  }
  // Consistency: with the refined biases, the linear solution without |g| = G should find a
  // gravity of about the right length by itself.
  {
    AlignmentSolution check;
    const std::vector<PreintegratedImu> pre =
        PreintegrateImu(input.imu, input.frame_t_ns, solution.b_g, solution.b_a);
    if (!SolveLinearAlignment(input, pre, &check, &reason) ||
        std::abs(check.unconstrained_gravity_norm - gravity_magnitude_) >
            options_.max_gravity_error) {
      ++stats_.gravity_mismatch;
      *why_not = "unconstrained gravity " + std::to_string(check.unconstrained_gravity_norm) +
                 " m/s^2";
      return false;
    }
  }
  const Eigen::Matrix2d cov_u = solution.covariance.block<2, 2>(kAlignG, kAlignG);
  const double roll_pitch_sigma =
      std::sqrt(std::max(0.0, Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d>(cov_u)
                                  .eigenvalues()
                                  .maxCoeff()));
  if (!(roll_pitch_sigma <= options_.max_roll_pitch_sigma)) {
    ++stats_.uncertain;
    *why_not = "roll/pitch uncertain (" + std::to_string(roll_pitch_sigma) + " rad)";
    return false;
  }

  // The state at the newest frame K. M: gravity along -z, yaw of I0 kept as is (the minimal
  // rotation that takes -g_I0 to +z).
  const std::vector<PreintegratedImu> pre =
      PreintegrateImu(input.imu, input.frame_t_ns, solution.b_g, solution.b_a);
  const PreintegratedImu& pK = pre.back();
  const double t = pK.dt_s;
  const Eigen::Vector3d& g = solution.g_I0;
  const Eigen::Vector3d u = g.normalized();
  const Eigen::Quaterniond q_M_I0 = Eigen::Quaterniond::FromTwoVectors(-g, Eigen::Vector3d::UnitZ());
  const Eigen::Matrix3d R_M_I0 = q_M_I0.toRotationMatrix();
  const Eigen::Vector3d v_K_I0 = solution.v_I0 + g * t + pK.beta;
  result->t_ns = frames_.back().t_ns;
  result->q_M_I = (q_M_I0 * pK.q_0_k).normalized();
  result->p_M_I = R_M_I0 * (solution.v_I0 * t + 0.5 * t * t * g + pK.alpha);
  result->v_M = R_M_I0 * v_K_I0;
  result->b_g = solution.b_g;
  result->b_a = solution.b_a;
  // Error propagation into the filter's (dv_M, dtheta_IK, db_g, db_a). A tangent step du of u
  // rotates M's gravity axis in I0: dtheta_I0 = -[u]x B(u) du (so that Exp(-dtheta) u = u + B du).
  const Eigen::Matrix<double, 3, 2> B = BearingBasis(u);
  const Eigen::Matrix<double, 3, 2> T = -Skew(u) * B;
  const Eigen::Matrix3d R_0K = pK.q_0_k.toRotationMatrix();
  Eigen::Matrix<double, 12, kAlignDim> J = Eigen::Matrix<double, 12, kAlignDim>::Zero();
  J.block<3, 3>(0, kAlignV) = R_M_I0;
  J.block<3, 2>(0, kAlignG) = R_M_I0 * (gravity_magnitude_ * t * B - Skew(v_K_I0) * T);
  J.block<3, 3>(0, kAlignBg) = R_M_I0 * pK.d_beta_d_bg;
  J.block<3, 3>(0, kAlignBa) = R_M_I0 * pK.d_beta_d_ba;
  J.block<3, 2>(3, kAlignG) = R_0K.transpose() * T;
  J.block<3, 3>(3, kAlignBg) = pK.d_R_d_bg;
  J.block<3, 3>(6, kAlignBg).setIdentity();
  J.block<3, 3>(9, kAlignBa).setIdentity();
  result->covariance = J * solution.covariance * J.transpose();
  result->roll_pitch_sigma = roll_pitch_sigma;
  result->rms_px = rms_px;
  result->features = input.num_features;
  result->frames = static_cast<int>(frames_.size());
  result->window_s = t;
  return true;
}

}  // namespace vilma::estimator
