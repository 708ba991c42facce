#include "vilma/localizer/pose_ransac.h"

#include <Eigen/Eigenvalues>
#include <catch2/catch.hpp>
#include <cmath>
#include <random>

#include "test_cameras.h"
#include "test_random.h"

using namespace vilma;
using namespace vilma::localizer;

namespace {

using test::EurocCamera;

// n points in front of the camera at T_G_C, keypoints with Gaussian pixel noise; the first
// round(outlier_ratio * n) matches get a random wrong 3D point.
void MakeMatches(const Camera& cam, const Transformation& T_G_C, int n, double outlier_ratio,
                 double noise_px, uint64_t seed, std::vector<Eigen::Vector2d>* uv,
                 std::vector<Eigen::Vector3d>* p_G) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> g(0.0, noise_px);
  const int outliers = static_cast<int>(std::lround(outlier_ratio * n));
  while (static_cast<int>(uv->size()) < n) {
    const double y = u(rng) * cam.height();  // y before x, as GCC drew them
    const double x = u(rng) * cam.width();   // (tests/test_random.h)
    const Eigen::Vector2d px(x, y);
    Eigen::Vector3d f;
    if (!cam.Unproject(px, &f)) continue;
    const Eigen::Vector3d p_C = f / f.z() * (1.0 + 7.0 * u(rng));
    Eigen::Vector2d k;
    if (cam.Project(p_C, &k) != Camera::ProjectionResult::kValid) continue;
    const bool outlier = static_cast<int>(uv->size()) < outliers;
    Eigen::Vector3d p_C_used = p_C;
    if (outlier) {  // a random point, drawn z, y, x
      const double p_z = 1 + 7 * u(rng);
      const double p_y = 3 * u(rng) - 1.5;
      const double p_x = 4 * u(rng) - 2;
      p_C_used = Eigen::Vector3d(p_x, p_y, p_z);
    }
    uv->push_back(k + vilma::testing::DrawVector2([&] { return g(rng); }));
    p_G->push_back(T_G_C * p_C_used);
  }
}

}  // namespace

TEST_CASE("pose ransac: P3P RANSAC recovers the pose with 50% outliers", "[localization]") {
  const Camera cam = EurocCamera();
  const Transformation T_G_C(
      ExpSO3(Eigen::Vector3d(0.3, -1.2, 0.5)), Eigen::Vector3d(2.0, -1.0, 1.5));
  std::vector<Eigen::Vector2d> uv;
  std::vector<Eigen::Vector3d> p_G;
  MakeMatches(cam, T_G_C, 200, 0.5, 0.5, 1, &uv, &p_G);
  PoseRansacOptions o;
  const PoseResult r = EstimateCameraPose(cam, uv, p_G, o);
  REQUIRE(r.status == PoseStatus::kOk);
  const double e_p = (r.T_G_C.translation() - T_G_C.translation()).norm();
  const double e_r = AngleBetween(r.T_G_C.rotation(), T_G_C.rotation()) * 180.0 / M_PI;
  INFO("position error " << e_p << " m, rotation error " << e_r << " deg, iterations "
                         << r.ransac_iterations);
  CHECK(e_p < 0.01);
  CHECK(e_r < 0.1);
  // The inliers are (nearly) exactly the true matches 100..199.
  int true_inliers = 0;
  for (int i : r.inliers) true_inliers += i >= 100;
  CHECK(true_inliers >= 95);
  CHECK(static_cast<int>(r.inliers.size()) - true_inliers <= 2);
  CHECK(r.rms_reprojection_px < 1.0);
  // Covariance: symmetric positive definite, and the true error is plausible under it.
  CHECK((r.covariance_C - r.covariance_C.transpose()).norm() < 1e-12);
  CHECK(Eigen::SelfAdjointEigenSolver<Matrix6d>(r.covariance_C).eigenvalues().minCoeff() > 0);
  const Vector6d xi = (T_G_C.inverse() * r.T_G_C).Log();
  CHECK(xi.dot(r.covariance_C.inverse() * xi) < 30.0);  // chi2(6) 99.99% ~ 27.9
}

TEST_CASE("pose ransac: rejection reasons", "[localization]") {
  const Camera cam = EurocCamera();
  const Transformation T_G_C;
  PoseRansacOptions o;
  {
    std::vector<Eigen::Vector2d> uv;
    std::vector<Eigen::Vector3d> p_G;
    MakeMatches(cam, T_G_C, 8, 0.0, 0.0, 2, &uv, &p_G);
    CHECK(EstimateCameraPose(cam, uv, p_G, o).status == PoseStatus::kTooFewMatches);
  }
  {
    // All outliers: no consistent pose with 10 inliers.
    std::vector<Eigen::Vector2d> uv;
    std::vector<Eigen::Vector3d> p_G;
    MakeMatches(cam, T_G_C, 60, 1.0, 0.0, 3, &uv, &p_G);
    const PoseStatus s = EstimateCameraPose(cam, uv, p_G, o).status;
    CHECK((s == PoseStatus::kTooFewInliers || s == PoseStatus::kRansacFailed));
  }
  o.min_inliers = 3;
  CHECK(!o.Validate().empty());
  o = PoseRansacOptions();
  o.threshold_px = 0;
  CHECK(!o.Validate().empty());
}
