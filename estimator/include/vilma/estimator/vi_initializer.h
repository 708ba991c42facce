// Moving-start initialization (docs/estimator.md, "Moving start"): tracks corners with KLT over
// the first frames (gyro-predicted, forward-backward checked), and once a window of
// `window_s` is full, aligns them with the preintegrated IMU (vi_alignment.h) for gravity,
// velocity and the biases. The result is accepted only when it passes the checks (features,
// parallax, residuals, |g| of the unconstrained solution, roll/pitch uncertainty); otherwise
// the window slides on by a frame and the reason is counted. No LCM; used by VioFilter.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <deque>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "vilma/core/imu.h"
#include "vilma/core/rig.h"
#include "vilma/estimator/filter_options.h"

namespace vilma::estimator {

// Attempts and why they were turned down.
struct InitializerStats {
  int64_t attempts = 0;
  int64_t accepted = 0;
  int64_t too_few_features = 0;  // fewer than min_features seen in >= 3 frames
  int64_t low_parallax = 0;      // the window's translation is too small to see
  int64_t solver_failed = 0;     // singular system (no translation, degenerate points)
  int64_t large_residual = 0;    // RMS or inlier ratio check
  int64_t gravity_mismatch = 0;  // unconstrained |g| far from g
  int64_t uncertain = 0;         // roll/pitch std above max_roll_pitch_sigma
};

// The state at the newest frame of an accepted window, in a gravity-aligned frame M whose yaw
// is that of the window's first IMU frame (g_M = (0, 0, -g)).
struct InitialAlignment {
  int64_t t_ns = 0;  // IMU clock
  Eigen::Quaterniond q_M_I = Eigen::Quaterniond::Identity();
  Eigen::Vector3d p_M_I = Eigen::Vector3d::Zero();  // relative to the window's first IMU pose
  Eigen::Vector3d v_M = Eigen::Vector3d::Zero();
  Eigen::Vector3d b_g = Eigen::Vector3d::Zero();
  Eigen::Vector3d b_a = Eigen::Vector3d::Zero();
  // Covariance of (dv_M, dtheta, db_g, db_a) in the filter's error-state convention (dtheta a
  // right perturbation of q_M_I); yaw is not included (the filter adds its own).
  Eigen::Matrix<double, 12, 12> covariance = Eigen::Matrix<double, 12, 12>::Zero();
  double roll_pitch_sigma = 0.0;  // [rad]
  double rms_px = 0.0;
  int features = 0;
  int frames = 0;
  double window_s = 0.0;
};

class VisualInertialInitializer {
 public:
  VisualInertialInitializer(const CameraConfig& camera, double gravity_magnitude,
                            const DynamicInitOptions& options);

  // Forgets frames and IMU (a new start).
  void Reset();
  // IMU samples in time order (the filter's checked stream).
  void AddImu(const ImuSample& sample);
  // A frame at IMU time t_ns. True when a window was accepted: `result` is the state at this
  // frame. Otherwise `why_not` says what is missing.
  bool AddFrame(int64_t t_ns, const cv::Mat& image_gray8, InitialAlignment* result,
                std::string* why_not);

  // Frames are held: a moving start was seen and is being aligned.
  bool collecting() const { return !frames_.empty(); }
  // Seconds from the first frame since Reset() to the newest.
  double waited_s() const;
  const InitializerStats& stats() const { return stats_; }

 private:
  struct Observation {
    int id = 0;
    Eigen::Vector2d pixel;
    Eigen::Vector3d bearing_C;
  };
  struct Frame {
    int64_t t_ns = 0;
    std::vector<Observation> observations;
  };

  void Track(int64_t t_ns, const cv::Mat& image);
  bool TryAlign(InitialAlignment* result, std::string* why_not);

  CameraConfig camera_;
  double gravity_magnitude_;
  DynamicInitOptions options_;
  InitializerStats stats_;
  std::deque<Frame> frames_;
  std::vector<ImuSample> imu_;
  cv::Mat previous_image_;
  int next_id_ = 0;
  int64_t first_t_ns_ = -1;
};

}  // namespace vilma::estimator
