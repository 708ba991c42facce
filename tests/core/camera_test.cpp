// Camera models (camera.h): round trips, analytic Jacobians against central differences,
// validation, and undistortion against OpenCV (calib3d) as an independent reference.
#include "vilma/core/camera.h"

#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>
#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <random>
#include <string>
#include <vector>

#include "core/test_utils.h"
#include "test_skip.h"

namespace vilma {
namespace {

// EuRoC MAV cam0 (V1_01 sensor.yaml): pinhole + radial-tangential, 752x480.
Camera EurocCam0(DistortionModel model = DistortionModel::kRadTan) {
  Eigen::VectorXd coefficients;
  if (model == DistortionModel::kRadTan) {
    coefficients.resize(4);
    coefficients << -0.28340811, 0.07395907, 0.00019359, 1.76187114e-05;
  }
  return Camera(752, 480, Eigen::Vector4d(458.654, 457.296, 367.215, 248.375), model, coefficients);
}

// TUM VI cam0 (Kalibr pinhole + equidistant, 512x512, ~190 degree field of view: the image
// corners see no ray).
Camera TumViFisheye() {
  Eigen::VectorXd coefficients(4);
  coefficients << 0.0034823894022493434, 0.0007150348452162257, -0.0020532361418706202,
      0.00020293673591811182;
  return Camera(
      512, 512,
      Eigen::Vector4d(190.97847715128717, 190.9733070521226, 254.93170605935475, 256.8974428996504),
      DistortionModel::kEquidistant, coefficients);
}

Camera CameraByName(const std::string& name) {
  if (name == "none") return EurocCam0(DistortionModel::kNone);
  if (name == "radtan") return EurocCam0(DistortionModel::kRadTan);
  return TumViFisheye();
}

cv::Mat ToCvK(const Camera& camera) {
  cv::Mat K;
  cv::eigen2cv(camera.K(), K);
  return K;
}

cv::Mat ToCvD(const Camera& camera) {
  cv::Mat D(1, 4, CV_64F);
  for (int i = 0; i < 4; ++i) D.at<double>(0, i) = camera.distortion_coefficients()[i];
  return D;
}

// Points in front of the camera whose projections cover the image (and the optical axis).
std::vector<Eigen::Vector3d> TestPoints(const Camera& camera) {
  std::vector<Eigen::Vector3d> points = {{0.0, 0.0, 1.0}, {1e-9, -2e-9, 2.0}, {3e-6, 1e-6, 1.0}};
  std::mt19937 rng(17);
  std::uniform_real_distribution<double> u(0.0, camera.width() - 1.0);
  std::uniform_real_distribution<double> v(0.0, camera.height() - 1.0);
  std::uniform_real_distribution<double> depth(0.5, 20.0);
  while (points.size() < 40) {
    Eigen::Vector3d bearing;
    // v before u: the order GCC drew them in (tests/test_random.h).
    const double pixel_v = v(rng);
    const double pixel_u = u(rng);
    if (!camera.Unproject(Eigen::Vector2d(pixel_u, pixel_v), &bearing)) continue;
    points.push_back(bearing * depth(rng));
  }
  return points;
}

TEST_CASE("Distortion model names and coefficient counts", "[camera]") {
  DistortionModel model;
  for (const DistortionModel m :
       {DistortionModel::kNone, DistortionModel::kRadTan, DistortionModel::kEquidistant}) {
    REQUIRE(ParseDistortionModel(ToString(m), &model));
    CHECK(model == m);
  }
  const std::vector<std::pair<std::string, DistortionModel>> aliases = {
      {"radial-tangential", DistortionModel::kRadTan},
      {"plumb_bob", DistortionModel::kRadTan},
      {"equi", DistortionModel::kEquidistant},
      {"fisheye", DistortionModel::kEquidistant}};
  for (const auto& [name, expected] : aliases) {
    INFO(name);
    REQUIRE(ParseDistortionModel(name, &model));
    CHECK(model == expected);
  }
  CHECK_FALSE(ParseDistortionModel("pinhole-radtan", &model));
  CHECK_FALSE(ParseDistortionModel("", &model));
  CHECK(NumDistortionCoefficients(DistortionModel::kNone) == 0);
  CHECK(NumDistortionCoefficients(DistortionModel::kRadTan) == 4);
  CHECK(NumDistortionCoefficients(DistortionModel::kEquidistant) == 4);
}

TEST_CASE("Validate names the problem", "[camera]") {
  CHECK(EurocCam0().Validate().empty());
  CHECK(EurocCam0(DistortionModel::kNone).Validate().empty());
  CHECK(TumViFisheye().Validate().empty());

  const Eigen::Vector4d k(458.654, 457.296, 367.215, 248.375);
  const Eigen::VectorXd d4 = EurocCam0().distortion_coefficients();
  using Catch::Matchers::Contains;
  CHECK_THAT(Camera(752, 480, Eigen::Vector4d(0.0, 457.296, 367.215, 248.375),
                    DistortionModel::kRadTan, d4)
                 .Validate(),
             Contains("focal"));
  CHECK_THAT(Camera(752, 480, Eigen::Vector4d(458.654, -1.0, 367.215, 248.375),
                    DistortionModel::kRadTan, d4)
                 .Validate(),
             Contains("focal"));
  CHECK_THAT(Camera(752, 480, k, DistortionModel::kRadTan, Eigen::VectorXd::Zero(3)).Validate(),
             Contains("4 coefficients") && Contains("got 3") && Contains("radtan"));
  CHECK_THAT(Camera(752, 480, k, DistortionModel::kNone, d4).Validate(), Contains("coefficients"));
  CHECK_THAT(Camera(0, 480, k, DistortionModel::kRadTan, d4).Validate(), Contains("size"));
  CHECK_THAT(Camera(752, -3, k, DistortionModel::kRadTan, d4).Validate(), Contains("size"));
  CHECK_THAT(Camera(752, 480, Eigen::Vector4d(458.654, 457.296, 800.0, 248.375),
                    DistortionModel::kRadTan, d4)
                 .Validate(),
             Contains("principal point"));
  CHECK_THAT(Camera(752, 480, Eigen::Vector4d(458.654, NAN, 367.215, 248.375),
                    DistortionModel::kRadTan, d4)
                 .Validate(),
             Contains("finite"));
  // r_d = r - 0.5 r^3 folds at r = 0.816 (r_d = 0.544) while the corners are at r_d ~ 0.97.
  Eigen::VectorXd folding(4);
  folding << -0.5, 0.0, 0.0, 0.0;
  CHECK_THAT(Camera(752, 480, k, DistortionModel::kRadTan, folding).Validate(), Contains("fold"));
  CHECK_FALSE(Camera().Validate().empty());
}

TEST_CASE("Unproject then Project round trip over a pixel grid", "[camera]") {
  const std::string name = GENERATE(as<std::string>{}, "none", "radtan", "equidistant");
  const Camera camera = CameraByName(name);
  INFO("model " << name);
  int checked = 0;
  double max_error_px = 0.0;
  for (double v = 0.0; v <= camera.height() - 1.0; v += (camera.height() - 1.0) / 30.0) {
    for (double u = 0.0; u <= camera.width() - 1.0; u += (camera.width() - 1.0) / 40.0) {
      const Eigen::Vector2d keypoint(u, v);
      Eigen::Vector3d bearing;
      const bool ok = camera.Unproject(keypoint, &bearing);
      if (camera.distortion_model() == DistortionModel::kEquidistant) {
        // Pixels up to 80 degrees off the axis must unproject; beyond 90 degrees (the fisheye
        // corners) they must not.
        double theta_d =
            Eigen::Vector2d((u - camera.cx()) / camera.fx(), (v - camera.cy()) / camera.fy())
                .norm();
        if (theta_d < 80.0 * M_PI / 180.0) REQUIRE(ok);
        if (theta_d > 1.7) REQUIRE_FALSE(ok);
      } else {
        REQUIRE(ok);
      }
      if (!ok) continue;
      CHECK(std::abs(bearing.norm() - 1.0) < 1e-14);
      CHECK(bearing.z() > 0.0);
      Eigen::Vector2d reprojected;
      REQUIRE(camera.Project(bearing, &reprojected) == Camera::ProjectionResult::kValid);
      const double error = (reprojected - keypoint).norm();
      max_error_px = std::max(max_error_px, error);
      CHECK(error < 1e-6);
      ++checked;
    }
  }
  CHECK(checked > 700);
  WARN("model " << name << ": " << checked << " grid pixels, max round-trip error " << max_error_px
                << " px");
}

TEST_CASE("Project then Unproject returns the bearing", "[camera]") {
  const std::string name = GENERATE(as<std::string>{}, "none", "radtan", "equidistant");
  const Camera camera = CameraByName(name);
  INFO("model " << name);
  for (const Eigen::Vector3d& p_C : TestPoints(camera)) {
    INFO("p_C " << p_C.transpose());
    Eigen::Vector2d keypoint;
    REQUIRE(camera.Project(p_C, &keypoint) == Camera::ProjectionResult::kValid);
    Eigen::Vector3d bearing;
    REQUIRE(camera.Unproject(keypoint, &bearing));
    VILMA_CHECK_MATRIX_NEAR(bearing, p_C.normalized(), 1e-12);
  }
}

TEST_CASE("Analytic Jacobians match central differences", "[camera]") {
  const std::string name = GENERATE(as<std::string>{}, "none", "radtan", "equidistant");
  const Camera camera = CameraByName(name);
  INFO("model " << name);

  SECTION("Project: d keypoint / d p_C") {
    for (const Eigen::Vector3d& p_C : TestPoints(camera)) {
      INFO("p_C " << p_C.transpose());
      Eigen::Vector2d keypoint;
      Eigen::Matrix<double, 2, 3> J;
      REQUIRE(camera.Project(p_C, &keypoint, &J) == Camera::ProjectionResult::kValid);
      const Eigen::Matrix<double, 2, 3> J_numeric = test::NumericJacobian<2, 3>(
          [&](const Eigen::Vector3d& p) -> Eigen::Vector2d {
            Eigen::Vector2d k;
            camera.Project(p, &k);
            return k;
          },
          p_C, 1e-5 * p_C.norm());
      VILMA_CHECK_MATRIX_NEAR(J, J_numeric, 1e-6);
    }
  }

  SECTION("Unproject: d bearing / d keypoint") {
    for (const Eigen::Vector3d& p_C : TestPoints(camera)) {
      Eigen::Vector2d keypoint;
      REQUIRE(camera.Project(p_C, &keypoint) == Camera::ProjectionResult::kValid);
      INFO("keypoint " << keypoint.transpose());
      Eigen::Vector3d bearing;
      Eigen::Matrix<double, 3, 2> J;
      REQUIRE(camera.Unproject(keypoint, &bearing, &J));
      const Eigen::Matrix<double, 3, 2> J_numeric = test::NumericJacobian<3, 2>(
          [&](const Eigen::Vector2d& k) -> Eigen::Vector3d {
            Eigen::Vector3d b;
            REQUIRE(camera.Unproject(k, &b));
            return b;
          },
          keypoint, 1e-2);
      // Entries are ~1/f ~ 2e-3: compare relative to the Jacobian's own scale.
      const double scale = J_numeric.cwiseAbs().maxCoeff();
      VILMA_CHECK_MATRIX_NEAR(J / scale, J_numeric / scale, 1e-6);
    }
  }

  SECTION("Distort: d distorted / d undistorted, including the optical axis") {
    std::vector<Eigen::Vector2d> points = {
        {0.0, 0.0}, {1e-12, 0.0}, {3e-6, -4e-6}, {1e-5, 0.0}, {2e-5, 1e-7}};
    for (const Eigen::Vector3d& p_C : TestPoints(camera)) {
      points.emplace_back(p_C.x() / p_C.z(), p_C.y() / p_C.z());
    }
    for (const Eigen::Vector2d& m : points) {
      INFO("m " << m.transpose());
      Eigen::Matrix2d J;
      const Eigen::Vector2d d = camera.Distort(m, &J);
      CHECK(d.allFinite());
      const Eigen::Matrix2d J_numeric = test::NumericJacobian<2, 2>(
          [&](const Eigen::Vector2d& x) -> Eigen::Vector2d { return camera.Distort(x); }, m,
          1e-6 * std::max(1.0, m.norm()));
      VILMA_CHECK_MATRIX_NEAR(J, J_numeric, 1e-6);
      // Undistort inverts Distort.
      Eigen::Vector2d m_back;
      REQUIRE(camera.Undistort(d, &m_back));
      VILMA_CHECK_MATRIX_NEAR(m_back, m, 1e-12);
    }
  }
}

TEST_CASE("Equidistant model is exact on and near the optical axis", "[camera]") {
  const Camera camera = TumViFisheye();
  const double k1 = camera.distortion_coefficients()[0];
  // On the axis: the principal point, identity Jacobian of Distort.
  Eigen::Vector2d keypoint;
  Eigen::Matrix<double, 2, 3> J;
  REQUIRE(camera.Project(Eigen::Vector3d(0.0, 0.0, 2.0), &keypoint, &J) ==
          Camera::ProjectionResult::kValid);
  VILMA_CHECK_MATRIX_NEAR(keypoint, Eigen::Vector2d(camera.cx(), camera.cy()), 1e-15);
  Eigen::Matrix<double, 2, 3> J_expected;
  J_expected << camera.fx() / 2.0, 0.0, 0.0, 0.0, camera.fy() / 2.0, 0.0;
  VILMA_CHECK_MATRIX_NEAR(J, J_expected, 1e-15);
  // Either side of the series/closed-form switch, s(r) = theta_d / r is continuous and equal
  // to 1 + (k1 - 1/3) r^2 to O(r^4).
  // Its Jacobian s I + h m m^T has h = s'(r) / r = 2 (k1 - 1/3) + O(r^2), seen on m = (r, 0)
  // as J(0, 0) - J(1, 1) = h r^2 (measurable to ~2e-16 / r^2).
  for (double r : {1e-7, 3e-6, 9.99e-6, 1.001e-5, 1e-4}) {
    INFO("r " << r);
    Eigen::Matrix2d J_d;
    const Eigen::Vector2d d = camera.Distort(Eigen::Vector2d(r, 0.0), &J_d);
    CHECK(d.x() / r == Approx(1.0 + (k1 - 1.0 / 3.0) * r * r).epsilon(1e-12));
    CHECK(d.y() == 0.0);
    CHECK(J_d(1, 1) == Approx(1.0 + (k1 - 1.0 / 3.0) * r * r).epsilon(1e-12));
    if (r >= 3e-6) {
      CHECK((J_d(0, 0) - J_d(1, 1)) / (r * r) == Approx(2.0 * (k1 - 1.0 / 3.0)).epsilon(1e-3));
    }
  }
  // Unproject of the principal point and a pixel next to it.
  Eigen::Vector3d bearing;
  Eigen::Matrix<double, 3, 2> J_b;
  REQUIRE(camera.Unproject(Eigen::Vector2d(camera.cx(), camera.cy()), &bearing, &J_b));
  VILMA_CHECK_MATRIX_NEAR(bearing, Eigen::Vector3d(0.0, 0.0, 1.0), 1e-15);
  Eigen::Matrix<double, 3, 2> J_b_expected = Eigen::Matrix<double, 3, 2>::Zero();
  J_b_expected(0, 0) = 1.0 / camera.fx();
  J_b_expected(1, 1) = 1.0 / camera.fy();
  VILMA_CHECK_MATRIX_NEAR(J_b * camera.fx(), J_b_expected * camera.fx(), 1e-14);
}

TEST_CASE("Projection results: behind the camera, outside the image, not finite", "[camera]") {
  const std::string name = GENERATE(as<std::string>{}, "none", "radtan", "equidistant");
  const Camera camera = CameraByName(name);
  INFO("model " << name);
  Eigen::Vector2d keypoint(-7.0, -7.0);
  CHECK(camera.Project(Eigen::Vector3d(0.1, 0.2, -1.0), &keypoint) ==
        Camera::ProjectionResult::kBehindCamera);
  CHECK(camera.Project(Eigen::Vector3d(0.1, 0.2, 0.0), &keypoint) ==
        Camera::ProjectionResult::kBehindCamera);
  CHECK(camera.Project(Eigen::Vector3d(0.0, 0.0, 0.0), &keypoint) ==
        Camera::ProjectionResult::kBehindCamera);
  CHECK(camera.Project(Eigen::Vector3d(NAN, 0.0, 1.0), &keypoint) ==
        Camera::ProjectionResult::kNotFinite);
  CHECK(camera.Project(Eigen::Vector3d(INFINITY, 0.0, 1.0), &keypoint) ==
        Camera::ProjectionResult::kNotFinite);
  // 60 degrees to the right of the axis: outside every test camera's image except the
  // fisheye's; 85 degrees is outside all. The keypoint and Jacobian are still written.
  const double angle = camera.distortion_model() == DistortionModel::kEquidistant ? 1.5 : 1.05;
  Eigen::Matrix<double, 2, 3> J = Eigen::Matrix<double, 2, 3>::Zero();
  CHECK(camera.Project(Eigen::Vector3d(std::sin(angle), 0.0, std::cos(angle)), &keypoint, &J) ==
        Camera::ProjectionResult::kOutsideImage);
  CHECK(keypoint.x() > camera.width() - 0.5);
  // On the horizontal through the principal point (radtan's tangential terms shift it 0.27 px).
  CHECK(std::abs(keypoint.y() - camera.cy()) < 0.5);
  CHECK(J(0, 0) > 0.0);
  // Just inside / outside the pixel area [-0.5, w - 0.5) x [-0.5, h - 0.5).
  CHECK(camera.IsInImage(Eigen::Vector2d(-0.5, -0.5)));
  CHECK(camera.IsInImage(Eigen::Vector2d(camera.width() - 0.5001, camera.height() - 0.5001)));
  CHECK_FALSE(camera.IsInImage(Eigen::Vector2d(camera.width() - 0.5, 10.0)));
  CHECK_FALSE(camera.IsInImage(Eigen::Vector2d(10.0, -0.51)));
  CHECK_FALSE(camera.IsInImage(Eigen::Vector2d(3.0, 10.0), 4.0));
  CHECK(camera.IsInImage(Eigen::Vector2d(3.6, 10.0), 4.0));
}

TEST_CASE("Radtan fold: rays past the fold are outside, pixels past it do not unproject",
          "[camera]") {
  // r_d = r - 0.5 r^3: increasing up to r = sqrt(2/3), r_d = 0.544, then decreasing. A ray at
  // r = 1.5 maps to r_d = -0.19, i.e. inside the image on the wrong side.
  Eigen::VectorXd folding(4);
  folding << -0.5, 0.0, 0.0, 0.0;
  const Camera camera(752, 480, Eigen::Vector4d(458.654, 457.296, 367.215, 248.375),
                      DistortionModel::kRadTan, folding);
  Eigen::Vector2d keypoint;
  CHECK(camera.Project(Eigen::Vector3d(1.5, 0.0, 1.0), &keypoint) ==
        Camera::ProjectionResult::kOutsideImage);
  CHECK(camera.IsInImage(keypoint));
  Eigen::Vector3d bearing;
  CHECK_FALSE(
      camera.Unproject(Eigen::Vector2d(camera.cx() + 0.6 * camera.fx(), camera.cy()), &bearing));
  REQUIRE(
      camera.Unproject(Eigen::Vector2d(camera.cx() + 0.5 * camera.fx(), camera.cy()), &bearing));
  CHECK(bearing.x() / bearing.z() < std::sqrt(2.0 / 3.0));
}

TEST_CASE("Project and undistortion agree with OpenCV (calib3d)", "[camera]") {
  SECTION("radtan: cv::projectPoints and cv::undistortPoints") {
    const Camera camera = EurocCam0();
    const std::vector<Eigen::Vector3d> points = TestPoints(camera);
    std::vector<cv::Point3d> object;
    for (const Eigen::Vector3d& p : points) object.emplace_back(p.x(), p.y(), p.z());
    std::vector<cv::Point2d> projected;
    cv::projectPoints(object, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), ToCvK(camera), ToCvD(camera),
                      projected);
    std::vector<cv::Point2d> keypoints;
    for (size_t i = 0; i < points.size(); ++i) {
      Eigen::Vector2d keypoint;
      REQUIRE(camera.Project(points[i], &keypoint) == Camera::ProjectionResult::kValid);
      CHECK(std::abs(keypoint.x() - projected[i].x) < 1e-9);
      CHECK(std::abs(keypoint.y() - projected[i].y) < 1e-9);
      keypoints.emplace_back(keypoint.x(), keypoint.y());
    }
    // A few pixels including one near the corner (strongest distortion). OpenCV iterates a
    // fixed point; let it run to a 1e-10 px reprojection error.
    keypoints.insert(keypoints.end(), {{367.0, 248.0}, {10.0, 12.0}, {740.0, 470.0}, {5.0, 400.0}});
    std::vector<cv::Point2d> undistorted;
    cv::undistortPoints(
        keypoints, undistorted, ToCvK(camera), ToCvD(camera), cv::noArray(), cv::noArray(),
        cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 2000, 1e-10));
    for (size_t i = 0; i < keypoints.size(); ++i) {
      INFO("keypoint " << keypoints[i]);
      Eigen::Vector3d bearing;
      REQUIRE(camera.Unproject(Eigen::Vector2d(keypoints[i].x, keypoints[i].y), &bearing));
      // Compare in pixels of the undistorted normalized plane.
      CHECK(std::abs(bearing.x() / bearing.z() - undistorted[i].x) * camera.fx() < 1e-6);
      CHECK(std::abs(bearing.y() / bearing.z() - undistorted[i].y) * camera.fy() < 1e-6);
    }
  }

