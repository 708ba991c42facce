#include "vilma/mapping/track_refinement.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <stdexcept>
#include <utility>

#include <opencv2/imgproc.hpp>

namespace vilma::mapping {
namespace {

bool Finite(double v) { return std::isfinite(v); }

// Bilinear sample of a CV_32F image at (u, v); the caller keeps (u, v) inside
// [0, cols - 1) x [0, rows - 1).
inline float Bilinear(const cv::Mat& m, double u, double v) {
  const int x = static_cast<int>(std::floor(u));
  const int y = static_cast<int>(std::floor(v));
  const float a = static_cast<float>(u - x);
  const float b = static_cast<float>(v - y);
  const float* r0 = m.ptr<float>(y) + x;
  const float* r1 = m.ptr<float>(y + 1) + x;
  return (1.0f - b) * ((1.0f - a) * r0[0] + a * r0[1]) + b * ((1.0f - a) * r1[0] + a * r1[1]);
}

// True when a bilinear sample at (u, v) and the gradient behind it are inside the image.
inline bool Inside(const cv::Mat& m, double u, double v) {
  return u >= 1.0 && v >= 1.0 && u < m.cols - 2.0 && v < m.rows - 2.0;
}

// The checks after an alignment (either solver): not converged stays, then too far, large
// error, bad warp, gain out of (0.5, 2).
void CheckConverged(const Eigen::Vector2d& c0, bool affine, const TrackRefinementOptions& options,
                    PatchAlignment* out) {
  if (out->status != PatchAlignment::Status::kOk) return;  // not converged
  if ((out->center - c0).norm() > options.max_shift_px) {
    out->status = PatchAlignment::Status::kTooFar;
  } else if (out->rms_error > options.max_error_grey) {
    out->status = PatchAlignment::Status::kLargeError;
  } else if (affine) {
    const Eigen::Vector2d s = Eigen::JacobiSVD<Eigen::Matrix2d>(out->warp).singularValues();
    if (!(s(0) <= options.max_warp_scale && s(1) >= 1.0 / options.max_warp_scale) ||
        out->warp.determinant() <= 0.0) {
      out->status = PatchAlignment::Status::kBadWarp;
    }
  }
  if (out->ok() && !(out->gain > 0.5 && out->gain < 2.0)) {
    out->status = PatchAlignment::Status::kLargeError;
  }
}

}  // namespace

std::string TrackRefinementOptions::Validate() const {
  if (method != "none" && method != "translation" && method != "affine") {
    return "method: expected \"none\", \"translation\" or \"affine\", got \"" + method + "\"";
  }
  if (patch_half_size_px < 2 || patch_half_size_px > 20) {
    return "patch_half_size_px: expected in [2, 20]";
  }
  if (max_iterations < 1) return "max_iterations: expected >= 1";
  if (!(Finite(convergence_px) && convergence_px > 0)) return "convergence_px: expected > 0";
  if (!(Finite(max_shift_px) && max_shift_px > 0)) return "max_shift_px: expected > 0";
  if (!(Finite(max_offset_px) && max_offset_px >= 0)) return "max_offset_px: expected >= 0";
  if (!(Finite(max_error_grey) && max_error_grey > 0)) return "max_error_grey: expected > 0";
  if (!(Finite(max_warp_scale) && max_warp_scale > 1)) return "max_warp_scale: expected > 1";
  if (!(Finite(keypoint_sigma_px) && keypoint_sigma_px > 0)) {
    return "keypoint_sigma_px: expected > 0";
  }
  if (on_failure != "keep" && on_failure != "reanchor" && on_failure != "split") {
    return "on_failure: expected \"keep\", \"reanchor\" or \"split\", got \"" + on_failure + "\"";
  }
  return {};
}

GradientImage GradientImage::FromGrey(const cv::Mat& grey, bool with_gradients) {
  if (grey.empty() || grey.type() != CV_8UC1) {
    throw std::invalid_argument("GradientImage: expected a non-empty 8-bit grey image");
  }
  GradientImage g;
  grey.convertTo(g.intensity, CV_32F);
  if (!with_gradients) return g;
  // Central differences: (I(u+1) - I(u-1)) / 2 (Sobel with ksize 1 is [-1 0 1] unscaled).
  cv::Sobel(g.intensity, g.grad_x, CV_32F, 1, 0, 1, 0.5, 0.0, cv::BORDER_REPLICATE);
  cv::Sobel(g.intensity, g.grad_y, CV_32F, 0, 1, 1, 0.5, 0.0, cv::BORDER_REPLICATE);
  return g;
}

bool PatchTemplate::Extract(const GradientImage& image, const Eigen::Vector2d& uv, int h) {
  if (!Sample(image, uv, h)) return false;
  Prepare();
  return true;
}

bool PatchTemplate::Sample(const GradientImage& image, const Eigen::Vector2d& uv, int h) {
  half_size = h;
  prepared = affine_ok = translation_ok = false;
  const cv::Mat& m = image.intensity;
  // Inside() for every sample is Inside() for the extreme ones (the grid is axis-aligned).
  if (!Inside(m, uv.x() - h, uv.y() - h) || !Inside(m, uv.x() + h, uv.y() + h)) return false;
  // A (2 h + 3)^2 grid of bilinear samples at uv + (x, y), x, y in [-h - 1, h + 1], all with
  // the same weights: the samples T are its interior, the central-difference gradients the
  // differences of its neighbours. Inside() keeps u - 1 and u + 1 (v too) inside the image,
  // where the bilinear sample of the central-difference image equals the central difference of
  // bilinear samples (both are linear filters), i.e. what sampling GradientImage::grad_x gives.
  const int w = 2 * h + 3;
  const int x0 = static_cast<int>(std::floor(uv.x())) - h - 1;
  const int y0 = static_cast<int>(std::floor(uv.y())) - h - 1;
  const float a = static_cast<float>(uv.x() - std::floor(uv.x()));
  const float b = static_cast<float>(uv.y() - std::floor(uv.y()));
  std::vector<float> grid(static_cast<std::size_t>(w * w));
  for (int y = 0; y < w; ++y) {
    const float* r0 = m.ptr<float>(y0 + y) + x0;
    const float* r1 = m.ptr<float>(y0 + y + 1) + x0;
    for (int x = 0; x < w; ++x) {
      grid[static_cast<std::size_t>(y * w + x)] =
          (1.0f - b) * ((1.0f - a) * r0[x] + a * r0[x + 1]) +
          b * ((1.0f - a) * r1[x] + a * r1[x + 1]);
    }
  }
  const int side = 2 * h + 1;
  samples.resize(static_cast<std::size_t>(side * side));
  gradients.resize(2 * samples.size());
  std::size_t k = 0;
  for (int y = 1; y <= side; ++y) {
    for (int x = 1; x <= side; ++x, ++k) {
      const float* g = &grid[static_cast<std::size_t>(y * w + x)];
      samples[k] = g[0];
      gradients[2 * k] = 0.5f * (g[1] - g[-1]);
      gradients[2 * k + 1] = 0.5f * (g[w] - g[-w]);
    }
  }
  return true;
}

void PatchTemplate::Prepare() {
  const int h = half_size;
  const std::size_t n = samples.size();
  prepared = true;
  affine_ok = translation_ok = false;
  double sum = 0.0;
  for (const float t : samples) sum += t;
  mean = sum / static_cast<double>(n);
  centered_sq = 0.0;
  for (const float t : samples) centered_sq += (t - mean) * (t - mean);
  // SD columns before the projection: grad T dW/dp at p = 0 (W(o; p) = c + (1 + dA) o), and
  // their means and inner products with T - mean.
  steepest_descent.resize(6 * n);
  double col_sum[6] = {}, col_dot[6] = {};
  std::size_t k = 0;
  for (int y = -h; y <= h; ++y) {
    for (int x = -h; x <= h; ++x, ++k) {
      const double gx = gradients[2 * k], gy = gradients[2 * k + 1];
      const double col[6] = {gx, gy, gx * x, gx * y, gy * x, gy * y};
      const double t = samples[k] - mean;
      for (int j = 0; j < 6; ++j) {
        steepest_descent[6 * k + static_cast<std::size_t>(j)] = static_cast<float>(col[j]);
        col_sum[j] += col[j];
        col_dot[j] += col[j] * t;
      }
    }
  }
  if (!(centered_sq > 0.0)) return;  // a flat patch: nothing to align
  // Project out span{1, T - mean}: v - mean(v) - <v, T~> / |T~|^2 T~; H = SD^T SD from the
  // stored (float) values, so that H^-1 SD^T is consistent.
  double col_mean[6], col_f[6];
  for (int j = 0; j < 6; ++j) {
    col_mean[j] = col_sum[j] / static_cast<double>(n);
    col_f[j] = col_dot[j] / centered_sq;
  }
  Eigen::Matrix<double, 6, 6> H = Eigen::Matrix<double, 6, 6>::Zero();
  for (std::size_t i = 0; i < n; ++i) {
    const double t = samples[i] - mean;
    float* row = &steepest_descent[6 * i];
    double r[6];
    for (int j = 0; j < 6; ++j) {
      row[j] = static_cast<float>(row[j] - col_mean[j] - col_f[j] * t);
      r[j] = row[j];
    }
    for (int j = 0; j < 6; ++j) {
      for (int l = j; l < 6; ++l) H(j, l) += r[j] * r[l];
    }
  }
  H.triangularView<Eigen::StrictlyLower>() = H.transpose();
  const Eigen::LDLT<Eigen::Matrix<double, 6, 6>> ldlt6(H);
  if (ldlt6.info() == Eigen::Success && ldlt6.isPositive() && ldlt6.vectorD().minCoeff() > 0.0) {
    hessian_inv_affine = ldlt6.solve(Eigen::Matrix<double, 6, 6>::Identity());
    affine_ok = hessian_inv_affine.allFinite();
  }
  const Eigen::Matrix2d H2 = H.topLeftCorner<2, 2>();
  if (H2(0, 0) > 0.0 && H2.determinant() > 0.0) {
    hessian_inv_translation = H2.inverse();
    translation_ok = hessian_inv_translation.allFinite();
  }
}

const char* PatchAlignmentStatusName(PatchAlignment::Status status) {
  switch (status) {
    case PatchAlignment::Status::kOk: return "ok";
    case PatchAlignment::Status::kLeftImage: return "left the image";
    case PatchAlignment::Status::kNotConverged: return "not converged";
    case PatchAlignment::Status::kTooFar: return "too far";
    case PatchAlignment::Status::kLargeError: return "large error";
    case PatchAlignment::Status::kBadWarp: return "bad warp";
    case PatchAlignment::Status::kSingular: return "singular";
    case PatchAlignment::Status::kOffset: return "offset from the detector";
  }
  return "?";
}

PatchAlignment AlignPatchTemplateForwardAdditive(const PatchTemplate& patch,
                                                 const GradientImage& image,
                                                 const Eigen::Vector2d& c0,
                                                 const Eigen::Matrix2d& A0,
                                                 const TrackRefinementOptions& options) {
  if (image.grad_x.empty() || image.grad_y.empty()) {
    throw std::invalid_argument("AlignPatchTemplateForwardAdditive: the image has no gradients");
  }
  // Parameters x = [c_u, c_v, A00, A01, A10, A11, g, b] (affine) or [c_u, c_v, g, b].
  const bool affine = options.method == "affine";
  const int n = affine ? 8 : 4;
  const int h = patch.half_size;
  PatchAlignment out;
  out.center = c0;
  out.warp = affine ? A0 : Eigen::Matrix2d::Identity();
  Eigen::Matrix<double, 8, 8> H;
  Eigen::Matrix<double, 8, 1> rhs, J;
  double sum_r2 = 0.0;
  int count = 0;
  for (int it = 0; it < options.max_iterations; ++it) {
    out.iterations = it + 1;
    H.setZero();
    rhs.setZero();
    J.setZero();
    sum_r2 = 0.0;
    count = 0;
    std::size_t k = 0;
    for (int y = -h; y <= h; ++y) {
      for (int x = -h; x <= h; ++x, ++k) {
        const double u = out.center.x() + out.warp(0, 0) * x + out.warp(0, 1) * y;
        const double v = out.center.y() + out.warp(1, 0) * x + out.warp(1, 1) * y;
        if (!Inside(image.intensity, u, v)) {
          out.status = PatchAlignment::Status::kLeftImage;
          return out;
        }
        const double I = Bilinear(image.intensity, u, v);
        const double gx = Bilinear(image.grad_x, u, v);
        const double gy = Bilinear(image.grad_y, u, v);
        const double T = patch.samples[k];
        const double r = I - (out.gain * T + out.offset);
        J(0) = gx;
        J(1) = gy;
        if (affine) {
          J(2) = gx * x;
          J(3) = gx * y;
          J(4) = gy * x;
          J(5) = gy * y;
          J(6) = -T;
          J(7) = -1.0;
        } else {
          J(2) = -T;
          J(3) = -1.0;
        }
        H.topLeftCorner(n, n).noalias() += J.head(n) * J.head(n).transpose();
        rhs.head(n) -= J.head(n) * r;
        sum_r2 += r * r;
        ++count;
      }
    }
    const Eigen::MatrixXd Hn = H.topLeftCorner(n, n);
    Eigen::LDLT<Eigen::MatrixXd> ldlt(Hn);
    if (ldlt.info() != Eigen::Success || !ldlt.isPositive()) {
      out.status = PatchAlignment::Status::kSingular;
      return out;
    }
    const Eigen::VectorXd dx = ldlt.solve(rhs.head(n));
    if (!dx.allFinite()) {
      out.status = PatchAlignment::Status::kSingular;
      return out;
    }
    out.center += dx.head<2>();
    double step = dx.head<2>().norm();
    if (affine) {
      Eigen::Matrix2d dA;
      dA << dx(2), dx(3), dx(4), dx(5);
      out.warp += dA;
      // The farthest patch corner's move: |dc| + |dA| h (spectral norm bound by Frobenius).
      step += dA.norm() * h;
      out.gain += dx(6);
      out.offset += dx(7);
    } else {
      out.gain += dx(2);
      out.offset += dx(3);
    }
    if (step < options.convergence_px) {
      out.status = PatchAlignment::Status::kOk;
      break;
    }
  }
  out.rms_error = count > 0 ? std::sqrt(sum_r2 / count) : 0.0;
  CheckConverged(c0, affine, options, &out);
  return out;
}

PatchAlignment AlignPatchTemplate(const PatchTemplate& patch, const GradientImage& image,
                                  const Eigen::Vector2d& c0, const Eigen::Matrix2d& A0,
                                  const TrackRefinementOptions& options) {
  const bool affine = options.method == "affine";
  const int h = patch.half_size;
  PatchAlignment out;
  out.center = c0;
  out.warp = affine ? A0 : Eigen::Matrix2d::Identity();
  if (!patch.prepared) {
    throw std::logic_error(
        "AlignPatchTemplate: the template is not prepared (PatchTemplate::Prepare)");
  }
  if (!(affine ? patch.affine_ok : patch.translation_ok)) {
    out.status = PatchAlignment::Status::kSingular;
    return out;
  }
  const cv::Mat& m = image.intensity;
  const float* sd = patch.steepest_descent.data();
  const float* T = patch.samples.data();
  const float T_mean = static_cast<float>(patch.mean);
  const double n = static_cast<double>(patch.samples.size());
  double sum_r2 = 0.0;
  for (int it = 0; it < options.max_iterations; ++it) {
    out.iterations = it + 1;
    const double cu = out.center.x(), cv = out.center.y();
    const double a00 = out.warp(0, 0), a01 = out.warp(0, 1);
    const double a10 = out.warp(1, 0), a11 = out.warp(1, 1);
    // The warped patch is a parallelogram: inside when its four corners are.
    bool inside = true;
    for (const int sy : {-h, h}) {
      for (const int sx : {-h, h}) {
        inside = inside && Inside(m, cu + a00 * sx + a01 * sy, cv + a10 * sx + a11 * sy);
      }
    }
    if (!inside) {
      out.status = PatchAlignment::Status::kLeftImage;
      return out;
    }
    // One pass: I at the warped samples, the sums for the gain and offset regression on T and
    // b = SD^T I (SD^T T = SD^T 1 = 0: the error image's template part drops out). Sums over a
    // row in float, over rows in double.
    double s_i = 0.0, s_ii = 0.0, s_it = 0.0;
    double b[6] = {};
    std::size_t k = 0;
    for (int y = -h; y <= h; ++y) {
      const double row_u = cu + a01 * y - a00 * h, row_v = cv + a11 * y - a10 * h;
      float r_i = 0.0f, r_ii = 0.0f, r_it = 0.0f;
      float r_b[6] = {};
      for (int j = 0; j <= 2 * h; ++j, ++k) {
        const double u = row_u + a00 * j;
        const double v = row_v + a10 * j;
        const int xi = static_cast<int>(u);  // u, v >= 1: truncation is floor
        const int yi = static_cast<int>(v);
        const float fa = static_cast<float>(u - xi);
        const float fb = static_cast<float>(v - yi);
        const float* r0 = m.ptr<float>(yi) + xi;
        const float* r1 = m.ptr<float>(yi + 1) + xi;
        const float I = (1.0f - fb) * ((1.0f - fa) * r0[0] + fa * r0[1]) +
                        fb * ((1.0f - fa) * r1[0] + fa * r1[1]);
        const float* s = sd + 6 * k;
        r_i += I;
        r_ii += I * I;
        r_it += I * (T[k] - T_mean);
        r_b[0] += s[0] * I;
        r_b[1] += s[1] * I;
        if (affine) {
          r_b[2] += s[2] * I;
          r_b[3] += s[3] * I;
          r_b[4] += s[4] * I;
          r_b[5] += s[5] * I;
        }
      }
      s_i += r_i;
      s_ii += r_ii;
      s_it += r_it;
      for (int j = 0; j < 6; ++j) b[j] += r_b[j];
    }
    // Gain and offset for this warp (least squares of I on T), and the residual they leave.
    out.gain = s_it / patch.centered_sq;
    out.offset = s_i / n - out.gain * patch.mean;
    sum_r2 = std::max(0.0, (s_ii - s_i * s_i / n) - s_it * s_it / patch.centered_sq);
    // The template's gradient is seen scaled by the gain: divide it out (clamped to where the
    // result is accepted at all).
    const double g = std::min(2.0, std::max(0.5, out.gain));
    Eigen::Vector2d dc;
    Eigen::Matrix2d dA = Eigen::Matrix2d::Zero();
    if (affine) {
      const Eigen::Matrix<double, 6, 1> dp =
          patch.hessian_inv_affine * Eigen::Map<const Eigen::Matrix<double, 6, 1>>(b) / g;
      dc = dp.head<2>();
      dA << dp(2), dp(3), dp(4), dp(5);
    } else {
      dc = patch.hessian_inv_translation * Eigen::Vector2d(b[0], b[1]) / g;
    }
    // W(p) <- W(p) o W(dp)^-1, W(o; dp) = dc + (1 + dA) o: A' = A (1 + dA)^-1, c' = c - A' dc.
    const Eigen::Matrix2d M = Eigen::Matrix2d::Identity() + dA;
    const double det = M.determinant();
    if (!(std::abs(det) > 1e-9) || !dc.allFinite() || !dA.allFinite()) {
      out.status = PatchAlignment::Status::kSingular;
      return out;
    }
    const Eigen::Matrix2d A_new = out.warp * M.inverse();
    const Eigen::Vector2d c_new = out.center - A_new * dc;
    // The farthest patch corner's move, as in the forward additive solver.
    const double step = (c_new - out.center).norm() + (A_new - out.warp).norm() * h;
    out.center = c_new;
    if (affine) out.warp = A_new;
    if (step < options.convergence_px) {
      out.status = PatchAlignment::Status::kOk;
      break;
    }
  }
  out.rms_error = std::sqrt(sum_r2 / n);
  CheckConverged(c0, affine, options, &out);
  return out;
}

TrackRefiner::TrackRefiner(const TrackRefinementOptions& options, int64_t split_id_base)
    : options_(options), next_split_id_(split_id_base) {}

void TrackRefiner::Refine(const cv::Mat& image, const std::vector<int64_t>& tracker_ids,
                          std::vector<Eigen::Vector2d>* uv, std::vector<int64_t>* track_ids,
                          std::vector<RefinedKeypoint>* kinds) {
  track_ids->assign(tracker_ids.begin(), tracker_ids.end());
  if (kinds != nullptr) kinds->assign(tracker_ids.size(), RefinedKeypoint::kReference);
  if (!options_.enabled()) return;
  const bool forward_additive = solver_ == Solver::kForwardAdditive;
  const bool split = options_.on_failure == "split";
  const bool reanchor = options_.on_failure == "reanchor";
  const GradientImage gradients = GradientImage::FromGrey(image, forward_additive);
  std::unordered_map<int64_t, Track>& next = next_;
  next.clear();
  next.reserve(tracker_ids.size());
  const int h = options_.patch_half_size_px;
  for (std::size_t k = 0; k < tracker_ids.size(); ++k) {
    const int64_t tid = tracker_ids[k];
    if (tid < 0) continue;
    const Eigen::Vector2d detected = (*uv)[k];
    const auto it = tracks_.find(tid);
    Track track;
    RefinedKeypoint kind = RefinedKeypoint::kReference;
    bool start_new = true;
    if (it != tracks_.end()) {
      track = std::move(it->second);
      // The start: the previous stored point moved by the detector's motion.
      const Eigen::Vector2d c0 = track.aligned_uv + (detected - track.detected_uv);
      bool aligned = false;
      if (track.has_patch) {
        // The inverse compositional data only for tracks that continue (most never do).
        if (!forward_additive && !track.patch.prepared) track.patch.Prepare();
        PatchAlignment a =
            forward_additive ? AlignPatchTemplateForwardAdditive(track.patch, gradients, c0,
                                                                 track.warp, options_)
                             : AlignPatchTemplate(track.patch, gradients, c0, track.warp, options_);
        if (a.ok() && options_.max_offset_px > 0.0 &&
            (a.center - detected).norm() > options_.max_offset_px) {
          a.status = PatchAlignment::Status::kOffset;
        }
        if (a.ok()) {
          (*uv)[k] = a.center;
          track.detected_uv = detected;
          track.aligned_uv = a.center;
          track.warp = a.warp;
          ++stats_.refined;
          stats_.shift_sum_px += (a.center - detected).norm();
          aligned = true;
          kind = RefinedKeypoint::kAligned;
        } else {
          ++stats_.failed_by_status[static_cast<int>(a.status)];
          if (split) {
            ++stats_.splits;
          } else {
            ++stats_.kept;
          }
        }
      }
      if (aligned) {
        start_new = false;
      } else if (!split) {
        // Kept in its track at c0 (consistent with the track up to the detector's noise). The
        // warp stays (the next alignment starts from it). "reanchor", or a track without a
        // template yet (its first observation too close to the border): a template here.
        (*uv)[k] = c0;
        track.detected_uv = detected;
        track.aligned_uv = c0;
        kind = RefinedKeypoint::kUnaligned;
        if (reanchor || !track.has_patch) {
          track.has_patch = track.patch.Sample(gradients, c0, h);
          track.warp.setIdentity();
        }
        start_new = false;
      } else {
        // "split": a track whose first observation had no patch (too close to the border) or
        // whose alignment failed continues as a new track from here.
        track.id = next_split_id_++;
      }
    } else {
      track.id = tid;
    }
    if (start_new) {
      track.has_patch = track.patch.Sample(gradients, detected, h);
      track.detected_uv = detected;
      track.aligned_uv = detected;
      track.warp.setIdentity();
      // Without a template the first observation cannot anchor its track (kept modes: the
      // detector's noise; "split": the reference, as before).
      if (!track.has_patch && !split) kind = RefinedKeypoint::kUnaligned;
    }
    (*track_ids)[k] = track.id;
    if (kinds != nullptr) (*kinds)[k] = kind;
    next.emplace(tid, std::move(track));
  }
  std::swap(tracks_, next_);
}

}  // namespace vilma::mapping
