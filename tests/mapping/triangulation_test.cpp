#include "vilma/mapping/triangulation.h"

#include <catch2/catch.hpp>
#include <cmath>
#include <random>

#include "test_random.h"

using namespace vilma;
using namespace vilma::mapping;

namespace {

Camera TestCamera() {
  return Camera(752, 480, Eigen::Vector4d(458.654, 457.296, 367.215, 248.375),
                DistortionModel::kRadTan,
                (Eigen::VectorXd(4) << -0.2834, 0.0740, 1.9e-4, 1.8e-5).finished());
}

// Camera looking from `c_M` at `target_M` (z axis towards it), with some roll.
Transformation LookAt(const Eigen::Vector3d& c_M, const Eigen::Vector3d& target_M, double roll) {
  const Eigen::Vector3d z = (target_M - c_M).normalized();
  Eigen::Vector3d x = z.cross(Eigen::Vector3d::UnitZ());
  if (x.norm() < 1e-6) x = Eigen::Vector3d::UnitX();
  x.normalize();
  const Eigen::Vector3d y = z.cross(x);
  Eigen::Matrix3d R;
  R << x, y, z;
  return Transformation(R * Eigen::AngleAxisd(roll, Eigen::Vector3d::UnitZ()).toRotationMatrix(),
                        c_M);
}

// Observations of p_M from cameras on a line segment of length `baseline` centred at c0,
// looking at p_M from slightly off, so that p_M is not at the image centre.
std::vector<TriangulationObservation> Observe(const Camera& camera, const Eigen::Vector3d& p_M,
                                              const Eigen::Vector3d& c0, double baseline, int n,
                                              double noise_px, std::mt19937* rng) {
  std::normal_distribution<double> noise(0.0, noise_px);
  std::vector<TriangulationObservation> obs;
  for (int k = 0; k < n; ++k) {
    const double s = n > 1 ? static_cast<double>(k) / (n - 1) - 0.5 : 0.0;
    const Eigen::Vector3d c = c0 + Eigen::Vector3d(baseline * s, 0.05 * s, 0.02 * k);
    const Eigen::Vector3d look = p_M + (p_M - c).norm() * Eigen::Vector3d(0.06 * s, -0.04, 0.02);
    TriangulationObservation o;
    o.T_M_C = LookAt(c, look, 0.1 * k);
    o.camera = &camera;
    REQUIRE(camera.Project(o.T_M_C.inverse() * p_M, &o.uv) == Camera::ProjectionResult::kValid);
    if (noise_px > 0) o.uv += vilma::testing::DrawVector2([&] { return noise(*rng); });
    obs.push_back(o);
  }
  return obs;
}

}  // namespace

TEST_CASE("triangulation: exact bearings give the point", "[mapping]") {
  const Camera camera = TestCamera();
  std::mt19937 rng(3);
  const Eigen::Vector3d p_M =
      GENERATE(Eigen::Vector3d(1.0, 4.0, 0.5), Eigen::Vector3d(-2.0, 8.0, 1.5),
               Eigen::Vector3d(0.1, 1.0, -0.2));
  for (int n : {2, 3, 8}) {
    const auto obs = Observe(camera, p_M, Eigen::Vector3d::Zero(), 0.5, n, 0.0, &rng);
    const TriangulationResult linear = TriangulateLinear(obs);
    REQUIRE(linear.ok());
    CHECK((linear.p_M - p_M).norm() < 1e-6);
    const TriangulationResult refined = Triangulate(obs, TriangulationOptions());
    REQUIRE(refined.ok());
    CHECK((refined.p_M - p_M).norm() < 1e-9);
    CHECK(refined.rms_reprojection_error_px < 1e-6);
  }
}

