#include "vilma/localizer/pose_acceptance.h"

#include <catch2/catch.hpp>
#include <cmath>
#include <random>

#include "pose_test_scene.h"
#include "test_cameras.h"

using namespace vilma;
using namespace vilma::localizer;

namespace {

using test::EurocCamera;
using test::kT_G_C;
using test::AddPoseInliers;
using test::PoseScene;

// Matches to random points (outliers).
void AddOutliers(const Camera& cam, int n, std::mt19937_64* rng, PoseScene* s) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  for (int i = 0; i < n; ++i) {
    // Coordinates last to first: the order GCC drew them in (tests/test_random.h).
    const double y = u(*rng) * cam.height();
    const double x = u(*rng) * cam.width();
    s->uv.emplace_back(x, y);
    const double p_z = 1 + 8 * u(*rng);
    const double p_y = 6 * u(*rng) - 3;
    const double p_x = 8 * u(*rng) - 4;
    s->p_G.push_back(kT_G_C * Eigen::Vector3d(p_x, p_y, p_z));
  }
}

AcceptedPose Run(const Camera& cam, const PoseScene& s, const PoseAcceptanceOptions& options = {}) {
  PoseRansacOptions ransac;
  const PoseResult pose = EstimateCameraPose(cam, s.uv, s.p_G, ransac);
  REQUIRE((pose.status == PoseStatus::kOk || pose.status == PoseStatus::kTooFewInliers));
  return AcceptPose(cam, s.uv, s.p_G, pose, ransac, options);
}

double PositionError(const AcceptedPose& a) {
  return (a.T_G_C.translation() - kT_G_C.translation()).norm();
}

}  // namespace

TEST_CASE("pose acceptance: reprojection Jacobian equals central differences", "[localization]") {
  const Camera cams[] = {EurocCamera(),
                         Camera(1226, 370, Eigen::Vector4d(718.9, 718.9, 607.2, 185.2),
                                DistortionModel::kNone, Eigen::VectorXd())};
  for (const Camera& cam : cams) {
    const Eigen::Vector3d p_G = kT_G_C * Eigen::Vector3d(0.4, -0.3, 3.0);
    const Eigen::Vector2d uv(300.0, 200.0);
    Eigen::Vector2d e;
    Eigen::Matrix<double, 2, 6> J;
    REQUIRE(ReprojectionResidual(cam, kT_G_C, p_G, uv, &e, &J));
    const double h = 1e-6;
    for (int k = 0; k < 6; ++k) {
      Vector6d d = Vector6d::Zero();
      d[k] = h;
      Eigen::Vector2d ep, em;
      REQUIRE(ReprojectionResidual(cam, kT_G_C * Transformation::Exp(d), p_G, uv, &ep, nullptr));
      REQUIRE(ReprojectionResidual(cam, kT_G_C * Transformation::Exp(-d), p_G, uv, &em, nullptr));
      const Eigen::Vector2d numeric = (ep - em) / (2 * h);
      INFO("column " << k << ": analytic " << J.col(k).transpose() << ", numeric "
                     << numeric.transpose());
      CHECK((J.col(k) - numeric).norm() <= 1e-5 * std::max(1.0, numeric.norm()));
    }
  }
  // Behind the camera: no residual.
  Eigen::Vector2d e;
  CHECK_FALSE(ReprojectionResidual(EurocCamera(), kT_G_C, kT_G_C * Eigen::Vector3d(0, 0, -2),
                                   Eigen::Vector2d(1, 1), &e, nullptr));
}

