// Multilevel patches and their photometric error (ROVIO: Bloesch et al., IJRR 2017, sec. 4).
// A patch is a square of `patch_size` x `patch_size` samples on each of several pyramid levels
// around one feature. Samples sit at patch offsets o in {-(s-1)/2 .. (s-1)/2}^2 (units: pixels
// of that level) mapped into the image by an affine warp W (2x2): on level l the sample for o is
// at p_l + W o, where p_l is the feature's pixel on level l. W encodes the perspective
// distortion of the patch since it was extracted (W = I right after extraction).
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "vilma/estimator/image_pyramid.h"

namespace vilma::estimator {

struct PatchOptions {
  int patch_size = 6;   // samples per side on each level (even or odd)
  int num_levels = 4;   // levels 0 .. num_levels-1 carry a patch
  std::string Validate() const;
};

class MultilevelPatch {
 public:
  MultilevelPatch() = default;

  // Samples the patch around `pixel` (level-0 coordinates) with warp W on every level of
  // `options`, bilinearly, plus the intensity gradients along the patch axes (from a one-sample
  // border). Levels whose samples (with border) leave the image are marked invalid. Returns
  // false when no level is valid.
  bool Extract(const ImagePyramid& pyramid, const Eigen::Vector2d& pixel,
               const Eigen::Matrix2d& warp, const PatchOptions& options);

  int patch_size() const { return patch_size_; }
  int num_levels() const { return num_levels_; }
  bool level_valid(int l) const { return valid_[static_cast<std::size_t>(l)] != 0; }
  // patch_size^2 values of level l, row-major (row = second patch axis).
  const float* intensities(int l) const;
  const float* gradient_x(int l) const;  // d intensity / d o_x
  const float* gradient_y(int l) const;  // d intensity / d o_y

  // Smallest eigenvalue of the structure tensor summed over valid levels, normalized per
  // sample: a Shi-Tomasi score that says how well the patch constrains a 2D position.
  double ShiTomasiScore() const;

 private:
  int patch_size_ = 0;
  int num_levels_ = 0;
  std::vector<unsigned char> valid_;
  std::vector<float> intensities_;  // [level][sample]
  std::vector<float> gradient_x_;
  std::vector<float> gradient_y_;
};

struct PhotometricOptions {
  int min_level = 0;            // use patch levels [min_level, max_level]
  int max_level = 3;
  // Per-level illumination compensation: the image samples are compared with
  // gain * patch + offset, gain and offset solved in closed form (least squares) per level.
  bool compensate_illumination = true;
};

// Residual r_k = I_l(p_l + W o_k) - (gain_l * P_l(o_k) + offset_l) for every sample k of every
// used level whose samples fall inside the image, and its Jacobian with respect to the
// level-0 pixel (N x 2, from the patch gradients mapped through W^-T and scaled by 2^-l). The
// rows are stacked coarse level first. Returns false when no level can be used.
bool ComputePhotometricResidual(const MultilevelPatch& patch, const ImagePyramid& pyramid,
                                const Eigen::Vector2d& pixel, const Eigen::Matrix2d& warp,
                                const PhotometricOptions& options, Eigen::VectorXd* residual,
                                Eigen::Matrix<double, Eigen::Dynamic, 2>* J_residual_pixel);

struct AlignmentResult {
  bool converged = false;
  Eigen::Vector2d pixel = Eigen::Vector2d::Zero();       // level-0
  Eigen::Matrix2d information = Eigen::Matrix2d::Zero();  // J^T J at the solution [1/px^2]
  double mean_abs_error = 0.0;                           // mean |r| at the solution [grey]
  int iterations = 0;
};

// Gauss-Newton alignment of the patch in the image from `initial_pixel`, coarse to fine
// (levels max_level .. min_level), with the warp held fixed. Used to seed features, to
// re-detect lost ones and as an outlier check; the filter itself uses the residual above.
AlignmentResult AlignPatch(const MultilevelPatch& patch, const ImagePyramid& pyramid,
                           const Eigen::Vector2d& initial_pixel, const Eigen::Matrix2d& warp,
                           const PhotometricOptions& options, int max_iterations = 10);

}  // namespace vilma::estimator
