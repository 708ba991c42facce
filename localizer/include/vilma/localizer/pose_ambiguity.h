// Displaced rival (docs/localizer.md, "Displaced rival"): the best-supported pose that is NOT
// the winner's answer, searched among poses that share the winner's inliers. The second-
// hypothesis test of pose_acceptance.h looks for a rival among the matches the winner does not
// explain; it cannot see a rival that explains mostly the same matches. That is the
// rotation-translation ambiguity of a narrow or shallow inlier set: when all inliers lie in a
// small depth band at depth Z, a sideways shift t of the camera is compensated by a rotation
// t / Z, and only matches at other depths (which the shifted pose rejects with large errors)
// tell the two apart. Both wrong poses the gates let through had this shape (kitti
// other-part frame 27: inliers at 22-34 m, 0.29 m sideways and 0.59 deg = 0.29 / 28 rad;
// euroc corner frame 71: inliers at 4.1-6.2 m, 0.19 m sideways and 2.2 deg = 0.19 / 5 rad;
// in both the near matches that agree with the truth have errors of 12-31 px under the
// estimate). The search: P3P on two winner inliers and one match the winner rejects (a point
// the winner's pose cannot explain, e.g. at another depth), each solution that is displaced
// from the winner (beyond a position OR a rotation bound) scored by its inliers over all
// matches; the best is refined on its inliers and kept if it stays displaced and gains.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <vector>

#include "vilma/core/camera.h"
#include "vilma/core/geometry.h"

namespace vilma::localizer {

struct DisplacedRivalOptions {
  int samples = 300;               // P3P samples (each up to 4 solutions)
  double threshold_px = 2.0;       // inlier threshold (ransac.threshold_px)
  double min_position_m = 0.3;     // displaced: farther than this from the winner OR
  double min_rotation_deg = 2.0;   // ... rotated more than this
  int refine_iterations = 10;      // Gauss-Newton steps per refinement round (2 rounds)
  uint64_t seed = 1;
};

struct DisplacedRival {
  bool found = false;       // some displaced P3P solution had at least 3 inliers
  int inliers = 0;          // its inliers over all matches at threshold_px
  double position_m = -1.0; // its distance to the winner
  double rotation_deg = -1.0;
  Transformation T_G_C;
};

// keypoints[i] sees p_G[i]; `winner_inliers` are indices of the winner's inliers and
// `winner_errors[i]` the reprojection error of match i under T_G_C_winner (infinite if it does
// not project). Deterministic for a given seed.
DisplacedRival FindDisplacedRival(const Camera& camera,
                                  const std::vector<Eigen::Vector2d>& keypoints,
                                  const std::vector<Eigen::Vector3d>& p_G,
                                  const std::vector<int>& winner_inliers,
                                  const std::vector<double>& winner_errors,
                                  const Transformation& T_G_C_winner,
                                  const DisplacedRivalOptions& options);

}  // namespace vilma::localizer
