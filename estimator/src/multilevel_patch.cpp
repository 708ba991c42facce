// Multilevel patches, photometric residual and Gauss-Newton patch alignment (ROVIO-style).
//
// Jacobian choice: the image gradient at a sample is approximated by the patch gradient mapped
// through the warp, as ROVIO does. With P(o) = I(p_l + W o), chain rule gives
// dP/do = W^T grad I, hence grad I = W^-T dP/do; the patch gradients are central differences
// of the warped samples (one-sample border), which is cheaper than sampling image gradients
// and smoother than the piecewise-constant gradient of the bilinear interpolant. With the
// illumination model I ~ gain * P + offset, grad I ~ gain * W^-T dP/do. On level l,
// d p_l / d p_0 = 2^-l I.
//
// Illumination compensation: per level, gain and offset minimize sum_k (I_k - gain P_k -
// offset)^2 in closed form, so r = (Id - H) I with H the orthogonal projector onto
// span{P, 1}. The exact derivative is therefore d r / d p_0 = (Id - H) d I / d p_0: the
// Jacobian columns are projected the same way (variable projection), which keeps the Jacobian
// consistent with the residual that is actually computed.
#include "vilma/estimator/multilevel_patch.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdint>
#include <stdexcept>
#include <string>

namespace vilma::estimator {
namespace {

constexpr int kMaxPatchSize = 32;
constexpr int kMaxPatchLevels = 8;

// True when the (2 * half + 1) wide grid of offsets {-half .. half}^2 (possibly half-integer)
// mapped by p + W o stays where bilinear interpolation is defined: 0 <= x < cols - 1,
// 0 <= y < rows - 1. The map is affine, so checking the four corners suffices.
bool GridInside(const cv::Mat& image, const Eigen::Vector2d& p, const Eigen::Matrix2d& W,
                double half) {
  const double max_x = static_cast<double>(image.cols - 1);
  const double max_y = static_cast<double>(image.rows - 1);
  for (int sy = -1; sy <= 1; sy += 2) {
    for (int sx = -1; sx <= 1; sx += 2) {
      const Eigen::Vector2d q = p + W * Eigen::Vector2d(sx * half, sy * half);
      if (!(q.x() >= 0.0 && q.x() < max_x && q.y() >= 0.0 && q.y() < max_y)) return false;
    }
  }
  return true;
}

// Bilinear interpolation; the caller guarantees 0 <= x < cols - 1 and 0 <= y < rows - 1.
inline float Bilinear(const std::uint8_t* data, std::size_t stride, double x, double y) {
  const double fx = std::floor(x);
  const double fy = std::floor(y);
  const float ax = static_cast<float>(x - fx);
  const float ay = static_cast<float>(y - fy);
  const std::uint8_t* r0 = data + static_cast<std::size_t>(fy) * stride +
                           static_cast<std::size_t>(fx);
  const std::uint8_t* r1 = r0 + stride;
  const float top = static_cast<float>(r0[0]) + ax * (static_cast<float>(r0[1]) - r0[0]);
  const float bottom = static_cast<float>(r1[0]) + ax * (static_cast<float>(r1[1]) - r1[0]);
  return top + ay * (bottom - top);
}

// Samples a `count` x `count` grid of offsets starting at o = (first, first) with unit steps,
// row-major, at p + W o. No bounds check (see GridInside).
void SampleGrid(const cv::Mat& image, const Eigen::Vector2d& p, const Eigen::Matrix2d& W,
                double first, int count, float* out) {
  const std::uint8_t* data = image.ptr<std::uint8_t>(0);
  const std::size_t stride = image.step[0];
  const Eigen::Vector2d step_x = W.col(0);
  const Eigen::Vector2d step_y = W.col(1);
  Eigen::Vector2d row_start = p + W * Eigen::Vector2d(first, first);
  for (int r = 0; r < count; ++r) {
    Eigen::Vector2d q = row_start;
    for (int c = 0; c < count; ++c) {
      *out++ = Bilinear(data, stride, q.x(), q.y());
      q += step_x;
    }
    row_start += step_y;
  }
}

}  // namespace

std::string PatchOptions::Validate() const {
  if (patch_size < 2 || patch_size > kMaxPatchSize) {
    return "patch_size: expected 2 .. " + std::to_string(kMaxPatchSize) + ", got " +
           std::to_string(patch_size);
  }
  if (num_levels < 1 || num_levels > kMaxPatchLevels) {
    return "num_levels: expected 1 .. " + std::to_string(kMaxPatchLevels) + ", got " +
           std::to_string(num_levels);
  }
  return {};
}

bool MultilevelPatch::Extract(const ImagePyramid& pyramid, const Eigen::Vector2d& pixel,
                              const Eigen::Matrix2d& warp, const PatchOptions& options) {
  const std::string error = options.Validate();
  if (!error.empty()) throw std::invalid_argument("MultilevelPatch::Extract: " + error);
  const int s = options.patch_size;
  const int n = s * s;
  const int ext = s + 2;  // with the one-sample border
  patch_size_ = s;
  num_levels_ = options.num_levels;
  const std::size_t total = static_cast<std::size_t>(num_levels_) * static_cast<std::size_t>(n);
  // resize() keeps the capacity: no allocation after the first patch of this size.
  valid_.resize(static_cast<std::size_t>(num_levels_));
  intensities_.resize(total);
  gradient_x_.resize(total);
  gradient_y_.resize(total);

  float bordered[(kMaxPatchSize + 2) * (kMaxPatchSize + 2)];
  const double half = 0.5 * (s - 1);
  bool any_valid = false;
  for (int l = 0; l < num_levels_; ++l) {
    valid_[static_cast<std::size_t>(l)] = 0;
    if (l >= pyramid.num_levels()) continue;
    const cv::Mat& image = pyramid.level(l);
    const Eigen::Vector2d p_l = ImagePyramid::LevelFromBase(pixel, l);
    if (!GridInside(image, p_l, warp, half + 1.0)) continue;
    SampleGrid(image, p_l, warp, -half - 1.0, ext, bordered);
    float* I = intensities_.data() + static_cast<std::size_t>(l) * n;
    float* gx = gradient_x_.data() + static_cast<std::size_t>(l) * n;
    float* gy = gradient_y_.data() + static_cast<std::size_t>(l) * n;
    for (int r = 0; r < s; ++r) {
      const float* up = bordered + r * ext + 1;
      const float* mid = up + ext;
      const float* down = mid + ext;
      for (int c = 0; c < s; ++c) {
        I[r * s + c] = mid[c];
        gx[r * s + c] = 0.5f * (mid[c + 1] - mid[c - 1]);
        gy[r * s + c] = 0.5f * (down[c] - up[c]);
      }
    }
    valid_[static_cast<std::size_t>(l)] = 1;
    any_valid = true;
  }
  return any_valid;
}

const float* MultilevelPatch::intensities(int l) const {
  return intensities_.data() + static_cast<std::size_t>(l) * patch_size_ * patch_size_;
}
const float* MultilevelPatch::gradient_x(int l) const {
  return gradient_x_.data() + static_cast<std::size_t>(l) * patch_size_ * patch_size_;
}
const float* MultilevelPatch::gradient_y(int l) const {
  return gradient_y_.data() + static_cast<std::size_t>(l) * patch_size_ * patch_size_;
}

// Structure tensor A = sum over valid levels and samples of g g^T (g = patch gradient in
// patch-axis units of its level, as ROVIO), divided by the number of samples; the score is
// lambda_min(A) = (a + c) / 2 - sqrt(((a - c) / 2)^2 + b^2) for A = [a b; b c].
double MultilevelPatch::ShiTomasiScore() const {
  double a = 0.0, b = 0.0, c = 0.0;
  int count = 0;
  const int n = patch_size_ * patch_size_;
  for (int l = 0; l < num_levels_; ++l) {
    if (!level_valid(l)) continue;
    const float* gx = gradient_x(l);
    const float* gy = gradient_y(l);
    for (int k = 0; k < n; ++k) {
      a += static_cast<double>(gx[k]) * gx[k];
      b += static_cast<double>(gx[k]) * gy[k];
      c += static_cast<double>(gy[k]) * gy[k];
    }
    count += n;
  }
  if (count == 0) return 0.0;
  a /= count;
  b /= count;
  c /= count;
  const double half_diff = 0.5 * (a - c);
  return 0.5 * (a + c) - std::sqrt(half_diff * half_diff + b * b);
}

bool ComputePhotometricResidual(const MultilevelPatch& patch, const ImagePyramid& pyramid,
                                const Eigen::Vector2d& pixel, const Eigen::Matrix2d& warp,
                                const PhotometricOptions& options, Eigen::VectorXd* residual,
                                Eigen::Matrix<double, Eigen::Dynamic, 2>* J_residual_pixel) {
  const int s = patch.patch_size();
  const int n = s * s;
  if (s <= 0) return false;
  const int lo = std::max(options.min_level, 0);
  const int hi = std::min({options.max_level, patch.num_levels() - 1, pyramid.num_levels() - 1,
                           kMaxPatchLevels - 1});
  const double det = warp.determinant();
  if (!(std::abs(det) > 1e-12)) return false;
  const double half = 0.5 * (s - 1);

  // First pass: which levels can be used (valid in the patch, samples inside the image).
  bool usable[kMaxPatchLevels] = {};
  int num_usable = 0;
  for (int l = hi; l >= lo; --l) {
    if (!patch.level_valid(l)) continue;
    if (!GridInside(pyramid.level(l), ImagePyramid::LevelFromBase(pixel, l), warp, half)) continue;
    usable[l] = true;
    ++num_usable;
  }
  if (num_usable == 0) return false;
  const Eigen::Index rows = static_cast<Eigen::Index>(num_usable) * n;
  // Eigen's resize() does not reallocate when the size is unchanged.
  residual->resize(rows);
  if (J_residual_pixel != nullptr) J_residual_pixel->resize(rows, 2);

  const Eigen::Matrix2d W_inv_T = warp.inverse().transpose();
  float sampled[kMaxPatchSize * kMaxPatchSize];
  Eigen::Index row = 0;
  for (int l = hi; l >= lo; --l) {
    if (!usable[l]) continue;
    SampleGrid(pyramid.level(l), ImagePyramid::LevelFromBase(pixel, l), warp, -half, s, sampled);
    const float* P = patch.intensities(l);

    // Closed-form illumination fit I ~ gain * P + offset (least squares over this level).
    double gain = 1.0;
    double offset = 0.0;
    double mean_P = 0.0;
    double var_P = 0.0;  // sum of squared deviations
    bool fit_gain = false;
    if (options.compensate_illumination) {
      double mean_I = 0.0;
      for (int k = 0; k < n; ++k) {
        mean_P += P[k];
        mean_I += sampled[k];
      }
      mean_P /= n;
      mean_I /= n;
      double cov = 0.0;
      for (int k = 0; k < n; ++k) {
        const double dP = P[k] - mean_P;
        var_P += dP * dP;
        cov += dP * (sampled[k] - mean_I);
      }
      // A (nearly) flat patch does not determine a gain: only the offset is fitted.
      fit_gain = var_P > 1e-6 * n;
      gain = fit_gain ? cov / var_P : 1.0;
      offset = mean_I - gain * mean_P;
    }
    for (int k = 0; k < n; ++k) {
      (*residual)(row + k) = static_cast<double>(sampled[k]) - (gain * P[k] + offset);
    }

    if (J_residual_pixel != nullptr) {
      // d r / d p_0 ~ gain * 2^-l * W^-T dP/do, then projected like the residual.
      const Eigen::Matrix2d M = (gain / static_cast<double>(1 << l)) * W_inv_T;
      const float* gx = patch.gradient_x(l);
      const float* gy = patch.gradient_y(l);
      for (int k = 0; k < n; ++k) {
        const double ox = gx[k];
        const double oy = gy[k];
        (*J_residual_pixel)(row + k, 0) = M(0, 0) * ox + M(0, 1) * oy;
        (*J_residual_pixel)(row + k, 1) = M(1, 0) * ox + M(1, 1) * oy;
      }
      if (options.compensate_illumination) {
        // v <- v - a P - c with (a, c) the least-squares fit of v on {P, 1}:
        // (v - mean v) - a (P - mean P), a = sum (P - mean P) v / var_P.
        for (int col = 0; col < 2; ++col) {
          double* v = J_residual_pixel->col(col).data() + row;  // column-major: contiguous
          double mean_v = 0.0;
          for (int k = 0; k < n; ++k) mean_v += v[k];
          mean_v /= n;
          double a = 0.0;
          if (fit_gain) {
            for (int k = 0; k < n; ++k) a += (P[k] - mean_P) * v[k];
            a /= var_P;
          }
          for (int k = 0; k < n; ++k) v[k] = v[k] - mean_v - a * (P[k] - mean_P);
        }
      }
    }
    row += n;
  }
  return true;
}

AlignmentResult AlignPatch(const MultilevelPatch& patch, const ImagePyramid& pyramid,
                           const Eigen::Vector2d& initial_pixel, const Eigen::Matrix2d& warp,
                           const PhotometricOptions& options, int max_iterations) {
  AlignmentResult result;
  result.pixel = initial_pixel;
  const int lo = std::max(options.min_level, 0);
  const int hi = std::min({options.max_level, patch.num_levels() - 1, pyramid.num_levels() - 1,
                           kMaxPatchLevels - 1});
  if (hi < lo || max_iterations < 1) return result;
  // Per-thread buffers: no heap allocation per call after warm-up.
  thread_local Eigen::VectorXd r;
  thread_local Eigen::Matrix<double, Eigen::Dynamic, 2> J;

  // Coarse to fine: stage L uses levels [L, hi]. Each stage runs Gauss-Newton until the step
  // is below 0.01 * 2^(L - lo) level-0 px (0.01 px on the finest stage: a coarse stage cannot
  // resolve finer steps anyway), at most max_iterations steps per stage. Single-level stages
  // (classic pyramidal Lucas-Kanade) were tried: a 6x6 patch on one fine level of a smooth
  // texture is too weakly conditioned and diverges; the joint stages keep the coarse levels'
  // conditioning at the price of their small interpolation bias.
  bool final_stage_converged = false;
  for (int L = hi; L >= lo; --L) {
    PhotometricOptions stage = options;
    stage.min_level = L;
    stage.max_level = hi;
    const double tolerance = 0.01 * static_cast<double>(1 << (L - lo));
    bool stage_converged = false;
    for (int it = 0; it < max_iterations; ++it) {
      if (!ComputePhotometricResidual(patch, pyramid, result.pixel, warp, stage, &r, &J)) {
        if (it == 0 && L != lo) break;  // no usable level in this stage: go finer
        return result;
      }
      // Gauss-Newton: (J^T J) delta = -J^T r.
      const Eigen::Matrix2d H = J.transpose() * J;
      const Eigen::Vector2d g = J.transpose() * r;
      const double det_H = H.determinant();
      if (!(det_H > 1e-9 * (H.trace() * H.trace() + 1e-12))) return result;  // degenerate
      Eigen::Vector2d delta = -(H.inverse() * g);
      // Trust region: the linearization holds within about one pixel of the stage's finest
      // level; longer Gauss-Newton steps (weak or aliased texture on the coarse levels) jump
      // to a wrong minimum far away instead of walking down the cost.
      const double max_step = static_cast<double>(1 << L);
      const double step = delta.norm();
      if (step > max_step) delta *= max_step / step;
      result.pixel += delta;
      ++result.iterations;
      if (!std::isfinite(result.pixel.x()) || !std::isfinite(result.pixel.y())) return result;
      if (delta.norm() < tolerance) {
        stage_converged = true;
        break;
      }
    }
    if (L == lo) final_stage_converged = stage_converged;
  }
  PhotometricOptions final_options = options;
  final_options.min_level = lo;
  final_options.max_level = hi;
  if (!ComputePhotometricResidual(patch, pyramid, result.pixel, warp, final_options, &r, &J)) {
    return result;
  }
  result.information = J.transpose() * J;
  result.mean_abs_error = r.cwiseAbs().mean();
  result.converged = final_stage_converged;
  return result;
}

}  // namespace vilma::estimator
