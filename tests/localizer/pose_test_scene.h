// A query camera's matches for the localizer's pose tests: inliers spread over a part of the
// image at a depth range, with Gaussian pixel noise (pose_acceptance_test.cpp,
// pose_consistency_test.cpp).
#pragma once

#include <Eigen/Core>

#include <random>
#include <vector>

#include "test_cameras.h"
#include "test_random.h"

namespace vilma::localizer::test {

struct PoseScene {
  std::vector<Eigen::Vector2d> uv;
  std::vector<Eigen::Vector3d> p_G;
};

// A match per pixel drawn uniformly from [x0, x1] x [y0, y1] (fractions of the image), at a
// depth uniform in [z0, z1], seen with Gaussian pixel noise.
inline void AddPoseInliers(const Camera& cam, int n, double x0, double y0, double x1, double y1,
                           double z0, double z1, double noise_px, std::mt19937_64* rng,
                           PoseScene* s) {
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> g(0.0, noise_px);
  int added = 0;
  while (added < n) {
    // y before x: the order GCC drew them in (tests/test_random.h).
    const double y = (y0 + (y1 - y0) * u(*rng)) * cam.height();
    const double x = (x0 + (x1 - x0) * u(*rng)) * cam.width();
    const Eigen::Vector2d px(x, y);
    Eigen::Vector3d f;
    if (!cam.Unproject(px, &f)) continue;
    const Eigen::Vector3d p_C = f / f.z() * (z0 + (z1 - z0) * u(*rng));
    Eigen::Vector2d k;
    if (cam.Project(p_C, &k) != Camera::ProjectionResult::kValid) continue;
    s->uv.push_back(k + vilma::testing::DrawVector2([&] { return g(*rng); }));
    s->p_G.push_back(kT_G_C * p_C);
    ++added;
  }
}

}  // namespace vilma::localizer::test