  SECTION("equidistant: cv::fisheye::projectPoints and cv::fisheye::undistortPoints") {
    const Camera camera = TumViFisheye();
    const std::vector<Eigen::Vector3d> points = TestPoints(camera);
    std::vector<cv::Point3d> object;
    for (const Eigen::Vector3d& p : points) object.emplace_back(p.x(), p.y(), p.z());
    std::vector<cv::Point2d> projected;
    cv::fisheye::projectPoints(object, projected, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0),
                               ToCvK(camera), ToCvD(camera));
    std::vector<cv::Point2d> keypoints;
    for (size_t i = 0; i < points.size(); ++i) {
      Eigen::Vector2d keypoint;
      REQUIRE(camera.Project(points[i], &keypoint) == Camera::ProjectionResult::kValid);
      CHECK(std::abs(keypoint.x() - projected[i].x) < 1e-9);
      CHECK(std::abs(keypoint.y() - projected[i].y) < 1e-9);
      keypoints.emplace_back(keypoint.x(), keypoint.y());
    }
    std::vector<cv::Point2d> undistorted;
    cv::fisheye::undistortPoints(
        keypoints, undistorted, ToCvK(camera), ToCvD(camera), cv::noArray(), cv::noArray(),
        cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 100, 1e-14));
    for (size_t i = 0; i < keypoints.size(); ++i) {
      INFO("keypoint " << keypoints[i]);
      Eigen::Vector3d bearing;
      REQUIRE(camera.Unproject(Eigen::Vector2d(keypoints[i].x, keypoints[i].y), &bearing));
      const double scale = camera.fx() * std::max(1.0, 1.0 / bearing.z());
      CHECK(std::abs(bearing.x() / bearing.z() - undistorted[i].x) * camera.fx() < 1e-6 * scale);
      CHECK(std::abs(bearing.y() / bearing.z() - undistorted[i].y) * camera.fy() < 1e-6 * scale);
    }
  }
}

