// Pinhole camera with radial-tangential or equidistant distortion (see camera.h).
//
// Pipeline (all models): p_C = (X, Y, Z), Z > 0
//   normalized   m = (x, y) = (X / Z, Y / Z)
//   distorted    d = Distort(m)
//   keypoint     u = (fx d_x + cx, fy d_y + cy)
//
// radtan (Brown-Conrady / OpenCV plumb bob / Kalibr "radial-tangential"), r^2 = x^2 + y^2:
//   d_x = x (1 + k1 r^2 + k2 r^4) + 2 p1 x y + p2 (r^2 + 2 x^2)
//   d_y = y (1 + k1 r^2 + k2 r^4) + p1 (r^2 + 2 y^2) + 2 p2 x y
// equidistant (Kannala-Brandt as Kalibr's "equidistant" and OpenCV's cv::fisheye), r = |m|:
//   theta = atan(r) = atan2(|(X, Y)|, Z),
//   theta_d = theta (1 + k1 theta^2 + k2 theta^4 + k3 theta^6 + k4 theta^8),
//   d = (theta_d / r) m,
// i.e. the distorted normalized radius equals the distorted ray angle [rad].
#include "vilma/core/camera.h"

#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <limits>
#include <sstream>

namespace vilma {
namespace {

constexpr int kMaxUndistortIterations = 20;
// Convergence threshold on the residual of Distort(m) - d, in normalized image units
// (1e-14 * f ~ 5e-12 px for f ~ 500 px; reachable in double precision for |d| ~ 1).
constexpr double kUndistortTolerance = 1e-14;
// Accept the last iterate if its residual is below this (still ~1e-7 px).
constexpr double kUndistortAcceptTolerance = 1e-10;
// Below this normalized radius the equidistant model uses its Taylor expansion about the
// optical axis (the closed form divides by r^3); the neglected terms are O(r^4) < 1e-20.
constexpr double kEquidistantSmallRadius = 1e-5;
// Map value for target pixels that have no source (behind the camera): far outside any image,
// still representable as int16 inside cv::remap's fixed-point conversion.
constexpr float kInvalidMapValue = -10000.0f;

// theta_d(theta) and d theta_d / d theta for the equidistant model.
void EquidistantThetaD(const Eigen::VectorXd& k, double theta, double* theta_d, double* d_theta_d) {
  const double t2 = theta * theta;
  // Horner: 1 + k1 t2 + k2 t2^2 + k3 t2^3 + k4 t2^4.
  const double poly = 1.0 + t2 * (k[0] + t2 * (k[1] + t2 * (k[2] + t2 * k[3])));
  // d/dtheta [theta poly] = 1 + 3 k1 t2 + 5 k2 t2^2 + 7 k3 t2^3 + 9 k4 t2^4.
  const double d_poly =
      1.0 + t2 * (3.0 * k[0] + t2 * (5.0 * k[1] + t2 * (7.0 * k[2] + t2 * 9.0 * k[3])));
  *theta_d = theta * poly;
  *d_theta_d = d_poly;
}

// Squared normalized radius at which the radial part of radtan folds over:
// d/dr [r (1 + k1 r^2 + k2 r^4)] = 1 + 3 k1 s + 5 k2 s^2 = 0 with s = r^2. Smallest positive
// root, +inf if none. Rays beyond it are not seen by the camera (their distorted radius comes
// back towards the centre, or the polynomial only rises again by extrapolation).
double RadTanFoldRadiusSquared(double k1, double k2) {
  constexpr double kInf = std::numeric_limits<double>::infinity();
  const double a = 5.0 * k2, b = 3.0 * k1, c = 1.0;
  if (a == 0.0) return b < 0.0 ? -c / b : kInf;
  const double discriminant = b * b - 4.0 * a * c;
  if (discriminant < 0.0) return kInf;
  // Numerically stable roots q / a and c / q.
  const double q = -0.5 * (b + std::copysign(std::sqrt(discriminant), b));
  double s = kInf;
  if (q / a > 0.0) s = std::min(s, q / a);
  if (q != 0.0 && c / q > 0.0) s = std::min(s, c / q);
  return s;
}

// True when the normalized point m lies where the distortion is monotonic in the radius (so
// that each pixel has one ray): radtan before its fold (tangential terms, ~1e-4 in practice,
// ignored), equidistant where d theta_d / d theta > 0 (checked locally: calibrated
// Kannala-Brandt polynomials are monotonic over their field of view).
bool InDistortionDomain(DistortionModel model, const Eigen::VectorXd& k, const Eigen::Vector2d& m) {
  switch (model) {
    case DistortionModel::kNone:
      return true;
    case DistortionModel::kRadTan:
      return m.squaredNorm() < RadTanFoldRadiusSquared(k[0], k[1]);
    case DistortionModel::kEquidistant: {
      double theta_d, d_theta_d;
      EquidistantThetaD(k, std::atan(m.norm()), &theta_d, &d_theta_d);
      return d_theta_d > 0.0;
    }
  }
  return false;
}

}  // namespace

const char* ToString(DistortionModel model) {
  switch (model) {
    case DistortionModel::kNone:
      return "none";
    case DistortionModel::kRadTan:
      return "radtan";
    case DistortionModel::kEquidistant:
      return "equidistant";
  }
  return "unknown";
}

bool ParseDistortionModel(const std::string& name, DistortionModel* model) {
  if (name == "none") {
    *model = DistortionModel::kNone;
  } else if (name == "radtan" || name == "radial-tangential" || name == "plumb_bob") {
    *model = DistortionModel::kRadTan;
  } else if (name == "equidistant" || name == "equi" || name == "fisheye") {
    *model = DistortionModel::kEquidistant;
  } else {
    return false;
  }
  return true;
}

int NumDistortionCoefficients(DistortionModel model) {
  switch (model) {
    case DistortionModel::kNone:
      return 0;
    case DistortionModel::kRadTan:
    case DistortionModel::kEquidistant:
      return 4;
  }
  return 0;
}

Camera::Camera(int width, int height, const Eigen::Vector4d& fx_fy_cx_cy, DistortionModel model,
               const Eigen::VectorXd& distortion_coefficients)
    : width_(width),
      height_(height),
      intrinsics_(fx_fy_cx_cy),
      model_(model),
      coefficients_(distortion_coefficients) {}

std::string Camera::Validate() const {
  std::ostringstream error;
  if (width_ <= 0 || height_ <= 0) {
    error << "image size must be positive, got " << width_ << "x" << height_;
    return error.str();
  }
  if (!intrinsics_.allFinite()) return "intrinsics must be finite";
  if (!(fx() > 0.0) || !(fy() > 0.0)) {
    error << "focal lengths must be positive, got fx = " << fx() << ", fy = " << fy();
    return error.str();
  }
  if (cx() < 0.0 || cx() > width_ || cy() < 0.0 || cy() > height_) {
    error << "principal point (" << cx() << ", " << cy() << ") must lie inside the " << width_
          << "x" << height_ << " image";
    return error.str();
  }
  const int expected = NumDistortionCoefficients(model_);
  if (coefficients_.size() != expected) {
    error << "distortion model '" << ToString(model_) << "' takes " << expected
          << " coefficients, got " << coefficients_.size();
    return error.str();
  }
  if (!coefficients_.allFinite()) return "distortion coefficients must be finite";
  if (model_ == DistortionModel::kRadTan) {
    // Radtan polynomials fold over at large radii (d r_d / d r < 0). A calibration is only
    // usable if the image corners lie before the fold, i.e. every pixel has one ray. (Not
    // checked for equidistant: circular-fisheye corners legitimately see no ray.)
    const Eigen::Vector2d corners[4] = {
        {0.0, 0.0}, {width_ - 1.0, 0.0}, {0.0, height_ - 1.0}, {width_ - 1.0, height_ - 1.0}};
    for (const Eigen::Vector2d& corner : corners) {
      Eigen::Vector3d bearing;
      if (!Unproject(corner, &bearing)) {
        error << "radtan distortion is not invertible at image corner (" << corner.x() << ", "
              << corner.y() << "): the polynomial folds over inside the image";
        return error.str();
      }
    }
  }
  return std::string();
}

Eigen::Matrix3d Camera::K() const {
  Eigen::Matrix3d K = Eigen::Matrix3d::Identity();
  K(0, 0) = fx();
  K(1, 1) = fy();
  K(0, 2) = cx();
  K(1, 2) = cy();
  return K;
}

Eigen::Vector2d Camera::Distort(const Eigen::Vector2d& m, Eigen::Matrix2d* J) const {
  switch (model_) {
    case DistortionModel::kNone: {
      if (J != nullptr) J->setIdentity();
      return m;
    }
    case DistortionModel::kRadTan: {
      const double k1 = coefficients_[0], k2 = coefficients_[1];
      const double p1 = coefficients_[2], p2 = coefficients_[3];
      const double x = m.x(), y = m.y();
      const double x2 = x * x, y2 = y * y, xy = x * y;
      const double r2 = x2 + y2;
      const double radial = 1.0 + r2 * (k1 + k2 * r2);
      const Eigen::Vector2d d(x * radial + 2.0 * p1 * xy + p2 * (r2 + 2.0 * x2),
                              y * radial + p1 * (r2 + 2.0 * y2) + 2.0 * p2 * xy);
      if (J != nullptr) {
        // d radial / d x = 2 x (k1 + 2 k2 r^2), likewise for y.
        const double dr = 2.0 * (k1 + 2.0 * k2 * r2);
        (*J)(0, 0) = radial + x2 * dr + 2.0 * p1 * y + 6.0 * p2 * x;
        (*J)(0, 1) = xy * dr + 2.0 * p1 * x + 2.0 * p2 * y;
        (*J)(1, 0) = xy * dr + 2.0 * p1 * x + 2.0 * p2 * y;
        (*J)(1, 1) = radial + y2 * dr + 6.0 * p1 * y + 2.0 * p2 * x;
      }
      return d;
    }
    case DistortionModel::kEquidistant: {
      // d = s(r) m with s = theta_d(atan r) / r. Jacobian: s I + h m m^T with
      // h = s'(r) / r = (theta_d'(theta) r / (1 + r^2) - theta_d) / r^3.
      const double k1 = coefficients_[0];
      const double r2 = m.squaredNorm();
      const double r = std::sqrt(r2);
      double s, h;
      if (r < kEquidistantSmallRadius) {
        // theta = r - r^3/3 + O(r^5), theta_d = theta + k1 theta^3 + O(r^5)
        //   => s = 1 + (k1 - 1/3) r^2 + O(r^4), h = 2 (k1 - 1/3) + O(r^2).
        s = 1.0 + (k1 - 1.0 / 3.0) * r2;
        h = 2.0 * (k1 - 1.0 / 3.0);
      } else {
        const double theta = std::atan(r);
        double theta_d, d_theta_d;
        EquidistantThetaD(coefficients_, theta, &theta_d, &d_theta_d);
        s = theta_d / r;
        h = (d_theta_d * r / (1.0 + r2) - theta_d) / (r2 * r);
      }
      if (J != nullptr) *J = s * Eigen::Matrix2d::Identity() + h * m * m.transpose();
      return s * m;
    }
  }
  if (J != nullptr) J->setIdentity();
  return m;
}

bool Camera::Undistort(const Eigen::Vector2d& d, Eigen::Vector2d* m_out) const {
  if (!d.allFinite()) return false;
  switch (model_) {
    case DistortionModel::kNone:
      *m_out = d;
      return true;
    case DistortionModel::kRadTan: {
      // Gauss-Newton (= Newton, square system) on Distort(m) - d = 0 from m = d. The radtan
      // map is close to identity near the centre, so this converges quadratically in a few
      // iterations; a fold (det J <= 0) means the pixel has no (physical) ray.
      Eigen::Vector2d m = d;
      Eigen::Matrix2d J;
      double residual_norm = std::numeric_limits<double>::infinity();
      for (int i = 0; i < kMaxUndistortIterations; ++i) {
        const Eigen::Vector2d residual = Distort(m, &J) - d;
        residual_norm = residual.norm();
        if (!(residual_norm > kUndistortTolerance)) break;  // also stops on NaN
        const double det = J.determinant();
        if (!(det > 0.0)) return false;
        m -= J.inverse() * residual;  // 2x2 closed-form inverse
      }
      if (!(residual_norm < kUndistortAcceptTolerance) || !m.allFinite()) return false;
      // A solution past the fold is a second, non-physical preimage.
      if (!InDistortionDomain(model_, coefficients_, m)) return false;
      *m_out = m;
      return true;
    }
    case DistortionModel::kEquidistant: {
      // The model is radially symmetric: solve theta_d(theta) = |d| for theta by scalar Newton
      // (Gauss-Newton in one unknown), then m = tan(theta) d / |d|.
      const double target = d.norm();
      if (target < kEquidistantSmallRadius * 1e-3) {
        // |d| < 1e-8 (also avoids 0 / 0 on the axis): invert s = 1 + (k1 - 1/3) r^2 to first
        // order; the neglected terms are O(|d|^5), far below double precision.
        *m_out = d * (1.0 - (coefficients_[0] - 1.0 / 3.0) * target * target);
        return true;
      }
      double theta = std::min(target, 1.5);
      double theta_d = 0.0, d_theta_d = 1.0;
      double residual = std::numeric_limits<double>::infinity();
      for (int i = 0; i < kMaxUndistortIterations; ++i) {
        EquidistantThetaD(coefficients_, theta, &theta_d, &d_theta_d);
        residual = theta_d - target;
        if (!(std::abs(residual) > kUndistortTolerance)) break;
        if (!(d_theta_d > 0.0)) return false;
        theta -= residual / d_theta_d;
        // Keep the iterate in the half space in front of the camera.
        theta = std::clamp(theta, 0.0, 0.5 * M_PI - 1e-9);
      }
      EquidistantThetaD(coefficients_, theta, &theta_d, &d_theta_d);
      residual = theta_d - target;
      if (!(std::abs(residual) < kUndistortAcceptTolerance) || !(d_theta_d > 0.0) ||
          !(theta < 0.5 * M_PI - 1e-8)) {
        return false;
      }
      *m_out = (std::tan(theta) / target) * d;
      return m_out->allFinite();
    }
  }
  return false;
}

bool Camera::IsInImage(const Eigen::Vector2d& keypoint, double margin_px) const {
  // Pixel (i, j) covers [i - 0.5, i + 0.5) x [j - 0.5, j + 0.5) since (0, 0) is the centre of
  // the top-left pixel.
  return keypoint.x() >= -0.5 + margin_px && keypoint.x() < width_ - 0.5 - margin_px &&
         keypoint.y() >= -0.5 + margin_px && keypoint.y() < height_ - 0.5 - margin_px;
}

Camera::ProjectionResult Camera::Project(const Eigen::Vector3d& p_C, Eigen::Vector2d* keypoint,
                                         Eigen::Matrix<double, 2, 3>* J_keypoint_p_C) const {
  if (!p_C.allFinite()) return ProjectionResult::kNotFinite;
  if (!(p_C.z() > 0.0)) return ProjectionResult::kBehindCamera;
  const double inv_z = 1.0 / p_C.z();
  const Eigen::Vector2d m(p_C.x() * inv_z, p_C.y() * inv_z);
  Eigen::Matrix2d J_d_m;
  const Eigen::Vector2d d = Distort(m, &J_d_m);
  const Eigen::Vector2d u(fx() * d.x() + cx(), fy() * d.y() + cy());
  if (!u.allFinite()) return ProjectionResult::kNotFinite;
  *keypoint = u;
  if (J_keypoint_p_C != nullptr) {
    // d m / d p_C = [1/Z 0 -X/Z^2; 0 1/Z -Y/Z^2].
    Eigen::Matrix<double, 2, 3> J_m_p;
    J_m_p << inv_z, 0.0, -m.x() * inv_z,  //
        0.0, inv_z, -m.y() * inv_z;
    const Eigen::Matrix2d J_u_d = Eigen::Vector2d(fx(), fy()).asDiagonal();
    *J_keypoint_p_C = J_u_d * J_d_m * J_m_p;
  }
  // A ray past the fold of the distortion polynomial can land inside the image but is not seen
  // there: report it as outside.
  if (!InDistortionDomain(model_, coefficients_, m) || !IsInImage(u)) {
    return ProjectionResult::kOutsideImage;
  }
  return ProjectionResult::kValid;
}

bool Camera::Unproject(const Eigen::Vector2d& keypoint, Eigen::Vector3d* bearing_C,
                       Eigen::Matrix<double, 3, 2>* J_bearing_keypoint) const {
  const Eigen::Vector2d d((keypoint.x() - cx()) / fx(), (keypoint.y() - cy()) / fy());
  Eigen::Vector2d m;
  if (!Undistort(d, &m)) return false;
  const Eigen::Vector3d ray(m.x(), m.y(), 1.0);
  const double norm = ray.norm();
  const Eigen::Vector3d bearing = ray / norm;
  if (J_bearing_keypoint != nullptr) {
    // bearing = ray / |ray|: d bearing / d ray = (I - b b^T) / |ray|; ray = (m, 1);
    // d m / d d = (d Distort / d m)^-1 (inverse function theorem); d d / d u = diag(1/f).
    Eigen::Matrix2d J_d_m;
    Distort(m, &J_d_m);
    const Eigen::Matrix3d J_b_ray =
        (Eigen::Matrix3d::Identity() - bearing * bearing.transpose()) / norm;
    const Eigen::Matrix2d J_m_u =
        J_d_m.inverse() * Eigen::Vector2d(1.0 / fx(), 1.0 / fy()).asDiagonal();
    *J_bearing_keypoint = J_b_ray.leftCols<2>() * J_m_u;
  }
  *bearing_C = bearing;
  return true;
}

Camera Camera::UndistortedPinhole(double alpha) const {
  // As OpenCV's getOptimalNewCameraMatrix: undistort the image border (pixel centres), take
  // the inner rectangle (inside the undistorted border: every target pixel has source data)
  // and the outer one (bounding box: every source pixel is visible), map each to the pixel
  // centres [0, w-1] x [0, h-1] of the new camera and blend the two by alpha. Every border
  // pixel is sampled (not OpenCV's 9x9 grid), so the inner rectangle is tight.
  double inner_left = -std::numeric_limits<double>::infinity();
  double inner_right = std::numeric_limits<double>::infinity();
  double inner_top = -std::numeric_limits<double>::infinity();
  double inner_bottom = std::numeric_limits<double>::infinity();
  double outer_left = std::numeric_limits<double>::infinity();
  double outer_right = -std::numeric_limits<double>::infinity();
  double outer_top = std::numeric_limits<double>::infinity();
  double outer_bottom = -std::numeric_limits<double>::infinity();

  // Undistorted normalized coordinates of a pixel; false where it has no ray (fisheye
  // corners, radtan fold), which then bounds neither rectangle.
  auto undistort_pixel = [this](double u, double v, Eigen::Vector2d* m) {
    return Undistort(Eigen::Vector2d((u - cx()) / fx(), (v - cy()) / fy()), m);
  };
  auto grow_outer = [&](const Eigen::Vector2d& m) {
    outer_left = std::min(outer_left, m.x());
    outer_right = std::max(outer_right, m.x());
    outer_top = std::min(outer_top, m.y());
    outer_bottom = std::max(outer_bottom, m.y());
  };
  const double u_max = width_ - 1.0, v_max = height_ - 1.0;
  Eigen::Vector2d m;
  for (int i = 0; i < width_; ++i) {
    if (undistort_pixel(i, 0.0, &m)) {
      inner_top = std::max(inner_top, m.y());
      grow_outer(m);
    }
    if (undistort_pixel(i, v_max, &m)) {
      inner_bottom = std::min(inner_bottom, m.y());
      grow_outer(m);
    }
  }
  for (int j = 0; j < height_; ++j) {
    if (undistort_pixel(0.0, j, &m)) {
      inner_left = std::max(inner_left, m.x());
      grow_outer(m);
    }
    if (undistort_pixel(u_max, j, &m)) {
      inner_right = std::min(inner_right, m.x());
      grow_outer(m);
    }
  }

  Eigen::Vector4d new_intrinsics = intrinsics_;
  const bool inner_ok = std::isfinite(inner_left) && std::isfinite(inner_right) &&
                        std::isfinite(inner_top) && std::isfinite(inner_bottom) &&
                        inner_right > inner_left && inner_bottom > inner_top;
  const bool outer_ok = outer_right > outer_left && outer_bottom > outer_top;
  if (inner_ok && outer_ok && width_ > 1 && height_ > 1) {
    // Map [left, right] -> [0, w-1]: f = (w-1) / (right - left), c = -f left.
    const double fx0 = u_max / (inner_right - inner_left), cx0 = -fx0 * inner_left;
    const double fy0 = v_max / (inner_bottom - inner_top), cy0 = -fy0 * inner_top;
    const double fx1 = u_max / (outer_right - outer_left), cx1 = -fx1 * outer_left;
    const double fy1 = v_max / (outer_bottom - outer_top), cy1 = -fy1 * outer_top;
    new_intrinsics << (1.0 - alpha) * fx0 + alpha * fx1, (1.0 - alpha) * fy0 + alpha * fy1,
        (1.0 - alpha) * cx0 + alpha * cx1, (1.0 - alpha) * cy0 + alpha * cy1;
  }
  return Camera(width_, height_, new_intrinsics, DistortionModel::kNone, Eigen::VectorXd());
}

void Camera::ComputeUndistortionMaps(const Camera& target, cv::Mat* map_x, cv::Mat* map_y) const {
  map_x->create(target.height(), target.width(), CV_32FC1);
  map_y->create(target.height(), target.width(), CV_32FC1);
  Eigen::Vector3d bearing_C;
  Eigen::Vector2d keypoint;
  for (int v = 0; v < target.height(); ++v) {
    float* row_x = map_x->ptr<float>(v);
    float* row_y = map_y->ptr<float>(v);
    for (int u = 0; u < target.width(); ++u) {
      float mx = kInvalidMapValue, my = kInvalidMapValue;
      if (target.Unproject(Eigen::Vector2d(u, v), &bearing_C)) {
        const ProjectionResult result = Project(bearing_C, &keypoint);
        // Keypoints outside this image are kept (cv::remap's border mode handles them), except
        // rays past a distortion fold that Project reports outside while landing inside.
        if (result == ProjectionResult::kValid ||
            (result == ProjectionResult::kOutsideImage && !IsInImage(keypoint))) {
          mx = static_cast<float>(keypoint.x());
          my = static_cast<float>(keypoint.y());
        }
      }
      row_x[u] = mx;
      row_y[u] = my;
    }
  }
}

}  // namespace vilma
