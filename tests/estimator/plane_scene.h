// A synthetic world for filter and pipeline tests: a textured plane z = kPlaneZ in W seen by
// pinhole cameras that look up (+z of W, R_I_C = I), camera 1 (if asked for) 10 cm to the side
// of camera 0 (a stereo pair: 10 px disparity at the plane). The IMU moves along x and y after
// a static start; IMU samples are exact (no noise, no bias), 200 Hz; frames 20 Hz.
#pragma once

#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <functional>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <string>

#include "vilma/core/imu.h"
#include "vilma/core/rig.h"
#include "vilma/estimator/filter_options.h"
#include "vilma/estimator/vio_filter.h"

namespace vilma::estimator::testing {

class PlaneScene {
 public:
  static constexpr double kPlaneZ = 3.0;  // [m]
  static constexpr int kWidth = 320, kHeight = 240;
  static constexpr double kF = 300.0;
  static constexpr double kBaseline = 0.1;  // p_I_C1.x [m]

  // start_time: when the motion begins [s] (negative: moving from the first sample).
  explicit PlaneScene(int num_cameras = 1, double start_time = 1.0) : start_(start_time) {
    cv::Mat noise(1000, 1000, CV_32F);
    cv::RNG rng(12345);
    rng.fill(noise, cv::RNG::UNIFORM, 0.0, 1.0);
    cv::GaussianBlur(noise, texture_, cv::Size(0, 0), 2.5);
    cv::normalize(texture_, texture_, 0.0, 255.0, cv::NORM_MINMAX);
    for (int i = 0; i < num_cameras; ++i) {
      CameraConfig cam;
      cam.name = "cam" + std::to_string(i);
      cam.camera = Camera(kWidth, kHeight, Eigen::Vector4d(kF, kF, 160, 120),
                          DistortionModel::kNone, Eigen::VectorXd());
      cam.T_I_C = Transformation(Eigen::Quaterniond::Identity(),
                                 Eigen::Vector3d(i == 0 ? 0.0 : kBaseline, 0, 0));
      rig_.cameras.push_back(cam);
    }
  }

  const SensorRig& rig() const { return rig_; }

  Eigen::Vector3d Position(double t) const {  // p_M_I [m]
    const double tau = std::max(0.0, t - start_);
    return Eigen::Vector3d(0.4 * (1.0 - std::cos(2.0 * tau)), 0.2 * (1.0 - std::cos(1.3 * tau)),
                           0.0);
  }
  Eigen::Vector3d AccelerationW(double t) const {
    const double tau = t - start_;
    if (tau < 0.0) return Eigen::Vector3d::Zero();
    return Eigen::Vector3d(0.4 * 4.0 * std::cos(2.0 * tau), 0.2 * 1.69 * std::cos(1.3 * tau), 0);
  }
  ImuSample Imu(int64_t t_ns) const {
    ImuSample s;
    s.t_ns = t_ns;
    s.a_I = AccelerationW(static_cast<double>(t_ns) * 1e-9) + Eigen::Vector3d(0, 0, 9.81);
    return s;
  }
  // Camera `camera`'s image at time t [s] (bilinear lookup of the texture, 1 px = 1 cm).
  cv::Mat Render(double t, int camera = 0) const {
    const Eigen::Vector3d c =
        Position(t) + rig_.cameras[static_cast<std::size_t>(camera)].T_I_C.translation();
    cv::Mat image(kHeight, kWidth, CV_8U);
    for (int v = 0; v < kHeight; ++v) {
      for (int u = 0; u < kWidth; ++u) {
        const double s = (kPlaneZ - c.z());
        const double x = c.x() + s * (u - 160) / kF, y = c.y() + s * (v - 120) / kF;
        const double tu = x * 100.0 + 500.0, tv = y * 100.0 + 500.0;
        const int iu = static_cast<int>(std::floor(tu)), iv = static_cast<int>(std::floor(tv));
        const double fu = tu - iu, fv = tv - iv;
        auto at = [&](int a, int b) { return static_cast<double>(texture_.at<float>(b, a)); };
        const double value = (1 - fv) * ((1 - fu) * at(iu, iv) + fu * at(iu + 1, iv)) +
                             fv * ((1 - fu) * at(iu, iv + 1) + fu * at(iu + 1, iv + 1));
        image.at<unsigned char>(v, u) = cv::saturate_cast<unsigned char>(value);
      }
    }
    return image;
  }

 private:
  double start_;
  cv::Mat texture_;
  SensorRig rig_;
};

// The filter options of the plane-scene stereo runs: few features (the scene's texture), stereo
// on with the mono feature counts.
inline FilterOptions PlaneStereoOptions() {
  FilterOptions options;
  options.features.max_features = 12;
  options.features.detect_below = 8;
  options.stereo.enabled = true;
  options.stereo.max_features = 0;  // the same counts as mono
  options.stereo.detect_below = 0;
  return options;
}

// Runs `filter` over `seconds` of the scene (images at 20 Hz, IMU at 200 Hz). With `second`,
// each frame also gets a second image made from camera 1's render (the identity for plain
// stereo); without it the frames are mono. Returns the final position error [m] against the
// motion since initialization; *resets counts the frames that reset the filter.
inline double RunPlaneScene(const PlaneScene& scene, double seconds, VioFilter* filter,
                            const std::function<cv::Mat(const cv::Mat&)>& second, int* resets) {
  const int64_t imu_dt = 5'000'000, cam_dt = 50'000'000;
  int64_t next_imu = 0;
  double t_init = -1.0;
  *resets = 0;
  for (int i = 0; i <= static_cast<int>(seconds * 20); ++i) {
    const int64_t t_cam = i * cam_dt;
    for (; next_imu <= t_cam + imu_dt; next_imu += imu_dt) filter->AddImu(scene.Imu(next_imu));
    const double t = static_cast<double>(t_cam) * 1e-9;
    const FrameResult r = second ? filter->AddImage(t_cam, scene.Render(t, 0), second(scene.Render(t, 1)))
                                 : filter->AddImage(t_cam, scene.Render(t, 0));
    if (r.reset) ++*resets;
    if (r.initialized_now) t_init = t;
  }
  return (filter->state().p_M_I - (scene.Position(seconds) - scene.Position(t_init))).norm();
}

}  // namespace vilma::estimator::testing