TEST_CASE("UndistortedPinhole keeps valid pixels (alpha 0) or all pixels (alpha 1)", "[camera]") {
  const Camera camera = EurocCam0();
  const Camera inner = camera.UndistortedPinhole(0.0);
  const Camera outer = camera.UndistortedPinhole(1.0);
  REQUIRE(inner.Validate().empty());
  REQUIRE(outer.Validate().empty());
  CHECK(inner.distortion_model() == DistortionModel::kNone);
  CHECK(inner.width() == camera.width());
  CHECK(inner.height() == camera.height());
  // Barrel distortion: cropping to valid pixels zooms in, showing everything zooms out.
  CHECK(inner.fx() > outer.fx());
  CHECK(inner.fy() > outer.fy());
  // alpha = 0: every target pixel's ray lands inside the source (within float rounding), and
  // the rectangle is tight: some border pixel lands on the source border.
  cv::Mat map_x, map_y;
  camera.ComputeUndistortionMaps(inner, &map_x, &map_y);
  double min_x, max_x, min_y, max_y;
  cv::minMaxLoc(map_x, &min_x, &max_x);
  cv::minMaxLoc(map_y, &min_y, &max_y);
  CHECK(min_x > -1e-3);
  CHECK(min_y > -1e-3);
  CHECK(max_x < camera.width() - 1.0 + 1e-3);
  CHECK(max_y < camera.height() - 1.0 + 1e-3);
  CHECK(std::min({min_x, min_y, camera.width() - 1.0 - max_x, camera.height() - 1.0 - max_y}) <
        0.01);
  // alpha = 1: every source pixel centre is seen by the target.
  for (const Eigen::Vector2d& corner :
       {Eigen::Vector2d(0.0, 0.0), Eigen::Vector2d(751.0, 0.0), Eigen::Vector2d(0.0, 479.0),
        Eigen::Vector2d(751.0, 479.0), Eigen::Vector2d(0.0, 240.0), Eigen::Vector2d(376.0, 0.0)}) {
    Eigen::Vector3d bearing;
    REQUIRE(camera.Unproject(corner, &bearing));
    Eigen::Vector2d keypoint;
    CHECK(outer.Project(bearing, &keypoint) == Camera::ProjectionResult::kValid);
    CHECK(outer.IsInImage(keypoint, -1e-6));
  }
  // alpha blends linearly.
  const Camera half = camera.UndistortedPinhole(0.5);
  VILMA_CHECK_MATRIX_NEAR(half.intrinsics(), 0.5 * (inner.intrinsics() + outer.intrinsics()),
                          1e-12);
  // Fisheye: corners without a ray are skipped; the result is still a usable camera.
  const Camera fisheye_inner = TumViFisheye().UndistortedPinhole(0.0);
  CHECK(fisheye_inner.Validate().empty());
}

