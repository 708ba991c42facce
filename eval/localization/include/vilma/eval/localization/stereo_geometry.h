// Rectified stereo points for the KITTI maps (docs/localizer.md, "KITTI localization check"):
// the sub-pixel disparity of a stereo match by 1-D patch alignment along the row, and the
// maximum-likelihood point of a landmark seen by several rectified stereo pairs.
//
// Why: a landmark's depth from one stereo pair is Z = f b / d; with the integer disparity of two
// detector corners (|error| up to ~1 px) a KITTI point at 30 m (f b = 386 px m, d ~ 13 px) is
// metres off along its ray. A query a few metres away then sees it shifted by pixels, which the
// localizer attributes to its pose (kitti other-part frame 27, 0.303 m off).
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "vilma/core/camera.h"
#include "vilma/core/geometry.h"

namespace vilma::eval {

struct DisparityRefinementOptions {
  int half_window_px = 4;        // the aligned patch is (2 w + 1)^2 pixels around the left point
  int search_radius_px = 2;      // ZNCC scan of d0 - r .. d0 + r in 1-px steps before the fit
  double max_change_px = 1.5;    // the refined disparity stays within this of d0 [px]
  double min_zncc = 0.8;         // zero-mean normalized cross-correlation at the result
  double min_patch_std = 2.0;    // grey-level standard deviation of the left patch at least
  int max_iterations = 10;       // Gauss-Newton iterations of the 1-D alignment
  std::string Validate() const;
};

enum class DisparityRefinementStatus {
  kOk,
  kOutside,       // a patch leaves an image
  kTextureless,   // left patch std below min_patch_std, or no gradient along the row
  kNoPeak,        // the ZNCC scan's best is at the scan's end: d0 is not near the optimum
  kMovedTooFar,   // converged beyond max_change_px from d0
  kLowZncc,       // below min_zncc at the result
};
const char* DisparityRefinementStatusName(DisparityRefinementStatus status);

struct DisparityRefinement {
  DisparityRefinementStatus status = DisparityRefinementStatus::kOutside;
  double disparity_px = 0.0;  // the left point (u, v) is seen at (u - d, v) in the right image
  double zncc = 0.0;          // at disparity_px
  double sigma_px = 0.0;      // Gauss-Newton standard deviation of d from the patch residuals
  int iterations = 0;
  bool ok() const { return status == DisparityRefinementStatus::kOk; }
};

// Sub-pixel disparity of the left point uv_left (any sub-pixel position) in a rectified 8-bit
// pair, starting from the disparity d0 of the matched keypoints:
//  1. ZNCC of the left patch P_L(x, y) = I_L(u + x, v + y) with the right patch
//     P_R(x, y; d) = I_R(u - d + x, v + y) for d = d0 + k, |k| <= search_radius_px; a parabola
//     through the best and its two neighbours gives the start d1;
//  2. Gauss-Newton on E(d) = sum (P_R(d) - mean P_R(d) - (P_L - mean P_L))^2 (1-D Lucas-Kanade,
//     bilinear interpolation; the brightness offset between the cameras drops out):
//     J = dP_R/dd - mean = -(dI_R/dx - mean), dd = -sum J r / sum J^2 until |dd| < 1e-4 px;
//     sigma_d^2 = sum r^2 / (N - 2) / sum J^2.
// The left point is fixed: the result triangulates what the left image shows at uv_left.
DisparityRefinement RefineDisparity(const cv::Mat& left, const cv::Mat& right,
                                    const Eigen::Vector2d& uv_left, double d0,
                                    const DisparityRefinementOptions& options);

// A point of the left rectified camera from its left pixel and disparity:
// Z = f_x b / d, X = (u - c_x) Z / f_x, Y = (v - c_y) Z / f_y.
Eigen::Vector3d StereoPoint_C(const Camera& camera, double baseline_m,
                              const Eigen::Vector2d& uv_left, double disparity_px);

// One stereo view of a landmark: the left camera's pose, the left pixel and the disparity (the
// right camera sits at +b along the left camera's x, the same intrinsics, rectified).
struct StereoObservation {
  Transformation T_W_C;
  Eigen::Vector2d uv_left = Eigen::Vector2d::Zero();
  double disparity_px = 0.0;
};

struct StereoTrackOptions {
  // Pixel noise of each view for the covariance sigma^2 (sum J^T J)^-1 over the used views.
  double sigma_px = 1.0;
  // A stereo view whose left or right residual at the joint point exceeds this is left out
  // (worst first, one at a time, re-solved each time; at least one view stays) [px]: a wrong
  // association of the map's frame-to-frame merging.
  double max_residual_px = 2.5;
  std::string Validate() const;
};

struct StereoTrackPoint {
  bool ok = false;                                          // false: no view projects
  Eigen::Vector3d p_W = Eigen::Vector3d::Zero();            // [m]
  Eigen::Matrix3d covariance_W = Eigen::Matrix3d::Zero();   // of p_W [m^2]
  std::vector<bool> used;                                   // per observation
  int views_used = 0;
  double rms_residual_px = 0.0;  // over the used views' 2 x views_used pixel residuals
};

// The maximum-likelihood point of all views under isotropic pixel noise (mapping::Triangulate
// on the 2 N pixels: midpoint of the rays, then Gauss-Newton), with outlying views removed as
// StereoTrackOptions says. One view gives its stereo point (StereoPoint_C) to rounding.
StereoTrackPoint TriangulateStereoTrack(const std::vector<StereoObservation>& observations,
                                        const Camera& camera, double baseline_m,
                                        const StereoTrackOptions& options);

}  // namespace vilma::eval
