// Test images for the localizer tests: a deterministic textured image (random rectangles and
// discs of random grey levels, lightly blurred) and its warp by a pure camera rotation.
#pragma once

#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "vilma/core/camera.h"

namespace vilma::localizer::test {

inline cv::Mat TexturedImage(int width, int height, uint64_t seed) {
  cv::RNG rng(seed);
  cv::Mat image(height, width, CV_8UC1, cv::Scalar(128));
  for (int k = 0; k < 900; ++k) {
    // Last argument first, in the order GCC drew them (tests/test_random.h).
    const int c_y = rng.uniform(-20, height + 20);
    const int c_x = rng.uniform(-20, width + 20);
    const cv::Point c(c_x, c_y);
    const int grey = rng.uniform(0, 256);
    if (rng.uniform(0, 3) == 0) {
      cv::circle(image, c, rng.uniform(3, 25), cv::Scalar(grey), cv::FILLED, cv::LINE_AA);
    } else {
      const int s_height = rng.uniform(4, 45);
      const int s_width = rng.uniform(4, 45);
      const cv::Size s(s_width, s_height);
      const cv::RotatedRect r(cv::Point2f(static_cast<float>(c.x), static_cast<float>(c.y)),
                              cv::Size2f(static_cast<float>(s.width),
                                         static_cast<float>(s.height)),
                              static_cast<float>(rng.uniform(0.0, 180.0)));
      cv::Point2f corners[4];
      r.points(corners);
      std::vector<cv::Point> poly;
      for (const auto& p : corners) poly.emplace_back(cvRound(p.x), cvRound(p.y));
      cv::fillConvexPoly(image, poly, cv::Scalar(grey), cv::LINE_AA);
    }
  }
  cv::GaussianBlur(image, image, cv::Size(3, 3), 0.8);
  return image;
}

inline Camera PinholeCamera(int width = 752, int height = 480) {
  return Camera(width, height, Eigen::Vector4d(458.0, 458.0, 0.5 * (width - 1), 0.5 * (height - 1)),
                DistortionModel::kNone, Eigen::VectorXd());
}

// Homography of a pure rotation for a distortion-free camera: x_cur ~ K R_Ck_Ckm1 K^-1 x_prev.
inline cv::Mat RotationHomography(const Camera& camera, const Eigen::Matrix3d& R_Ck_Ckm1) {
  const Eigen::Matrix3d K = camera.K();
  const Eigen::Matrix3d H = K * R_Ck_Ckm1 * K.inverse();
  cv::Mat h(3, 3, CV_64F);
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) h.at<double>(r, c) = H(r, c);
  }
  return h;
}

inline cv::Mat WarpByRotation(const cv::Mat& image, const Camera& camera,
                              const Eigen::Matrix3d& R_Ck_Ckm1) {
  cv::Mat warped;
  cv::warpPerspective(image, warped, RotationHomography(camera, R_Ck_Ckm1), image.size(),
                      cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(128));
  return warped;
}

inline Eigen::Vector2d ApplyHomography(const cv::Mat& h, const Eigen::Vector2d& p) {
  Eigen::Matrix3d H;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 3; ++c) H(r, c) = h.at<double>(r, c);
  }
  const Eigen::Vector3d q = H * p.homogeneous();
  return q.hnormalized();
}

}  // namespace vilma::localizer::test
