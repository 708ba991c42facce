// Split-half consistency of a refined camera pose (pose_consistency.h).
#include "vilma/localizer/pose_consistency.h"
#include "vilma/localizer/pose_ransac.h"

#include <catch2/catch.hpp>
#include <random>

#include "pose_test_scene.h"
#include "test_cameras.h"

using namespace vilma;
using namespace vilma::localizer;

namespace {

using test::EurocCamera;
using test::kT_G_C;
using test::PoseScene;
using test::AddPoseInliers;

}  // namespace

TEST_CASE("pose acceptance: split-half consistency agrees for a right pose, not for a biased one",
          "[localization]") {
  // 80 landmarks over the image with 0.5 px noise: the two halves (left/right of the inliers'
  // principal axis, and near/far) agree within their noise (d^2 below chi^2_6's 99.9 % point,
  // 22.5). Then the landmarks of the right half of the image are shifted 0.15 m sideways (a
  // systematic error of part of the map): refined on all points the pose is a compromise, and
  // the halves disagree by far more than their covariances allow.
  const Camera cam = EurocCamera();
  std::mt19937_64 rng(21);
  PoseScene s;
  AddPoseInliers(cam, 80, 0.05, 0.05, 0.95, 0.95, 2, 8, 0.5, &rng, &s);
  std::vector<int> all(s.uv.size());
  for (std::size_t i = 0; i < all.size(); ++i) all[i] = static_cast<int>(i);
  Transformation T = kT_G_C;
  RefineCameraPose(cam, s.uv, s.p_G, all, 10, 0.5, &T);
  for (const SplitAxis axis : {SplitAxis::kImageAxis, SplitAxis::kDepth}) {
    const SplitConsistency c = SplitHalfConsistency(cam, s.uv, s.p_G, all, T, 10, 0.5, {}, axis);
    INFO("axis " << static_cast<int>(axis) << ": d^2 " << c.mahalanobis2 << ", " << c.position_m
                 << " m, " << c.rotation_deg << " deg");
    REQUIRE(c.valid);
    CHECK(c.mahalanobis2 < 22.5);
  }
  PoseScene biased = s;
  for (std::size_t i = 0; i < biased.uv.size(); ++i) {
    if (biased.uv[i].x() > 0.5 * cam.width()) {
      biased.p_G[i] += kT_G_C.rotation() * Eigen::Vector3d(0.15, 0.0, 0.0);
    }
  }
  Transformation T_biased = kT_G_C;
  RefineCameraPose(cam, biased.uv, biased.p_G, all, 10, 0.5, &T_biased);
  const SplitConsistency c =
      SplitHalfConsistency(cam, biased.uv, biased.p_G, all, T_biased, 10, 0.5, {},
                           SplitAxis::kImageAxis);
  INFO("biased: d^2 " << c.mahalanobis2 << ", " << c.position_m << " m, " << c.rotation_deg
                      << " deg");
  REQUIRE(c.valid);
  CHECK(c.mahalanobis2 > 100.0);
  CHECK(c.position_m > 0.05);
  // Fewer than 8 inliers: not measured.
  CHECK_FALSE(SplitHalfConsistency(cam, s.uv, s.p_G, {0, 1, 2, 3, 4, 5, 6}, T, 10, 0.5, {},
                                   SplitAxis::kDepth)
                  .valid);
}