TEST_CASE("Undistortion maps agree with OpenCV's initUndistortRectifyMap", "[camera]") {
  const std::string name = GENERATE(as<std::string>{}, "radtan", "equidistant");
  const Camera camera = CameraByName(name);
  INFO("model " << name);
  const Camera target = camera.UndistortedPinhole(0.0);
  cv::Mat map_x, map_y;
  camera.ComputeUndistortionMaps(target, &map_x, &map_y);
  REQUIRE(map_x.type() == CV_32FC1);
  REQUIRE(map_x.size() == cv::Size(target.width(), target.height()));
  cv::Mat cv_map_x, cv_map_y;
  const cv::Size size(target.width(), target.height());
  if (camera.distortion_model() == DistortionModel::kRadTan) {
    cv::initUndistortRectifyMap(ToCvK(camera), ToCvD(camera), cv::Mat(), ToCvK(target), size,
                                CV_32FC1, cv_map_x, cv_map_y);
  } else {
    cv::fisheye::initUndistortRectifyMap(ToCvK(camera), ToCvD(camera), cv::Mat::eye(3, 3, CV_64F),
                                         ToCvK(target), size, CV_32FC1, cv_map_x, cv_map_y);
  }
  // Both store float32: ~5e-5 px resolution at 752 px.
  const double diff_x = cv::norm(map_x, cv_map_x, cv::NORM_INF);
  const double diff_y = cv::norm(map_y, cv_map_y, cv::NORM_INF);
  WARN("model " << name << ": max |map - OpenCV map| = " << std::max(diff_x, diff_y) << " px");
  CHECK(diff_x < 1e-3);
  CHECK(diff_y < 1e-3);
}

