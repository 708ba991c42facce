// The reprojection residual's robust loss (ReprojectionLoss, reprojection_residual.h) acts on
// the whitened residual: at k sigma of each observation's own keypoint noise, whatever that
// sigma is, or at a fixed pixel error when a pixel scale is given.
#include <catch2/catch.hpp>

#include <cmath>
#include <memory>
#include <vector>

#include "mapstore/synthetic_map.h"
#include "vilma/core/geometry.h"
#include "vilma/mapping/optimization/pose_manifold.h"
#include "vilma/mapping/optimization/reprojection_residual.h"

namespace vilma::mapping {
namespace {

// rho'(s) of `loss` for an observation whose keypoint lies `error_px` pixels (along u) from the
// landmark's projection, whitened by sigma_px (ReprojectionCostFunction): 1 where the loss is
// still quadratic; Huber b / sqrt(s) beyond its corner b^2, Cauchy 1 / (1 + s / b^2).
double LossSlopeAt(const ceres::LossFunction& loss, double error_px, double sigma_px) {
  const SensorRig rig = mapstore::testing::TestRig();
  const Camera& camera = rig.cameras[0].camera;
  std::vector<double> I(7, 0.0);
  I[6] = 1.0;  // identity pose [p, q (x y z w)]: the camera at G's origin looking along +z
  const Eigen::Vector3d p_C(0.3, -0.2, 4.0);
  Eigen::Vector2d uv;
  REQUIRE(camera.Project(p_C, &uv) == Camera::ProjectionResult::kValid);
  const ReprojectionCostFunction cost(&camera, uv - Eigen::Vector2d(error_px, 0.0), sigma_px);
  const double* params[4] = {I.data(), p_C.data(), I.data(), I.data()};
  double r[2];
  REQUIRE(cost.Evaluate(params, r, nullptr));
  CHECK(r[0] == Approx(error_px / sigma_px).epsilon(1e-9));  // whitened by sigma
  const double s = r[0] * r[0] + r[1] * r[1];
  double rho[3];
  loss.Evaluate(s, rho);
  return rho[1];
}

TEST_CASE("Reprojection robust loss acts at k sigma of each observation's own keypoint noise") {
  const double k = 3.0;
  // A detector keypoint (1 px) and a refined one (0.15 px, the map builder's track refinement).
  for (const double sigma_px : {1.0, 0.15}) {
    INFO("sigma " << sigma_px << " px");
    const std::unique_ptr<ceres::LossFunction> huber = ReprojectionLoss("huber", k, 0.0, sigma_px);
    REQUIRE(huber);
    // Quadratic up to k sigma, then rho' = k sigma / |e|: the corner at k * sigma_px pixels.
    CHECK(LossSlopeAt(*huber, 0.99 * k * sigma_px, sigma_px) == Approx(1.0).epsilon(1e-12));
    CHECK(LossSlopeAt(*huber, 1.01 * k * sigma_px, sigma_px) == Approx(1.0 / 1.01).epsilon(1e-6));
    CHECK(LossSlopeAt(*huber, 2.0 * k * sigma_px, sigma_px) == Approx(0.5).epsilon(1e-6));
    const std::unique_ptr<ceres::LossFunction> cauchy =
        ReprojectionLoss("cauchy", k, 0.0, sigma_px);
    REQUIRE(cauchy);
    // Cauchy's weight halves at s = b^2: an error of k sigma.
    CHECK(LossSlopeAt(*cauchy, k * sigma_px, sigma_px) == Approx(0.5).epsilon(1e-6));
    CHECK(LossSlopeAt(*cauchy, 0.5 * k * sigma_px, sigma_px) == Approx(0.8).epsilon(1e-6));
  }
}

TEST_CASE("Reprojection robust loss at a pixel scale acts at the same pixel error for any sigma") {
  for (const double sigma_px : {1.0, 0.15}) {
    INFO("sigma " << sigma_px << " px");
    // scale_px > 0 wins over scale_sigma: Huber's corner at 0.45 px for both keypoints.
    const std::unique_ptr<ceres::LossFunction> huber =
        ReprojectionLoss("huber", 3.0, 0.45, sigma_px);
    CHECK(LossSlopeAt(*huber, 0.99 * 0.45, sigma_px) == Approx(1.0).epsilon(1e-12));
    CHECK(LossSlopeAt(*huber, 1.01 * 0.45, sigma_px) == Approx(1.0 / 1.01).epsilon(1e-6));
    const std::unique_ptr<ceres::LossFunction> cauchy =
        ReprojectionLoss("cauchy", 3.0, 0.45, sigma_px);
    CHECK(LossSlopeAt(*cauchy, 0.45, sigma_px) == Approx(0.5).epsilon(1e-6));
  }
  // For 1 px keypoints, k sigma and k pixels are the same loss.
  const auto by_sigma = ReprojectionLoss("huber", 3.0, 0.0, 1.0);
  const auto by_px = ReprojectionLoss("huber", 99.0, 3.0, 1.0);
  for (const double e : {0.5, 2.9, 3.1, 10.0}) {
    CHECK(LossSlopeAt(*by_sigma, e, 1.0) == LossSlopeAt(*by_px, e, 1.0));
  }
}

TEST_CASE("Reprojection robust loss: none, and bad arguments are errors") {
  CHECK(ReprojectionLoss("none", 3.0, 0.0, 0.15) == nullptr);
  CHECK_THROWS_AS(ReprojectionLoss("tukey", 3.0, 0.0, 1.0), std::invalid_argument);
  CHECK_THROWS_AS(ReprojectionLoss("huber", 0.0, 0.0, 1.0), std::invalid_argument);
  CHECK_THROWS_AS(ReprojectionLoss("huber", 3.0, -1.0, 1.0), std::invalid_argument);
  CHECK_THROWS_AS(ReprojectionLoss("huber", 3.0, 0.0, 0.0), std::invalid_argument);
  CHECK_THROWS_AS(ReprojectionLoss("huber", 3.0, 0.0, std::nan("")), std::invalid_argument);
}

}  // namespace
}  // namespace vilma::mapping
