// FAST candidates on several pyramid levels, ranked by the Shi-Tomasi score of the multilevel
// patch they would become, one per free grid bucket, spaced by min_distance_px.
#include "vilma/estimator/feature_detector.h"

#include <algorithm>
#include <cmath>
#include <opencv2/features2d.hpp>
#include <stdexcept>
#include <tuple>

namespace vilma::estimator {
namespace {

struct RawCandidate {
  Eigen::Vector2d pixel;  // level 0
  int level = 0;
  int bucket = 0;
  float response = 0.0f;  // FAST response
  double score = 0.0;     // Shi-Tomasi
};

// Deterministic order for equal keys: by position (row, then column).
bool PositionLess(const RawCandidate& a, const RawCandidate& b) {
  return std::tie(a.pixel.y(), a.pixel.x()) < std::tie(b.pixel.y(), b.pixel.x());
}

}  // namespace

std::string FeatureDetectorOptions::Validate() const {
  if (fast_threshold < 1 || fast_threshold > 254) {
    return "fast_threshold: expected 1 .. 254, got " + std::to_string(fast_threshold);
  }
  if (min_level < 0 || max_level < min_level || max_level > 7) {
    return "min_level/max_level: expected 0 <= min_level <= max_level <= 7, got " +
           std::to_string(min_level) + "/" + std::to_string(max_level);
  }
  if (grid_cols < 1 || grid_rows < 1) {
    return "grid_cols/grid_rows: expected >= 1, got " + std::to_string(grid_cols) + "/" +
           std::to_string(grid_rows);
  }
  if (!(min_distance_px >= 0.0)) return "min_distance_px: expected >= 0";
  if (!std::isfinite(min_shi_tomasi_score)) return "min_shi_tomasi_score: expected finite";
  if (border_px < 0) return "border_px: expected >= 0, got " + std::to_string(border_px);
  if (max_candidates_per_bucket < 0) return "max_candidates_per_bucket: expected >= 0";
  const std::string patch_error = patch.Validate();
  if (!patch_error.empty()) return "patch." + patch_error;
  return {};
}

std::vector<FeatureCandidate> DetectFeatures(const ImagePyramid& pyramid,
                                             const std::vector<Eigen::Vector2d>& occupied,
                                             int max_new, const FeatureDetectorOptions& options) {
  return DetectFeatures(pyramid, occupied, max_new, options, nullptr, 0, nullptr);
}

std::vector<FeatureCandidate> DetectFeatures(
    const ImagePyramid& pyramid, const std::vector<Eigen::Vector2d>& occupied, int max_new,
    const FeatureDetectorOptions& options,
    const std::function<bool(const FeatureCandidate&)>& accept, int max_refusals,
    int* refusals) {
  int refused = 0;
  if (refusals != nullptr) *refusals = 0;
  const std::string error = options.Validate();
  if (!error.empty()) throw std::invalid_argument("DetectFeatures: " + error);
  std::vector<FeatureCandidate> out;
  if (max_new <= 0 || pyramid.num_levels() == 0) return out;

  const int w0 = pyramid.level(0).cols;
  const int h0 = pyramid.level(0).rows;
  const double min_d2 = options.min_distance_px * options.min_distance_px;
  const int num_buckets = options.grid_cols * options.grid_rows;
  auto bucket_of = [&](const Eigen::Vector2d& p) {
    const int bx = std::clamp(static_cast<int>(std::floor(p.x() * options.grid_cols / w0)), 0,
                              options.grid_cols - 1);
    const int by = std::clamp(static_cast<int>(std::floor(p.y() * options.grid_rows / h0)), 0,
                              options.grid_rows - 1);
    return by * options.grid_cols + bx;
  };
  auto far_from = [&](const Eigen::Vector2d& p, const auto& points, auto get) {
    for (const auto& q : points) {
      if ((get(q) - p).squaredNorm() < min_d2) return false;
    }
    return true;
  };

  std::vector<unsigned char> bucket_taken(static_cast<std::size_t>(num_buckets), 0);
  for (const Eigen::Vector2d& p : occupied) {
    if (p.x() >= 0.0 && p.x() < w0 && p.y() >= 0.0 && p.y() < h0) {
      bucket_taken[static_cast<std::size_t>(bucket_of(p))] = 1;
    }
  }

  // 1. FAST on each level; keep candidates inside the border, in free buckets, away from
  //    the tracked features.
  std::vector<RawCandidate> raw;
  std::vector<cv::KeyPoint> keypoints;
  const int top_level = std::min(options.max_level, pyramid.num_levels() - 1);
  const double border = options.border_px;
  for (int l = options.min_level; l <= top_level; ++l) {
    keypoints.clear();
    cv::FAST(pyramid.level(l), keypoints, options.fast_threshold, /*nonmaxSuppression=*/true);
    for (const cv::KeyPoint& kp : keypoints) {
      RawCandidate c;
      c.pixel = ImagePyramid::BaseFromLevel(Eigen::Vector2d(kp.pt.x, kp.pt.y), l);
      if (c.pixel.x() < border || c.pixel.x() > w0 - 1 - border || c.pixel.y() < border ||
          c.pixel.y() > h0 - 1 - border) {
        continue;
      }
      c.level = l;
      c.bucket = bucket_of(c.pixel);
      if (bucket_taken[static_cast<std::size_t>(c.bucket)]) continue;
      if (!far_from(c.pixel, occupied, [](const Eigen::Vector2d& q) { return q; })) continue;
      c.response = kp.response;
      raw.push_back(c);
    }
  }

  // 2. Score only the strongest FAST responses per bucket and level (Shi-Tomasi on a
  //    multilevel patch costs about a microsecond; textured images give thousands of corners).
  if (options.max_candidates_per_bucket > 0) {
    std::sort(raw.begin(), raw.end(), [](const RawCandidate& a, const RawCandidate& b) {
      if (a.bucket != b.bucket) return a.bucket < b.bucket;
      if (a.level != b.level) return a.level < b.level;
      if (a.response != b.response) return a.response > b.response;
      return PositionLess(a, b);
    });
    std::size_t kept = 0;
    int run = 0;
    for (std::size_t i = 0; i < raw.size(); ++i) {
      run = (i > 0 && raw[i].bucket == raw[i - 1].bucket && raw[i].level == raw[i - 1].level)
                ? run + 1
                : 0;
      if (run < options.max_candidates_per_bucket) raw[kept++] = raw[i];
    }
    raw.resize(kept);
  }

  // 3. Shi-Tomasi score of the patch the tracker would extract (identity warp).
  MultilevelPatch patch;
  std::size_t kept = 0;
  for (RawCandidate& c : raw) {
    if (!patch.Extract(pyramid, c.pixel, Eigen::Matrix2d::Identity(), options.patch)) continue;
    c.score = patch.ShiTomasiScore();
    if (!(c.score > 0.0) || c.score < options.min_shi_tomasi_score) continue;
    raw[kept++] = c;
  }
  raw.resize(kept);

  // 4. Best first (ties: finer level, then position), greedy with one per bucket and spacing.
  std::sort(raw.begin(), raw.end(), [](const RawCandidate& a, const RawCandidate& b) {
    if (a.score != b.score) return a.score > b.score;
    if (a.level != b.level) return a.level < b.level;
    return PositionLess(a, b);
  });
  for (const RawCandidate& c : raw) {
    if (static_cast<int>(out.size()) >= max_new) break;
    if (bucket_taken[static_cast<std::size_t>(c.bucket)]) continue;
    if (!far_from(c.pixel, out, [](const FeatureCandidate& f) { return f.pixel; })) continue;
    FeatureCandidate f;
    f.pixel = c.pixel;
    f.level = c.level;
    f.score = c.score;
    if (accept && refused < max_refusals && !accept(f)) {
      ++refused;  // passed over: the next candidate of this bucket may be taken
      continue;
    }
    bucket_taken[static_cast<std::size_t>(c.bucket)] = 1;
    out.push_back(f);
  }
  if (refusals != nullptr) *refusals = refused;
  return out;
}

}  // namespace vilma::estimator