// A smooth pattern on the unit sphere of bearings in C: a function of the direction only, so
// that its period in pixels is >= ~0.3 * f for any camera.
float Pattern(const Eigen::Vector3d& b) {
  return static_cast<float>(128.0 + 100.0 * std::sin(2.0 * M_PI * b.x() / 0.3) *
                                        std::cos(2.0 * M_PI * (b.y() + 0.3 * b.x()) / 0.35));
}

// Renders the pattern as seen by `camera`: each pixel looks along its ray.
cv::Mat Render(const Camera& camera) {
  cv::Mat image(camera.height(), camera.width(), CV_32FC1, cv::Scalar(0));
  for (int v = 0; v < camera.height(); ++v) {
    for (int u = 0; u < camera.width(); ++u) {
      Eigen::Vector3d b;
      if (camera.Unproject(Eigen::Vector2d(u, v), &b)) {
        image.at<float>(v, u) = Pattern(b);
      }
    }
  }
  return image;
}

TEST_CASE("Remapping a rendered distorted image yields the undistorted rendering", "[camera]") {
  const std::string name = GENERATE(as<std::string>{}, "radtan", "equidistant");
  const Camera camera = CameraByName(name);
  INFO("model " << name);
  const Camera target = camera.UndistortedPinhole(0.0);
  cv::Mat map_x, map_y;
  camera.ComputeUndistortionMaps(target, &map_x, &map_y);
  cv::Mat remapped;
  cv::remap(Render(camera), remapped, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT,
            cv::Scalar(-1000));
  const cv::Mat expected = Render(target);
  // Bilinear interpolation of a sinusoid of amplitude 100 and period P px errs by up to
  // (2 pi / P)^2 / 8 * 100: 0.15 grey levels for the shortest period (0.3 * 191 px in the
  // fisheye). A map off by 0.1 px errs by up to 0.1 * 100 * 2 pi / P ~ 1 grey level.
  double max_error = 0.0, sum_error = 0.0;
  int count = 0;
  for (int v = 0; v < target.height(); ++v) {
    for (int u = 0; u < target.width(); ++u) {
      const float x = map_x.at<float>(v, u), y = map_y.at<float>(v, u);
      if (x < 0.0f || y < 0.0f || x > camera.width() - 1.0f || y > camera.height() - 1.0f) continue;
      const double error = std::abs(remapped.at<float>(v, u) - expected.at<float>(v, u));
      max_error = std::max(max_error, error);
      sum_error += error;
      ++count;
    }
  }
  REQUIRE(count > 0.9 * target.width() * target.height());
  WARN("model " << name << ": remap vs direct rendering, mean " << sum_error / count << ", max "
                << max_error << " grey levels over " << count << " pixels");
  CHECK(sum_error / count < 0.1);
  CHECK(max_error < 1.0);
}

