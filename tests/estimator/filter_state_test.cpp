#include "vilma/estimator/filter_state.h"

#include <catch2/catch.hpp>
#include <random>

#include "core/test_utils.h"
#include "test_random.h"
#include "vilma/core/camera.h"
#include "vilma/core/geometry.h"

namespace vilma::estimator {
namespace {

TEST_CASE("bearing boxplus and boxminus are inverse and the basis is orthonormal") {
  std::mt19937 rng(3);
  std::normal_distribution<double> n(0.0, 1.0);
  for (int trial = 0; trial < 50; ++trial) {
    // z, y, x: the order GCC drew them in (tests/test_random.h).
    const double z = 1.5 + n(rng) * 0.3;
    const double y = n(rng);
    const double x = n(rng);
    const Eigen::Vector3d mu = Eigen::Vector3d(x, y, z).normalized();
    const Eigen::Matrix<double, 3, 2> B = BearingBasis(mu);
    CHECK((B.transpose() * B - Eigen::Matrix2d::Identity()).norm() < 1e-12);
    CHECK((B.transpose() * mu).norm() < 1e-12);
    const Eigen::Vector2d d = vilma::testing::DrawVector2([&] { return 0.3 * n(rng); });
    const Eigen::Vector3d mu1 = BearingBoxPlus(mu, d);
    CHECK(std::abs(mu1.norm() - 1.0) < 1e-12);
    CHECK(std::abs(std::acos(std::min(1.0, mu1.dot(mu))) - d.norm()) < 1e-9);
    CHECK((BearingBoxMinus(mu1, mu) - d).norm() < 1e-9);
  }
}

TEST_CASE("pixel Jacobian of a bearing in tangent coordinates matches central differences") {
  // The update's d pixel / d dmu = J_project(mu) B(mu) relies on mu (+) d = mu + B d + O(d^2).
  Eigen::VectorXd radtan(4);
  radtan << -0.28, 0.07, 2e-4, 2e-5;
  const Camera camera(752, 480, Eigen::Vector4d(458.6, 457.3, 367.2, 248.4),
                      DistortionModel::kRadTan, radtan);
  std::mt19937 rng(5);
  std::normal_distribution<double> n(0.0, 0.3);
  for (int trial = 0; trial < 20; ++trial) {
    const double y = 0.6 * n(rng);  // y before x, as GCC drew them (tests/test_random.h)
    const double x = n(rng);
    const Eigen::Vector3d mu = Eigen::Vector3d(x, y, 1.0).normalized();
    Eigen::Vector2d pixel;
    Eigen::Matrix<double, 2, 3> Jp;
    camera.Project(mu, &pixel, &Jp);
    const Eigen::Matrix2d analytic = Jp * BearingBasis(mu);
    const Eigen::Matrix2d numeric = test::NumericJacobian<2, 2>(
        [&](const Eigen::Vector2d& d) -> Eigen::Vector2d {
          Eigen::Vector2d p;
          camera.Project(BearingBoxPlus(mu, d), &p);
          return p;
        },
        Eigen::Vector2d::Zero(), 1e-7);
    VILMA_CHECK_MATRIX_NEAR(analytic, numeric, 1e-5);
  }
}

TEST_CASE("state boxplus and boxminus are inverse") {
  FilterState x;
  x.q_M_I = ExpSO3(Eigen::Vector3d(0.3, -0.2, 1.0));
  x.q_I_C = ExpSO3(Eigen::Vector3d(-1.5, 0.1, 0.2));
  x.features.resize(3);
  x.features[0].active = true;
  x.features[0].mu_C = Eigen::Vector3d(0.2, 0.1, 1.0).normalized();
  x.features[2].active = true;
  x.features[2].mu_C = Eigen::Vector3d(-0.4, 0.3, 1.0).normalized();
  std::mt19937 rng(1);
  std::normal_distribution<double> n(0.0, 0.2);
  Eigen::VectorXd dx(x.dim());
  for (Eigen::Index i = 0; i < dx.size(); ++i) dx[i] = n(rng);
  dx.segment<3>(FeatureIndex(1)).setZero();  // inactive slot: boxminus gives zeros
  FilterState y;
  BoxPlus(x, dx, &y);
  VILMA_CHECK_MATRIX_NEAR(BoxMinus(y, x), dx, 1e-9);
  CHECK(x.num_active() == 2);
}

TEST_CASE("MedianInverseDepth takes the median over the features with a known depth") {
  FilterState x;
  x.features.resize(6);
  Eigen::MatrixXd P = Eigen::MatrixXd::Zero(x.dim(), x.dim());
  // (rho, sigma_rho, active): ratios 0.1, 0.2, 0.25, 1.0 (unknown), 0.1 (inactive), 0.1.
  const double rho[6] = {0.10, 0.05, 0.20, 0.5, 0.3, 0.08};
  const double sigma[6] = {0.01, 0.01, 0.05, 0.5, 0.03, 0.008};
  const bool active[6] = {true, true, true, true, false, true};
  for (int i = 0; i < 6; ++i) {
    x.features[static_cast<std::size_t>(i)].active = active[i];
    x.features[static_cast<std::size_t>(i)].rho = rho[i];
    P(FeatureIndex(i) + 2, FeatureIndex(i) + 2) = sigma[i] * sigma[i];
  }
  double median = -1.0;
  // Known at ratio 0.3: 0.10, 0.05, 0.20, 0.08 -> the upper median 0.10.
  REQUIRE(MedianInverseDepth(x, P, 0.3, 3, &median));
  CHECK(median == 0.10);
  // At ratio 0.15 only 0.10 and 0.08 (0.05 has 0.2, 0.20 has 0.25): two, fewer than three.
  median = -1.0;
  CHECK_FALSE(MedianInverseDepth(x, P, 0.15, 3, &median));
  CHECK(median == -1.0);  // untouched
  REQUIRE(MedianInverseDepth(x, P, 0.15, 2, &median));
  CHECK(median == 0.10);
  // The unknown feature counts once the ratio admits it (1.0): 0.05 0.08 0.10 0.20 0.5.
  REQUIRE(MedianInverseDepth(x, P, 1.0, 3, &median));
  CHECK(median == 0.10);
  // A feature at infinity (rho = 0) has no depth to offer, whatever its sigma.
  x.features[0].rho = 0.0;
  REQUIRE(MedianInverseDepth(x, P, 0.3, 3, &median));
  CHECK(median == 0.08);  // 0.05 0.08 0.20 -> 0.08
}

}  // namespace
}  // namespace vilma::estimator
