#include "vilma/mapping/track_refinement.h"

#include <Eigen/Dense>
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
  return {};
}

GradientImage GradientImage::FromGrey(const cv::Mat& grey) {
  if (grey.empty() || grey.type() != CV_8UC1) {
    throw std::invalid_argument("GradientImage: expected a non-empty 8-bit grey image");
  }
  GradientImage g;
  grey.convertTo(g.intensity, CV_32F);
  // Central differences: (I(u+1) - I(u-1)) / 2 (Sobel with ksize 1 is [-1 0 1] unscaled).
  cv::Sobel(g.intensity, g.grad_x, CV_32F, 1, 0, 1, 0.5, 0.0, cv::BORDER_REPLICATE);
  cv::Sobel(g.intensity, g.grad_y, CV_32F, 0, 1, 1, 0.5, 0.0, cv::BORDER_REPLICATE);
  return g;
}

bool PatchTemplate::Extract(const GradientImage& image, const Eigen::Vector2d& uv, int h) {
  half_size = h;
  samples.clear();
  samples.reserve(static_cast<std::size_t>((2 * h + 1) * (2 * h + 1)));
  for (int y = -h; y <= h; ++y) {
    for (int x = -h; x <= h; ++x) {
      const double u = uv.x() + x;
      const double v = uv.y() + y;
      if (!Inside(image.intensity, u, v)) return false;
      samples.push_back(Bilinear(image.intensity, u, v));
    }
  }
  return true;
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

PatchAlignment AlignPatchTemplate(const PatchTemplate& patch, const GradientImage& image,
                                  const Eigen::Vector2d& c0, const Eigen::Matrix2d& A0,
                                  const TrackRefinementOptions& options) {
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
  if (out.status != PatchAlignment::Status::kOk) return out;  // not converged
  if ((out.center - c0).norm() > options.max_shift_px) {
    out.status = PatchAlignment::Status::kTooFar;
  } else if (out.rms_error > options.max_error_grey) {
    out.status = PatchAlignment::Status::kLargeError;
  } else if (affine) {
    const Eigen::Vector2d s = Eigen::JacobiSVD<Eigen::Matrix2d>(out.warp).singularValues();
    if (!(s(0) <= options.max_warp_scale && s(1) >= 1.0 / options.max_warp_scale) ||
        out.warp.determinant() <= 0.0) {
      out.status = PatchAlignment::Status::kBadWarp;
    }
  }
  if (out.ok() && !(out.gain > 0.5 && out.gain < 2.0)) out.status = PatchAlignment::Status::kLargeError;
  return out;
}

TrackRefiner::TrackRefiner(const TrackRefinementOptions& options, int64_t split_id_base)
    : options_(options), next_split_id_(split_id_base) {}

void TrackRefiner::Refine(const cv::Mat& image, const std::vector<int64_t>& tracker_ids,
                          std::vector<Eigen::Vector2d>* uv, std::vector<int64_t>* track_ids) {
  track_ids->assign(tracker_ids.begin(), tracker_ids.end());
  if (!options_.enabled()) return;
  const GradientImage gradients = GradientImage::FromGrey(image);
  std::unordered_map<int64_t, Track> next;
  next.reserve(tracker_ids.size());
  const int h = options_.patch_half_size_px;
  for (std::size_t k = 0; k < tracker_ids.size(); ++k) {
    const int64_t tid = tracker_ids[k];
    if (tid < 0) continue;
    const Eigen::Vector2d detected = (*uv)[k];
    const auto it = tracks_.find(tid);
    Track track;
    bool start_new = true;
    if (it != tracks_.end()) {
      track = std::move(it->second);
      if (track.has_patch) {
        const Eigen::Vector2d c0 = track.aligned_uv + (detected - track.detected_uv);
        PatchAlignment a = AlignPatchTemplate(track.patch, gradients, c0, track.warp, options_);
        if (a.ok() && options_.max_offset_px > 0.0 &&
            (a.center - detected).norm() > options_.max_offset_px) {
          a.status = PatchAlignment::Status::kOffset;
        }
        if (a.ok()) {
          (*uv)[k] = a.center;
          track.detected_uv = detected;
          track.aligned_uv = a.center;
          track.warp = a.warp;
          (*track_ids)[k] = track.id;
          ++stats_.refined;
          stats_.shift_sum_px += (a.center - detected).norm();
          start_new = false;
        } else {
          ++stats_.splits;
          ++stats_.split_by_status[static_cast<int>(a.status)];
        }
      }
      // A track whose first observation had no patch (too close to the border) or whose
      // alignment failed continues as a new track from here.
      if (start_new) track.id = next_split_id_++;
    } else {
      track.id = tid;
    }
    if (start_new) {
      track.has_patch = track.patch.Extract(gradients, detected, h);
      track.detected_uv = detected;
      track.aligned_uv = detected;
      track.warp.setIdentity();
      (*track_ids)[k] = track.id;
    }
    next.emplace(tid, std::move(track));
  }
  tracks_ = std::move(next);
}

}  // namespace vilma::mapping