TEST_CASE("pose acceptance: image spread counts cells and the convex hull", "[localization]") {
  const Camera cam(800, 600, Eigen::Vector4d(500, 500, 400, 300), DistortionModel::kNone,
                   Eigen::VectorXd());
  double cells = 0.0, hull = 0.0;
  // A 200 x 150 square (plus an interior point) in the top-left cell of a 4 x 4 grid.
  ImageSpread(cam, {{0, 0}, {199, 0}, {199, 149}, {0, 149}, {50, 50}}, 4, 4, &cells, &hull);
  CHECK(cells == Approx(1.0 / 16.0));
  CHECK(hull == Approx(199.0 * 149.0 / (800.0 * 600.0)));
  // The four corners: every corner cell, the whole image as hull.
  ImageSpread(cam, {{0, 0}, {799, 0}, {799, 599}, {0, 599}}, 4, 4, &cells, &hull);
  CHECK(cells == Approx(4.0 / 16.0));
  CHECK(hull == Approx(799.0 * 599.0 / (800.0 * 600.0)));
  // Collinear points have no area.
  ImageSpread(cam, {{0, 0}, {100, 100}, {500, 500}}, 4, 4, &cells, &hull);
  CHECK(hull == Approx(0.0).margin(1e-12));
}

TEST_CASE("pose acceptance: covariance is s^2 (J^T J)^-1 with s^2 the floored residual variance",
          "[localization]") {
  const Camera cam = EurocCamera();
  std::mt19937_64 rng(3);
  PoseScene exact, noisy;
  AddPoseInliers(cam, 100, 0, 0, 1, 1, 2, 6, 0.0, &rng, &exact);
  rng.seed(3);
  AddPoseInliers(cam, 100, 0, 0, 1, 1, 2, 6, 3.0, &rng, &noisy);
  std::vector<int> all(100);
  for (int i = 0; i < 100; ++i) all[i] = i;
  Matrix6d c_exact, c_noisy;
  double s_exact = 0.0, s_noisy = 0.0;
  REQUIRE(PoseCovariance(cam, exact.uv, exact.p_G, all, kT_G_C, 1.0, &c_exact, &s_exact));
  REQUIRE(PoseCovariance(cam, noisy.uv, noisy.p_G, all, kT_G_C, 1.0, &c_noisy, &s_noisy));
  CHECK(s_exact == Approx(0.0).margin(1e-9));
  CHECK(s_noisy == Approx(3.0).epsilon(0.15));
  // Same geometry (the same points): the noisy covariance is s^2 times the floor's.
  CHECK((c_noisy - s_noisy * s_noisy * c_exact).norm() <= 1e-6 * c_noisy.norm());
  // The floor: exact data keep sigma_px^2 (J^T J)^-1, not zero.
  Matrix6d c_floor2;
  REQUIRE(PoseCovariance(cam, exact.uv, exact.p_G, all, kT_G_C, 2.0, &c_floor2, nullptr));
  CHECK((c_floor2 - 4.0 * c_exact).norm() <= 1e-9 * c_floor2.norm());
  // Fewer than 4 points: no covariance.
  CHECK_FALSE(PoseCovariance(cam, exact.uv, exact.p_G, {0, 1, 2}, kT_G_C, 1.0, &c_exact, nullptr));
}

TEST_CASE("pose acceptance: a well-spread pose with outliers is accepted", "[localization]") {
  const Camera cam = EurocCamera();
  std::mt19937_64 rng(11);
  PoseScene s;
  AddPoseInliers(cam, 120, 0, 0, 1, 1, 2, 8, 0.5, &rng, &s);
  AddOutliers(cam, 80, &rng, &s);
  const AcceptedPose a = Run(cam, s);
  INFO(PoseVerdictName(a.verdict) << " rival " << a.quality.rival_ratio << " sigma "
                                  << a.quality.position_sigma_m);
  CHECK(a.verdict == PoseVerdict::kAccepted);
  CHECK(PositionError(a) < 0.05);
  CHECK(a.quality.inliers >= 115);
  CHECK(a.quality.rival_ratio < 0.3);
  CHECK(a.quality.cell_fraction > 0.8);
  CHECK(a.quality.position_sigma_m > 0.0);
  CHECK(a.quality.refine_rounds >= 1);
}