TEST_CASE("triangulation: pixel noise gives a bounded error that the covariance predicts",
          "[mapping]") {
  const Camera camera = TestCamera();
  std::mt19937 rng(7);
  const Eigen::Vector3d p_M(0.5, 4.0, 0.3);
  const int trials = 200;
  double sum_mahalanobis = 0.0;
  double max_error = 0.0;
  double sum_error_linear = 0.0;
  double sum_error_refined = 0.0;
  for (int t = 0; t < trials; ++t) {
    const auto obs = Observe(camera, p_M, Eigen::Vector3d::Zero(), 0.8, 6, 1.0, &rng);
    const TriangulationResult linear = TriangulateLinear(obs);
    const TriangulationResult r = Triangulate(obs, TriangulationOptions());
    REQUIRE(r.ok());
    const Eigen::Vector3d e = r.p_M - p_M;
    sum_mahalanobis += e.dot(r.covariance_M.inverse() * e);
    max_error = std::max(max_error, e.norm());
    sum_error_linear += (linear.p_M - p_M).norm();
    sum_error_refined += e.norm();
  }
  // Depth 4 m, baseline 0.8 m, 1 px noise at f = 458 px: depth sigma ~ 4^2 / (0.8 * 458) / ..
  // ~ 2-4 cm; the error stays well below 20 cm.
  CHECK(max_error < 0.2);
  // E[e^T C^-1 e] = 3 for a correct covariance (chi-square, 3 dof); 200 trials: +-0.3.
  CHECK(sum_mahalanobis / trials > 2.4);
  CHECK(sum_mahalanobis / trials < 3.6);
  // Both are unbiased-ish estimators of the same point: the mean errors are alike.
  CHECK(sum_error_refined < 1.5 * sum_error_linear);
  CHECK(sum_error_linear < 1.5 * sum_error_refined);
}

TEST_CASE("triangulation: per-observation sigmas weight the residuals and the covariance",
          "[mapping]") {
  const Camera camera = TestCamera();
  std::mt19937 rng(11);
  const Eigen::Vector3d p_M(0.5, 5.0, 1.0);
  std::vector<TriangulationObservation> obs =
      Observe(camera, p_M, Eigen::Vector3d::Zero(), 1.5, 8, 0.2, &rng);
  TriangulationOptions options;  // keypoint_sigma_px 1: the noise of observations without one
  const TriangulationResult unweighted = Triangulate(obs, options);
  REQUIRE(unweighted.ok());
  // Equal sigmas: the same point, the covariance scaled by sigma^2, the RMS error in pixels.
  for (TriangulationObservation& o : obs) o.sigma_px = 0.5;
  const TriangulationResult equal = Triangulate(obs, options);
  REQUIRE(equal.ok());
  CHECK((equal.p_M - unweighted.p_M).norm() < 1e-9);
  CHECK((equal.covariance_M - 0.25 * unweighted.covariance_M).norm() <
        1e-9 * unweighted.covariance_M.norm());
  CHECK(equal.rms_reprojection_error_px == Approx(unweighted.rms_reprojection_error_px));
  // One keypoint 3 px off: with its sigma at 3 px it pulls the point much less.
  obs[2].uv += Eigen::Vector2d(3.0, -2.0);
  for (TriangulationObservation& o : obs) o.sigma_px = 0.0;
  const TriangulationResult pulled = Triangulate(obs, options);
  obs[2].sigma_px = 3.0;
  const TriangulationResult weighted = Triangulate(obs, options);
  REQUIRE(pulled.ok());
  REQUIRE(weighted.ok());
  INFO("error unweighted " << (pulled.p_M - p_M).norm() << " m, weighted "
                           << (weighted.p_M - p_M).norm() << " m");
  CHECK((weighted.p_M - p_M).norm() < 0.5 * (pulled.p_M - p_M).norm());
}

