// Split-half consistency of a refined pose (docs/localizer.md, "Acceptance", gate 6): the
// inliers are split into two halves, each half is refined on its own from the pose, and the two
// half-poses must agree. A correct pose explains every part of its inlier set; a pose that is
// pulled off by a systematic error of part of the inliers (a biased subset, a mixture of the
// right points and chance agreements) gives halves that disagree by more than their noise.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "vilma/core/camera.h"
#include "vilma/core/geometry.h"

namespace vilma::localizer {

// How the inliers are split. kImageAxis: at the median of the inliers' image coordinates
// projected on their principal axis (the two image regions the inliers cover, e.g. left and
// right of the scene): tests whether the model holds across the image. kDepth: at the median
// depth of the landmarks in the camera (near against far points): tests whether the rotation
// (constrained by the far points) and the translation (by the near ones) agree.
enum class SplitAxis : uint8_t { kImageAxis, kDepth };

struct SplitConsistency {
  bool valid = false;               // both halves had >= 4 points and a regular covariance
  double position_m = 0.0;          // |p_1 - p_2| of the two half-poses (camera centres)
  double rotation_deg = 0.0;        // angle between their rotations
  double mahalanobis2 = 0.0;        // d^T (C_1 + C_2)^-1 d, d = Log(T_1^-1 T_2): chi^2 with 6 dof
};

// Refines each half (Gauss-Newton on the unweighted pixel error, `iterations` steps, from
// T_G_C) and compares the two poses. Each half's covariance is the unweighted estimate's
// (PoseCovariance with CovarianceOf::kUnweighted, landmark covariances when p_G_covariance is
// not empty), so d's covariance is C_1 + C_2 (the halves share no residual).
SplitConsistency SplitHalfConsistency(const Camera& camera,
                                      const std::vector<Eigen::Vector2d>& keypoints,
                                      const std::vector<Eigen::Vector3d>& p_G,
                                      const std::vector<int>& inliers, const Transformation& T_G_C,
                                      int iterations, double sigma_px,
                                      const std::vector<Eigen::Matrix3d>& p_G_covariance,
                                      SplitAxis axis);

}  // namespace vilma::localizer