TEST_CASE("pose acceptance: each gate rejects its constructed case", "[localization]") {
  const Camera cam = EurocCamera();
  std::mt19937_64 rng(5);
  SECTION("inliers clustered in one image corner") {
    PoseScene s;
    AddPoseInliers(cam, 40, 0.02, 0.02, 0.12, 0.12, 2, 8, 0.3, &rng, &s);
    AddOutliers(cam, 20, &rng, &s);
    const AcceptedPose a = Run(cam, s);
    CHECK(a.verdict == PoseVerdict::kClusteredInliers);
    CHECK(a.quality.cell_fraction < 0.1);
    PoseAcceptanceOptions no_spread;
    no_spread.min_cell_fraction = 0.0;
    no_spread.min_hull_fraction = 0.0;
    // Near points at 2-8 m make even this corner precise enough for the covariance gate: the
    // spread gate is what rejects it.
    CHECK(Run(cam, s, no_spread).verdict == PoseVerdict::kAccepted);
  }
  SECTION("far landmarks only: rotation fine, translation weak") {
    PoseScene s;
    AddPoseInliers(cam, 60, 0, 0, 1, 1, 150, 300, 0.5, &rng, &s);
    const AcceptedPose a = Run(cam, s);
    CHECK(a.verdict == PoseVerdict::kUncertainPose);
    CHECK(a.quality.position_sigma_m > PoseAcceptanceOptions().max_position_sigma_m);
    CHECK(a.quality.rotation_sigma_deg < 0.67);
  }
  SECTION("repetitive structure: a rival pose with equal support") {
    PoseScene s;
    AddPoseInliers(cam, 60, 0, 0, 1, 1, 3, 8, 0.3, &rng, &s);
    // Every keypoint also matches a copy of its landmark 1 m to the side (same descriptor).
    const std::size_t n = s.uv.size();
    for (std::size_t i = 0; i < n; ++i) {
      s.uv.push_back(s.uv[i]);
      s.p_G.push_back(s.p_G[i] + Eigen::Vector3d(1.0, 0.0, 0.0));
    }
    const AcceptedPose a = Run(cam, s);
    CHECK(a.verdict == PoseVerdict::kAmbiguousPose);
    CHECK(a.quality.rival_ratio > 0.8);
    CHECK(a.quality.rival_position_m > 0.5);
    PoseAcceptanceOptions no_rival;
    no_rival.rival_check = false;
    CHECK(Run(cam, s, no_rival).verdict == PoseVerdict::kAccepted);
  }
  SECTION("a third of the structure repeated: the rival is clearly weaker") {
    PoseScene s;
    AddPoseInliers(cam, 90, 0, 0, 1, 1, 3, 8, 0.3, &rng, &s);
    for (std::size_t i = 0; i < 90; i += 4) {
      s.uv.push_back(s.uv[i]);
      s.p_G.push_back(s.p_G[i] + Eigen::Vector3d(1.0, 0.0, 0.0));
    }
    const AcceptedPose a = Run(cam, s);
    CHECK(a.verdict == PoseVerdict::kAccepted);
    CHECK(a.quality.rival_ratio <= 0.3);
    CHECK(PositionError(a) < 0.05);
  }
  SECTION("a third repeated: a significant margin outweighs the rival, a small one does not") {
    // Every third landmark copied 1 m aside: the rival has a third of the winner's support
    // (above max_rival_ratio 0.3). With 240 inliers the margin (240 - 80) / sqrt(320) = 8.9
    // sigma is no chance; with 30 it is (30 - 10) / sqrt(40) = 3.2 sigma.
    auto third_repeated = [&](int n) {
      PoseScene s;
      AddPoseInliers(cam, n, 0, 0, 1, 1, 3, 8, 0.3, &rng, &s);
      for (int i = 0; i < n; i += 3) {
        s.uv.push_back(s.uv[static_cast<std::size_t>(i)]);
        s.p_G.push_back(s.p_G[static_cast<std::size_t>(i)] + Eigen::Vector3d(1.0, 0.0, 0.0));
      }
      return s;
    };
    const PoseScene many = third_repeated(240);
    const AcceptedPose a = Run(cam, many);
    INFO("rival " << a.quality.rival_ratio << " margin " << a.quality.rival_margin_sigma);
    CHECK(a.verdict == PoseVerdict::kAccepted);
    CHECK(a.quality.rival_ratio > PoseAcceptanceOptions().max_rival_ratio);
    CHECK(a.quality.rival_margin_sigma > 8.0);
    CHECK(PositionError(a) < 0.05);
    PoseAcceptanceOptions ratio_only;  // the rule before the margin
    ratio_only.max_outweighed_rival_ratio = 0.0;
    CHECK(Run(cam, many, ratio_only).verdict == PoseVerdict::kAmbiguousPose);
    const AcceptedPose few = Run(cam, third_repeated(30));
    INFO("few: rival " << few.quality.rival_ratio << " margin " << few.quality.rival_margin_sigma);
    CHECK(few.verdict == PoseVerdict::kAmbiguousPose);
    CHECK(few.quality.rival_margin_sigma < 5.0);
  }
  SECTION("few inliers among many matches: the inlier ratio") {
    // RANSAC rarely finds a 4 % model, but a wrong one found by chance looks like this: the
    // gate judges the model, however it was found.
    PoseScene s;
    AddPoseInliers(cam, 25, 0, 0, 1, 1, 2, 8, 0.3, &rng, &s);
    AddOutliers(cam, 600, &rng, &s);
    PoseResult pose;
    pose.status = PoseStatus::kOk;
    pose.T_G_C = kT_G_C;
    for (int i = 0; i < 25; ++i) pose.inliers.push_back(i);
    const AcceptedPose a = AcceptPose(cam, s.uv, s.p_G, pose, PoseRansacOptions(), {});
    CHECK(a.verdict == PoseVerdict::kLowInlierRatio);
    CHECK(a.quality.inliers >= 25);
    CHECK(a.quality.required_inliers == 32);  // ceil(0.05 x 625)
    PoseAcceptanceOptions lower;
    lower.min_inlier_ratio = 0.02;
    CHECK(AcceptPose(cam, s.uv, s.p_G, pose, PoseRansacOptions(), lower).verdict !=
          PoseVerdict::kLowInlierRatio);
  }
  SECTION("inlier errors spread over the threshold disc: the error distribution") {
    // Errors uniform over the 2 px disc (what chance agreements look like: median 1.41 px)
    // fail a median gate of 0.5 x 2 px; Gaussian 0.4 px noise of a right pose passes it.
    PoseAcceptanceOptions strict;
    strict.max_median_error_ratio = 0.5;
    PoseScene s;
    AddPoseInliers(cam, 150, 0, 0, 1, 1, 2, 8, 0.0, &rng, &s);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (Eigen::Vector2d& k : s.uv) {
      const double a = 2 * M_PI * u(rng), r = 1.95 * std::sqrt(u(rng));
      k += r * Eigen::Vector2d(std::cos(a), std::sin(a));
    }
    const AcceptedPose a = Run(cam, s, strict);
    CHECK(a.verdict == PoseVerdict::kHighReprojectionError);
    CHECK(a.quality.median_error_px > 1.0);
    PoseScene right;
    AddPoseInliers(cam, 150, 0, 0, 1, 1, 2, 8, 0.4, &rng, &right);
    CHECK(Run(cam, right, strict).verdict == PoseVerdict::kAccepted);
  }
  SECTION("too few inliers") {
    PoseScene s;
    AddPoseInliers(cam, 8, 0, 0, 1, 1, 2, 8, 0.3, &rng, &s);
    AddOutliers(cam, 4, &rng, &s);
    PoseRansacOptions ransac;
    const PoseResult pose = EstimateCameraPose(cam, s.uv, s.p_G, ransac);
    REQUIRE(pose.status == PoseStatus::kTooFewInliers);
    CHECK(AcceptPose(cam, s.uv, s.p_G, pose, ransac, {}).verdict == PoseVerdict::kTooFewInliers);
  }
}

