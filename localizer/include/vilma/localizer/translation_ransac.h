// Translation-only 2-point RANSAC on bearing vectors with a known rotation (Kneip, Chli,
// Siegwart, "Robust Real-Time Visual Odometry with a Single Camera and an IMU", BMVC 2011).
//
// Model: a point seen along unit bearing f_p in the previous camera and f_c in the current one,
// with R = R_Ck_Ckm1 known (gyroscope) and t = p_Ck_Ckm1 unknown:
//   d_c f_c = d_p R f_p + t.
// With a = R f_p the coplanarity of f_c, a and t reads  t . (a x f_c) = 0: each correspondence
// is one linear constraint on the direction of t, so two give t ~ n_1 x n_2 with n_i = a_i x f_c_i.
// The residual of a correspondence is the sine of the angle between f_c and the epipolar plane
// span(t, a), i.e. |f_c . (t x a)| / |t x a|; correspondences with parallax above the threshold
// must also have positive depths d_p, d_c (cheirality), which rejects half the outliers that
// lie on their epipolar plane. The rotation-only model (t = 0, residual |a x f_c|) competes
// with the best translation (see RansacOptions::rotation_only_margin and
// min_translation_support).
#pragma once

#include <Eigen/Core>
#include <vector>

#include "vilma/localizer/feature_options.h"

namespace vilma::localizer {

struct TranslationRansacResult {
  bool rotation_only = false;  // the t = 0 model was selected (no usable parallax)
  bool verified = false;       // false when there were fewer than options.min_matches
  Eigen::Vector3d t_dir = Eigen::Vector3d::Zero();  // unit direction of p_Ck_Ckm1, or zero
  std::vector<char> inliers;   // one flag per correspondence
  int num_inliers = 0;
  int iterations = 0;
};

// `a`: previous bearings rotated into the current frame (R_Ck_Ckm1 f_p), `f_c`: current
// bearings, all unit vectors, same size. `threshold` is the sine of the largest accepted angle
// to the epipolar plane [rad]. With method "none" or fewer than min_matches correspondences,
// every correspondence is returned as inlier and `verified` is false.
TranslationRansacResult RansacTranslationKnownRotation(const std::vector<Eigen::Vector3d>& a,
                                                       const std::vector<Eigen::Vector3d>& f_c,
                                                       double threshold,
                                                       const RansacOptions& options);

}  // namespace vilma::localizer
