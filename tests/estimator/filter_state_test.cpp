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

}  // namespace
}  // namespace vilma::estimator