TEST_CASE("pose acceptance: measure_all_gates measures every gate, the verdict unchanged",
          "[localization]") {
  const Camera cam = EurocCamera();
  std::mt19937_64 rng(5);
  PoseScene s;  // inliers in one image corner: the spread gate fails first
  AddPoseInliers(cam, 40, 0.02, 0.02, 0.12, 0.12, 2, 8, 0.3, &rng, &s);
  AddOutliers(cam, 20, &rng, &s);
  const AcceptedPose first = Run(cam, s);
  REQUIRE(first.verdict == PoseVerdict::kClusteredInliers);
  CHECK(first.quality.position_sigma_m < 0.0);  // not measured after the failing gate
  CHECK(first.quality.rival_ratio < 0.0);
  PoseAcceptanceOptions all;
  all.measure_all_gates = true;
  const AcceptedPose measured = Run(cam, s, all);
  CHECK(measured.verdict == PoseVerdict::kClusteredInliers);
  CHECK(measured.quality.cell_fraction == first.quality.cell_fraction);
  CHECK(measured.quality.position_sigma_m > 0.0);
  CHECK(measured.quality.rotation_sigma_deg > 0.0);
  CHECK(measured.quality.rival_ratio >= 0.0);
  CHECK(measured.quality.rival_margin_sigma > 0.0);
  CHECK(measured.quality.displaced_rival_ratio >= 0.0);
  CHECK(measured.T_G_C.translation() == first.T_G_C.translation());
}

