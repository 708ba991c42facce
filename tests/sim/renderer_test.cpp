#include "vilma/sim/renderer.h"

#include <catch2/catch.hpp>
#include <chrono>
#include <cmath>
#include <iostream>
#include <opencv2/imgproc.hpp>

#include <Eigen/Dense>

#include "vilma/core/geometry.h"
#include "vilma/sim/simulator.h"

using Eigen::Vector2d;
using Eigen::Vector3d;
using vilma::Transformation;
using vilma::sim::RenderOptions;
using vilma::sim::Renderer;
using vilma::sim::World;

namespace {

// Sub-pixel X-junction (checker corner) by saddle-point fitting. A blurred X-junction is
// point-symmetric about the corner, so its gradient vanishes there. The window is resampled
// (bilinear) centred on the current estimate so that higher-order terms do not bias the fit.
inline bool FindSaddle(const cv::Mat& image8, Eigen::Vector2d* corner, double sigma = 1.5,
                       int half = 4) {
  cv::Mat f;
  image8.convertTo(f, CV_32F);
  cv::GaussianBlur(f, f, cv::Size(0, 0), sigma);
  Eigen::Vector2d c = *corner;
  const int n = 2 * half + 1;
  Eigen::MatrixXd A(n * n, 6);
  for (int dy = -half, r = 0; dy <= half; ++dy)
    for (int dx = -half; dx <= half; ++dx, ++r) A.row(r) << dx * dx, dx * dy, dy * dy, dx, dy, 1.0;
  const auto qr = A.colPivHouseholderQr();
  for (int it = 0; it < 50; ++it) {
    cv::Mat patch;
    cv::getRectSubPix(f, cv::Size(n, n), cv::Point2f(static_cast<float>(c.x()), static_cast<float>(c.y())), patch, CV_32F);
    Eigen::VectorXd b(n * n);
    for (int dy = 0, r = 0; dy < n; ++dy)
      for (int dx = 0; dx < n; ++dx, ++r) b[r] = patch.at<float>(dy, dx);
    const Eigen::VectorXd p = qr.solve(b);
    Eigen::Matrix2d H;
    H << 2 * p[0], p[1], p[1], 2 * p[2];
    if (H.determinant() >= 0.0) return false;  // not a saddle
    Eigen::Vector2d step = H.inverse() * -Eigen::Vector2d(p[3], p[4]);
    if (step.norm() > 1.0) step *= 1.0 / step.norm();
    c += step;
    if (step.norm() < 1e-5) break;
  }
  *corner = c;
  return true;
}

// A 0.4 m checker marker (inner corner at its centre) at `depth` on the ray through
// `keypoint` of `camera` at T_W_C, rotated in its plane and tilted a little.
World MarkerWorld(const vilma::Camera& camera, const Transformation& T_W_C,
                  const Vector2d& keypoint, double depth, double spin, Vector3d* corner_W) {
  Vector3d bearing;
  REQUIRE(camera.Unproject(keypoint, &bearing));
  const Vector3d p_C = bearing / bearing.z() * depth;
  // Marker axes in C: facing the camera (normal -z), spun and tilted.
  const Eigen::Matrix3d R = (Eigen::AngleAxisd(0.3, Vector3d(1, 1, 0).normalized()) *
                             Eigen::AngleAxisd(spin, Vector3d::UnitZ()))
                                .toRotationMatrix();
  const Vector3d u_C = R.col(0) * 0.4, v_C = R.col(1) * -0.4;  // u x v = -z' (towards camera)
  const Vector3d origin_C = p_C - 0.5 * (u_C + v_C);
  World w;
  const Eigen::Matrix3d R_W_C = T_W_C.rotationMatrix();
  w.AddQuad(T_W_C * origin_C, R_W_C * u_C, R_W_C * v_C, 0.4 / 512, 1, 128.0, 1.0, true,
            vilma::sim::TextureKind::kChecker);
  w.background_intensity = 128.0;
  w.motion.free_space = Eigen::AlignedBox3d(Vector3d(-1, -1, -1), Vector3d(1, 1, 1));
  w.GenerateTextures();
  *corner_W = T_W_C * p_C;
  return w;
}

}  // namespace

