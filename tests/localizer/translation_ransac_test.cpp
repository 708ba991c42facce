#include "vilma/localizer/translation_ransac.h"

#include <Eigen/Geometry>
#include <catch2/catch.hpp>
#include <random>

#include "test_random.h"
#include "vilma/core/geometry.h"

namespace vilma::localizer {
namespace {

struct Correspondences {
  std::vector<Eigen::Vector3d> a;    // R_Ck_Ckm1 f_p
  std::vector<Eigen::Vector3d> f_c;
  std::vector<char> is_outlier;
};

// Points 2..10 m in front of the previous camera, seen from a camera moved by t (p_Ck_Ckm1)
// and rotated by R; `outlier_fraction` of the current bearings are replaced by random ones
// 3..30 deg away from the true one. Bearing noise: `noise` [rad] per axis.
Correspondences Make(const Eigen::Matrix3d& R, const Eigen::Vector3d& t, int n,
                     double outlier_fraction, double noise, uint32_t seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  std::normal_distribution<double> gauss(0.0, noise);
  Correspondences c;
  for (int i = 0; i < n; ++i) {
    // z, y, x: the order GCC drew them in (tests/test_random.h).
    const double z = 6.0 + 4.0 * uni(rng);
    const double y = 2.0 * uni(rng);
    const double x = 3.0 * uni(rng);
    const Eigen::Vector3d p_prev(x, y, z);
    const Eigen::Vector3d p_cur = R * p_prev + t;
    Eigen::Vector3d f = p_cur.normalized();
    const Eigen::Vector3d a = (R * p_prev).normalized();
    const bool outlier = i < static_cast<int>(outlier_fraction * n);
    if (outlier) {
      Eigen::Vector3d axis = vilma::testing::DrawVector3([&] { return uni(rng); });
      axis = axis.cross(f).normalized();
      const double angle = (3.0 + 27.0 * (0.5 + 0.5 * uni(rng))) * M_PI / 180.0;
      f = Eigen::AngleAxisd(angle, axis) * f;
    } else if (noise > 0.0) {
      f = (f + vilma::testing::DrawVector3([&] { return gauss(rng); })).normalized();
    }
    c.a.push_back(a);
    c.f_c.push_back(f);
    c.is_outlier.push_back(outlier ? 1 : 0);
  }
  return c;
}

TEST_CASE("2-point RANSAC finds the translation direction and the outliers", "[features]") {
  const uint32_t seed = GENERATE(1u, 2u, 3u);
  const Eigen::Matrix3d R = ExpSO3(Eigen::Vector3d(0.02, -0.05, 0.01)).toRotationMatrix();
  const Eigen::Vector3d t = Eigen::Vector3d(0.3, -0.05, 0.1);
  const Correspondences c = Make(R, t, 200, 0.3, 0.3 / 458.0, seed);
  RansacOptions o;
  const double threshold = 2.0 / 458.0;
  const TranslationRansacResult r = RansacTranslationKnownRotation(c.a, c.f_c, threshold, o);
  REQUIRE(r.verified);
  CHECK_FALSE(r.rotation_only);
  CHECK(r.t_dir.dot(t.normalized()) > std::cos(2.0 * M_PI / 180.0));
  int false_positives = 0, false_negatives = 0;
  for (std::size_t i = 0; i < c.a.size(); ++i) {
    if (c.is_outlier[i] && r.inliers[i]) ++false_positives;
    if (!c.is_outlier[i] && !r.inliers[i]) ++false_negatives;
  }
  INFO("iterations " << r.iterations << ", false positives " << false_positives
                     << ", false negatives " << false_negatives);
  CHECK(false_negatives <= 2);   // of 140 inliers
  CHECK(false_positives <= 6);   // of 60 outliers (those that fall on their epipolar plane)
  CHECK(r.num_inliers == 200 - 60 - false_negatives + false_positives);
  // Deterministic for a fixed seed.
  const TranslationRansacResult again = RansacTranslationKnownRotation(c.a, c.f_c, threshold, o);
  CHECK(again.inliers == r.inliers);
  CHECK(again.t_dir == r.t_dir);
}

TEST_CASE("2-point RANSAC selects the rotation-only model without parallax", "[features]") {
  const Eigen::Matrix3d R = ExpSO3(Eigen::Vector3d(0.1, 0.05, -0.02)).toRotationMatrix();
  const Correspondences c = Make(R, Eigen::Vector3d::Zero(), 300, 0.1, 0.2 / 458.0, 5);
  const TranslationRansacResult r =
      RansacTranslationKnownRotation(c.a, c.f_c, 2.0 / 458.0, RansacOptions());
  CHECK(r.rotation_only);
  CHECK(r.t_dir.isZero());
  for (std::size_t i = 0; i < c.a.size(); ++i) CHECK(r.inliers[i] == !c.is_outlier[i]);
}

TEST_CASE("2-point RANSAC: cheirality rejects points moving towards the epipole",
          "[features]") {
  // Forward motion: true points move away from the epipole (the image centre). A point whose
  // bearing moves the same distance towards the centre lies on its epipolar plane but would
  // need a negative depth.
  const Eigen::Vector3d t(0.0, 0.0, -0.5);  // p_Ck_Ckm1: the camera moved 0.5 m forward
  Correspondences c = Make(Eigen::Matrix3d::Identity(), t, 100, 0.0, 0.0, 9);
  const Eigen::Vector3d a = Eigen::Vector3d(0.2, 0.1, 1.0).normalized();
  const Eigen::Vector3d towards = (a - 0.05 * Eigen::Vector3d(0.2, 0.1, 0.0)).normalized();
  c.a.push_back(a);
  c.f_c.push_back(towards);
  const TranslationRansacResult r =
      RansacTranslationKnownRotation(c.a, c.f_c, 1.0 / 458.0, RansacOptions());
  REQUIRE_FALSE(r.rotation_only);
  CHECK(r.num_inliers == 100);
  CHECK_FALSE(r.inliers.back());
}

TEST_CASE("2-point RANSAC keeps everything when it cannot verify", "[features]") {
  const Correspondences c =
      Make(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.2, 0, 0), 5, 0.4, 0.0, 3);
  RansacOptions o;
  TranslationRansacResult r = RansacTranslationKnownRotation(c.a, c.f_c, 0.004, o);
  CHECK_FALSE(r.verified);
  CHECK(r.num_inliers == 5);
  o.method = "none";
  const Correspondences many =
      Make(Eigen::Matrix3d::Identity(), Eigen::Vector3d(0.2, 0, 0), 50, 0.4, 0.0, 3);
  r = RansacTranslationKnownRotation(many.a, many.f_c, 0.004, o);
  CHECK_FALSE(r.verified);
  CHECK(r.num_inliers == 50);
  CHECK_THROWS(RansacTranslationKnownRotation(many.a, c.f_c, 0.004, o));
}

}  // namespace
}  // namespace vilma::localizer