TEST_CASE("pose acceptance: options validate each field", "[localization]") {
  CHECK(PoseAcceptanceOptions().Validate().empty());
  auto bad = [](auto set) {
    PoseAcceptanceOptions o;
    set(o);
    return o.Validate();
  };
  CHECK_THAT(bad([](auto& o) { o.min_inlier_ratio = 1.5; }), Catch::Contains("min_inlier_ratio"));
  CHECK_THAT(bad([](auto& o) { o.refine_rounds = 0; }), Catch::Contains("refine_rounds"));
  CHECK_THAT(bad([](auto& o) { o.max_median_error_ratio = 0.0; }),
             Catch::Contains("max_median_error_ratio"));
  CHECK_THAT(bad([](auto& o) { o.max_p90_error_ratio = 2.0; }),
             Catch::Contains("max_p90_error_ratio"));
  CHECK_THAT(bad([](auto& o) { o.grid_rows = 0; }), Catch::Contains("grid_rows"));
  CHECK_THAT(bad([](auto& o) { o.min_cell_fraction = -0.1; }),
             Catch::Contains("min_cell_fraction"));
  CHECK_THAT(bad([](auto& o) { o.min_hull_fraction = 1.1; }),
             Catch::Contains("min_hull_fraction"));
  CHECK_THAT(bad([](auto& o) { o.max_outweighed_rival_ratio = 1.5; }),
             Catch::Contains("max_outweighed_rival_ratio"));
  CHECK_THAT(bad([](auto& o) { o.min_rival_margin_sigma = 0.0; }),
             Catch::Contains("min_rival_margin_sigma"));
  CHECK_THAT(bad([](auto& o) { o.max_position_sigma_m = 0.0; }),
             Catch::Contains("max_position_sigma_m"));
  CHECK_THAT(bad([](auto& o) { o.max_rotation_sigma_deg = -1.0; }),
             Catch::Contains("max_rotation_sigma_deg"));
  CHECK_THAT(bad([](auto& o) { o.rival_exclusion_factor = 0.5; }),
             Catch::Contains("rival_exclusion_factor"));
  CHECK_THAT(bad([](auto& o) { o.max_rival_ratio = 0.0; }), Catch::Contains("max_rival_ratio"));
  CHECK_THAT(bad([](auto& o) { o.rival_max_iterations = 0; }),
             Catch::Contains("rival_max_iterations"));
  CHECK_THAT(bad([](auto& o) { o.rival_min_position_m = -1.0; }),
             Catch::Contains("rival_min_position_m"));
  CHECK_THAT(bad([](auto& o) { o.rival_min_rotation_deg = -1.0; }),
             Catch::Contains("rival_min_rotation_deg"));
}
