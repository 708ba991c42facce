// The second camera of the stereo filter (ROVIO is multi-camera: Bloesch et al., IJRR 2017,
// sec. 5; docs/estimator.md "Stereo"). Features are anchored in camera 1 (the VIO camera) as a
// unit bearing mu and an inverse distance rho (p_C1 = mu / rho). In camera 2 the point is
//
//   p_C2 = R_C2_C1 p_C1 + p_C2_C1,  i.e. up to the positive factor 1/rho
//   m = R_C2_C1 mu + rho p_C2_C1     (finite for rho = 0: a point at infinity),
//
// and its pixel is pi_2(m). With the bearing boxplus mu (+) d = mu + B(mu) d to first order:
//
//   d pixel / d d   = J_pi2(m) R_C2_C1 B(mu)
//   d pixel / d rho = J_pi2(m) p_C2_C1
//
// (B(mu) the 3x2 tangent basis of filter_state.h). Both are checked against numeric
// differences through BearingBoxPlus in tests/estimator/stereo_test.cpp.
#pragma once

#include <Eigen/Core>

#include "vilma/core/camera.h"
#include "vilma/core/geometry.h"
#include "vilma/estimator/image_pyramid.h"
#include "vilma/estimator/multilevel_patch.h"

namespace vilma::estimator {

struct OtherCameraPrediction {
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();           // in camera 2 [px]
  Eigen::Matrix<double, 2, 3> J_pixel_m = Eigen::Matrix<double, 2, 3>::Zero();  // d pi2 / d m
  Eigen::Matrix<double, 2, 2> J_pixel_bearing = Eigen::Matrix2d::Zero();  // d pixel / d d
  Eigen::Vector2d J_pixel_rho = Eigen::Vector2d::Zero();      // d pixel / d rho [px m]
};

// The pixel of the feature (mu, rho) of camera 1 in camera 2 and its Jacobians. False when it
// does not project into camera 2's image (behind it, outside).
bool PredictInOtherCamera(const Camera& camera2, const Transformation& T_C2_C1,
                          const Eigen::Vector3d& mu_C1, double rho,
                          OtherCameraPrediction* prediction);

// The patch warp into camera 2: d pixel_2 / d pixel_1 for a patch extracted in camera 1 at the
// feature's bearing (D = B^T d mu / d pixel_1 at extraction, A = d tangent(now) /
// d tangent(extraction)): W2 = J_pixel_bearing A D (the rho dependence of the warp is
// neglected, as the anchor camera's warp neglects it).
inline Eigen::Matrix2d OtherCameraWarp(const OtherCameraPrediction& p, const Eigen::Matrix2d& A,
                                       const Eigen::Matrix2d& D) {
  return p.J_pixel_bearing * A * D;
}

// Noise of the joint photometric innovation of one feature in both cameras (docs/estimator.md,
// "The joint update of both cameras"). Each camera's residual is QR-reduced to two rows,
// y_i = R_i (pixel error) + (intensity noise), R_i the 2x2 triangular factor of its Jacobian.
// The pixel-level model error e_i (std pixel_sigma in each image: warp and template errors)
// comes from the same template in both images, with correlation c: e_2 = c e_1 + sqrt(1 - c^2)
// e', so
//
//   N = [ sI^2 I + sp^2 R1 R1^T     c sp^2 R1 R2^T       ]
//       [ c sp^2 R2 R1^T            sI^2 I + sp^2 R2 R2^T ]
//
// (c = 0: two independent updates, the separate C1 and C2 updates). The two pixel frames are
// taken as parallel (a near-rectified pair: the template's error moves both images alike).
Eigen::Matrix4d StereoJointNoise(const Eigen::Matrix2d& R1, const Eigen::Matrix2d& R2,
                                 double intensity_sigma, double pixel_sigma, double correlation);

struct StereoMatchOptions {
  double max_inverse_depth = 5.0;  // [1/m]
  double search_step_px = 2.0;     // [px]
  double max_match_error = 15.0;   // [grey levels]
  double max_epipolar_px = 2.0;    // [px]
  double pixel_sigma = 0.5;        // [px]
  double min_inverse_depth_sigma = 0.02;  // [1/m]
  int align_iterations = 10;
  int max_candidates = 3;  // local minima of the coarse search tried, lowest residual first
  // Uniqueness: the other local minima of the coarse search (more than 4 px along the curve
  // from the accepted one, coarse residual below 2x this ratio x its) are aligned too; if one
  // is accepted with a mean |residual| below this ratio x the match's, the match is dropped
  // (kAmbiguous). 0 turns the test off. Why: docs/estimator-stereo-history.md "False stereo matches
  // and the filter's consistency".
  double min_uniqueness_ratio = 0.0;
  PhotometricOptions photometric;
};

// Why a match was not accepted (counted per reason in FilterStats: the diagnosis of
// docs/estimator-stereo-history.md "Why stereo matches fail").
enum class StereoMatchFailure {
  kNone = 0,
  kNoSample,         // no point of the searched curve projects into camera 2 with a full patch
  kNotConverged,     // the 2D alignment from the best sample did not converge
  kResidual,         // converged, mean |residual| above max_match_error
  kNoDepth,          // no rho >= 0 on the curve near the aligned pixel (or no baseline)
  kEpipolar,         // the aligned pixel is more than max_epipolar_px off the curve
  kAmbiguous,        // another local minimum of the curve is nearly as good (min_uniqueness_ratio)
};
constexpr int kNumStereoMatchFailures = 7;

struct StereoMatch {
  bool found = false;
  StereoMatchFailure failure = StereoMatchFailure::kNone;
  double rho = 0.0;         // inverse distance along mu in camera 1 [1/m]
  double rho_sigma = 0.0;   // its std from pixel_sigma [1/m]
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();  // aligned pixel in camera 2
  double mean_abs_error = 0.0;
};

// Initial inverse distance of a new feature from the second image: the patch (extracted in
// camera 1 at bearing mu, tangent-from-pixel D) is compared along the epipolar curve
// pi_2(R mu + rho p) for rho in [0, max_inverse_depth] at steps of about search_step_px, the
// local minima of the residual along it (up to max_candidates, lowest first) are aligned in 2D
// (AlignPatch) until one is accepted, and rho is the least-squares point of the curve
// nearest to the aligned pixel (Gauss-Newton in rho). Accepted when the alignment converged
// with a mean |residual| <= max_match_error and the pixel is within max_epipolar_px of the
// curve, and (min_uniqueness_ratio > 0) no other place on the curve aligns with a mean
// |residual| within that ratio of the match's. rho_sigma = pixel_sigma /
// |d pixel / d rho| (at least min_inverse_depth_sigma).
StereoMatch MatchInOtherCamera(const MultilevelPatch& patch, const Eigen::Matrix2d& D,
                               const ImagePyramid& pyramid2, const Camera& camera2,
                               const Transformation& T_C2_C1, const Eigen::Vector3d& mu_C1,
                               const StereoMatchOptions& options);

}  // namespace vilma::estimator