TEST_CASE("rendered marker corners land where the rig model projects them", "[sim][renderer]") {
  const vilma::SensorRig rig = vilma::sim::MakeEurocRig(true);
  REQUIRE(rig.cameras.size() == 2);
  // Stereo baseline of the EuRoC VI-sensor: ~11 cm.
  const double baseline =
      (rig.cameras[0].T_I_C.translation() - rig.cameras[1].T_I_C.translation()).norm();
  CHECK(baseline == Approx(0.11).margin(0.005));
  const Transformation T_W_I(vilma::ExpSO3(Vector3d(0.3, -0.2, 1.0)), Vector3d(0.5, -1.0, 1.2));
  RenderOptions options;
  options.noise_sigma = 0.0;
  double worst = 0.0, sum = 0.0;
  int count = 0;
  for (int cam = 0; cam < 2; ++cam) {
    const vilma::Camera& camera = rig.cameras[cam].camera;
    const Transformation T_W_C = T_W_I * rig.cameras[cam].T_I_C;
    const std::vector<Vector2d> targets = {{376, 240}, {150.3, 100.7}, {620.6, 390.2},
                                           {80.2, 420.9}, {690.8, 60.4}, {400.5, 60.1}};
    for (size_t k = 0; k < targets.size(); ++k) {
      Vector3d corner_W;
      const World world = MarkerWorld(camera, T_W_C, targets[k], 1.2 + 0.3 * k, 0.3 * k, &corner_W);
      Renderer renderer(world, camera, options);
      cv::Mat image;
      renderer.Render({T_W_C}, 1, &image);
      // The rig model: p_C = T_C_I T_I_W p_W, projected with distortion.
      const Vector3d p_C = T_W_C.inverse() * corner_W;
      Vector2d expected;
      REQUIRE(camera.Project(p_C, &expected) == vilma::Camera::ProjectionResult::kValid);
      // Detect from a guess 1.5 px off. (cv::cornerSubPix is biased by ~0.05 px on such
      // corners; the centred saddle fit is not.)
      Eigen::Vector2d found = expected + Vector2d(1.5, -1.2);
      REQUIRE(FindSaddle(image, &found));
      const double err = (found - expected).norm();
      INFO("camera " << cam << " target " << targets[k].transpose() << " error " << err);
      CHECK(err < 0.1);
      worst = std::max(worst, err);
      sum += err;
      ++count;
    }
  }
  CHECK(sum / count < 0.05);
  std::cout << "[sim renderer] marker corner reprojection error: mean " << sum / count
            << " px, max " << worst << " px over " << count << " corners (cam0 + cam1)\n";
}

TEST_CASE("renders are deterministic, noise follows the seed", "[sim][renderer]") {
  World world = vilma::sim::MakePresetWorld("room", 1);
  world.GenerateTextures();
  const vilma::SensorRig rig = vilma::sim::MakeEurocRig(false);
  Renderer renderer(world, rig.cameras[0].camera, RenderOptions());
  const Transformation T_W_I(Eigen::Quaterniond(vilma::sim::Trajectory::R_L_I()), Vector3d(0, 0, 1.5));
  const Transformation T_W_C = T_W_I * rig.cameras[0].T_I_C;
  cv::Mat a, b, c;
  renderer.Render({T_W_C}, 5, &a);
  renderer.Render({T_W_C}, 5, &b);
  renderer.Render({T_W_C}, 6, &c);
  CHECK(cv::norm(a, b, cv::NORM_INF) == 0.0);
  CHECK(cv::norm(a, c, cv::NORM_INF) > 0.0);
  // Noise sigma 2: the difference of two noise draws has sigma 2 sqrt(2) (minus clipping and
  // rounding effects).
  cv::Mat diff;
  cv::subtract(a, c, diff, cv::noArray(), CV_32F);
  cv::Scalar mean, sd;
  cv::meanStdDev(diff, mean, sd);
  CHECK(sd[0] == Approx(2.0 * std::sqrt(2.0)).epsilon(0.1));
  // A textured indoor view: contrast everywhere, no background visible inside the room.
  cv::meanStdDev(a, mean, sd);
  CHECK(sd[0] > 20.0);
  CHECK(cv::countNonZero(a < 3) < static_cast<int>(a.total() / 200));
}

TEST_CASE("render speed", "[sim][renderer][.benchmark]") {
  vilma::sim::SimOptions o;
  o.world = "room";
  o.seconds = 12.0;
  vilma::sim::Simulator sim(o);
  cv::Mat image;
  const auto t0 = std::chrono::steady_clock::now();
  const int n = sim.num_frames();
  for (int i = 0; i < n; ++i) sim.RenderFrame(0, i, &image);
  const double s = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  std::cout << "[sim renderer] " << n / s << " frames/s (752x480, one core, room)\n";
}