TEST_CASE("triangulation: degenerate and behind-camera cases are reported", "[mapping]") {
  const Camera camera = TestCamera();
  std::mt19937 rng(1);
  // One observation only.
  auto obs = Observe(camera, Eigen::Vector3d(0, 3, 0), Eigen::Vector3d::Zero(), 0.5, 1, 0, &rng);
  CHECK(Triangulate(obs, TriangulationOptions()).status ==
        TriangulationStatus::kTooFewObservations);
  // One ray three times (the same camera pose and keypoint): no parallax.
  obs = Observe(camera, Eigen::Vector3d(0, 3, 0), Eigen::Vector3d::Zero(), 0.5, 3, 0, &rng);
  obs = {obs[0], obs[0], obs[0]};
  CHECK(TriangulateLinear(obs).status == TriangulationStatus::kDegenerate);
  // Rays that meet behind the cameras: mirror the cameras through the point.
  obs = Observe(camera, Eigen::Vector3d(0, 3, 0), Eigen::Vector3d::Zero(), 0.5, 3, 0, &rng);
  for (auto& o : obs) {
    // Move each camera along its ray beyond the point: the point is now behind it.
    const Eigen::Vector3d c = o.T_M_C.translation();
    o.T_M_C = Transformation(o.T_M_C.rotation(), c + 2.0 * (Eigen::Vector3d(0, 3, 0) - c));
  }
  CHECK(TriangulateLinear(obs).status == TriangulationStatus::kBehindCamera);
}

TEST_CASE("landmark quality: each elq rule rejects its case", "[mapping]") {
  const Camera camera = TestCamera();
  std::mt19937 rng(5);
  const LandmarkQualityOptions q;  // 4 observers, 5 deg, 0.05..40 m, 3 px
  auto verdict = [&](const std::vector<TriangulationObservation>& obs) {
    return EvaluateLandmarkQuality(obs, Triangulate(obs, TriangulationOptions()), q);
  };
  // Good: 4 m away, 1 m baseline (14 deg), 6 observers.
  CHECK(verdict(Observe(camera, {0, 4, 0}, Eigen::Vector3d::Zero(), 1.0, 6, 0.3, &rng)) ==
        LandmarkVerdict::kGood);
  // Too few observers.
  CHECK(verdict(Observe(camera, {0, 4, 0}, Eigen::Vector3d::Zero(), 1.0, 3, 0.0, &rng)) ==
        LandmarkVerdict::kTooFewObservers);
  // Too close: 3 cm in front of the cameras (baseline 5 cm keeps the angle large).
  CHECK(verdict(Observe(camera, {0, 0.03, 0}, Eigen::Vector3d::Zero(), 0.05, 5, 0.0, &rng)) ==
        LandmarkVerdict::kTooClose);
  // Too far: 60 m with a 12 m baseline (11 deg).
  CHECK(verdict(Observe(camera, {0, 60, 0}, Eigen::Vector3d::Zero(), 12.0, 5, 0.0, &rng)) ==
        LandmarkVerdict::kTooFar);
  // Small angle: 5 m with a 0.2 m baseline (2.3 deg).
  CHECK(verdict(Observe(camera, {0, 5, 0}, Eigen::Vector3d::Zero(), 0.2, 5, 0.0, &rng)) ==
        LandmarkVerdict::kSmallAngle);
  // Large reprojection error: one observation off by 25 px.
  auto obs = Observe(camera, {0, 4, 0}, Eigen::Vector3d::Zero(), 1.0, 5, 0.0, &rng);
  obs[2].uv += Eigen::Vector2d(25.0, -10.0);
  CHECK(verdict(obs) == LandmarkVerdict::kLargeReprojectionError);
  // Failed triangulation.
  for (auto& o : obs) o.T_M_C = Transformation(o.T_M_C.rotation(), Eigen::Vector3d::Zero());
  CHECK(verdict(obs) == LandmarkVerdict::kTriangulationFailed);
  // The angle helper: two rays at right angles.
  std::vector<TriangulationObservation> two(2);
  two[0].T_M_C = Transformation(Eigen::Quaterniond::Identity(), Eigen::Vector3d(1, 0, 0));
  two[1].T_M_C = Transformation(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 1, 0));
  CHECK(MaxObservationAngle(two, Eigen::Vector3d::Zero()) == Approx(M_PI / 2));
}