TEST_CASE("Undistort a real EuRoC cam0 image", "[camera]") {
  const std::filesystem::path dir =
      std::filesystem::path(VILMA_SHARED_DATA_DIR) / "euroc_V1_01_micro/mav0/cam0/data";
  if (!std::filesystem::is_directory(dir)) {
    VILMA_SKIP("EuRoC slice not found at " << dir.string());
  }
  std::vector<std::filesystem::path> files;
  for (const auto& entry : std::filesystem::directory_iterator(dir)) {
    if (entry.path().extension() == ".png") files.push_back(entry.path());
  }
  REQUIRE_FALSE(files.empty());
  std::sort(files.begin(), files.end());
  const cv::Mat image = cv::imread(files.front().string(), cv::IMREAD_GRAYSCALE);
  REQUIRE_FALSE(image.empty());
  const Camera camera = EurocCam0();
  REQUIRE(image.cols == camera.width());
  REQUIRE(image.rows == camera.height());

  const Camera target = camera.UndistortedPinhole(0.0);
  cv::Mat map_x, map_y;
  camera.ComputeUndistortionMaps(target, &map_x, &map_y);
  cv::Mat undistorted;
  cv::remap(image, undistorted, map_x, map_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT, 0);
  REQUIRE(undistorted.size() == image.size());

  // alpha = 0 crops to valid pixels: no black border appears, intensities are preserved.
  const double mean_in = cv::mean(image)[0], mean_out = cv::mean(undistorted)[0];
  cv::Scalar mean, stddev;
  cv::meanStdDev(undistorted, mean, stddev);
  WARN("EuRoC " << files.front().filename().string() << ": mean intensity " << mean_in << " -> "
                << mean_out << ", stddev " << stddev[0]);
  CHECK(std::abs(mean_out - mean_in) < 0.1 * mean_in);
  CHECK(stddev[0] > 10.0);
  cv::Mat border_black;
  cv::compare(undistorted, 0, border_black, cv::CMP_EQ);
  const double black_in = cv::countNonZero(image == 0);
  CHECK(cv::countNonZero(border_black) <= black_in + 0.001 * image.total());

  // The same undistortion with OpenCV's maps gives the same picture.
  cv::Mat cv_map_x, cv_map_y, cv_undistorted;
  cv::initUndistortRectifyMap(ToCvK(camera), ToCvD(camera), cv::Mat(), ToCvK(target), image.size(),
                              CV_32FC1, cv_map_x, cv_map_y);
  cv::remap(image, cv_undistorted, cv_map_x, cv_map_y, cv::INTER_LINEAR, cv::BORDER_CONSTANT, 0);
  cv::Mat diff;
  cv::absdiff(undistorted, cv_undistorted, diff);
  double max_diff;
  cv::minMaxLoc(diff, nullptr, &max_diff);
  CHECK(max_diff <= 1.0);
  CHECK(cv::mean(diff)[0] < 0.01);

  if (const char* out = std::getenv("VILMA_CAMERA_TEST_OUTPUT")) {
    cv::imwrite(std::string(out) + "/euroc_cam0_undistorted.png", undistorted);
  }
}

}  // namespace
}  // namespace vilma
