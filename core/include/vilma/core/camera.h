// Camera models: pinhole projection with radial-tangential (plumb bob, Brown-Conrady: k1, k2,
// p1, p2) or equidistant (Kannala-Brandt fisheye: k1..k4) distortion, as in Kalibr and the
// EuRoC sensor.yaml files. Points and bearings are in the camera frame C (z forward, x right,
// y down); keypoints are pixel coordinates with (0, 0) at the centre of the top-left pixel.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <string>

namespace vilma {

enum class DistortionModel { kNone, kRadTan, kEquidistant };

// "none", "radtan", "equidistant".
const char* ToString(DistortionModel model);
// Accepts the names above plus Kalibr's aliases ("radial-tangential", "plumb_bob",
// "equi", "fisheye"); returns false for anything else.
bool ParseDistortionModel(const std::string& name, DistortionModel* model);
// Number of coefficients the model takes (0, 4, 4).
int NumDistortionCoefficients(DistortionModel model);

class Camera {
 public:
  enum class ProjectionResult { kValid, kBehindCamera, kOutsideImage, kNotFinite };

  Camera() = default;
  // fx_fy_cx_cy in pixels; `distortion_coefficients` must have NumDistortionCoefficients(model)
  // entries (see Validate()).
  Camera(int width, int height, const Eigen::Vector4d& fx_fy_cx_cy, DistortionModel model,
         const Eigen::VectorXd& distortion_coefficients);

  // Empty when the model is usable, otherwise what is wrong (size, focal length, coefficient
  // count, principal point inside the image...).
  std::string Validate() const;

  int width() const { return width_; }
  int height() const { return height_; }
  double fx() const { return intrinsics_[0]; }
  double fy() const { return intrinsics_[1]; }
  double cx() const { return intrinsics_[2]; }
  double cy() const { return intrinsics_[3]; }
  const Eigen::Vector4d& intrinsics() const { return intrinsics_; }
  DistortionModel distortion_model() const { return model_; }
  const Eigen::VectorXd& distortion_coefficients() const { return coefficients_; }
  Eigen::Matrix3d K() const;

  // p_C -> keypoint [px]. J_keypoint_p_C (optional) is d keypoint / d p_C. Returns kValid only
  // for points in front of the camera that land inside the image; the keypoint (and Jacobian)
  // are still written for kOutsideImage.
  ProjectionResult Project(const Eigen::Vector3d& p_C, Eigen::Vector2d* keypoint,
                           Eigen::Matrix<double, 2, 3>* J_keypoint_p_C = nullptr) const;

  // keypoint [px] -> unit bearing vector in C. J_bearing_keypoint (optional) is
  // d bearing / d keypoint. Returns false if the undistortion does not converge.
  bool Unproject(const Eigen::Vector2d& keypoint, Eigen::Vector3d* bearing_C,
                 Eigen::Matrix<double, 3, 2>* J_bearing_keypoint = nullptr) const;

  // Distortion on normalized image coordinates (x/z, y/z for radtan; see the .cpp for the
  // equidistant definition). J (optional) is d distorted / d undistorted.
  Eigen::Vector2d Distort(const Eigen::Vector2d& xy_undistorted,
                          Eigen::Matrix2d* J = nullptr) const;
  // Inverse of Distort by Gauss-Newton; false if it does not converge.
  bool Undistort(const Eigen::Vector2d& xy_distorted, Eigen::Vector2d* xy_undistorted) const;

  bool IsInImage(const Eigen::Vector2d& keypoint, double margin_px = 0.0) const;

  // A distortion-free pinhole camera of the same size whose image keeps all valid pixels of
  // this one (alpha = 0) or shows the whole of this image (alpha = 1), as in OpenCV's
  // getOptimalNewCameraMatrix.
  Camera UndistortedPinhole(double alpha = 0.0) const;
  // Remap tables (CV_32FC1) that turn an image of this camera into one of `target` (same
  // optical centre, no rotation): target(u, v) = this(map_x(u, v), map_y(u, v)).
  void ComputeUndistortionMaps(const Camera& target, cv::Mat* map_x, cv::Mat* map_y) const;

 private:
  int width_ = 0;
  int height_ = 0;
  Eigen::Vector4d intrinsics_ = Eigen::Vector4d::Zero();
  DistortionModel model_ = DistortionModel::kNone;
  Eigen::VectorXd coefficients_;
};

}  // namespace vilma
