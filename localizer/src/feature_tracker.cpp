#include "vilma/localizer/feature_tracker.h"
#include "vilma/core/timing.h"

#include <algorithm>
#include <chrono>
#include <climits>
#include <cmath>
#include <opencv2/core/hal/hal.hpp>

namespace vilma::localizer {
namespace {

// Two candidates closer than this are the same image point (ORB finds a corner on several
// pyramid levels); the ratio test compares the best only with distinct points [px].
constexpr double kSamePointPx = 2.0;

}  // namespace

void FeatureTracker::GridIndex::Build(const std::vector<Eigen::Vector2d>& points,
                                      const std::vector<char>& valid, int width, int height,
                                      double cell_size) {
  cell = cell_size;
  cols = std::max(1, static_cast<int>(std::ceil(width / cell)));
  rows = std::max(1, static_cast<int>(std::ceil(height / cell)));
  offsets.assign(static_cast<std::size_t>(cols * rows + 1), 0);
  cell_of.assign(points.size(), -1);
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (!valid[i]) continue;
    const int cx = static_cast<int>(std::floor(points[i].x() / cell));
    const int cy = static_cast<int>(std::floor(points[i].y() / cell));
    if (cx < 0 || cy < 0 || cx >= cols || cy >= rows) continue;
    cell_of[i] = cy * cols + cx;
    ++offsets[static_cast<std::size_t>(cell_of[i] + 1)];
  }
  for (std::size_t c = 1; c < offsets.size(); ++c) offsets[c] += offsets[c - 1];
  items.assign(static_cast<std::size_t>(offsets.back()), -1);
  std::vector<int> fill(offsets.begin(), offsets.end() - 1);
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (cell_of[i] >= 0) items[static_cast<std::size_t>(fill[cell_of[i]]++)] = static_cast<int>(i);
  }
}

FeatureTracker::FeatureTracker(const KeyframeFeatureOptions& options, int64_t first_track_id)
    : options_(options), extractor_(options), next_track_id_(first_track_id) {}

void FeatureTracker::Reset() {
  has_previous_ = false;
  prev_features_ = KeyframeFeatures();
  prev_track_ids_.clear();
  prev_bearings_.clear();
  prev_bearing_valid_.clear();
}

TrackingResult FeatureTracker::Track(const cv::Mat& image, const Camera& camera,
                                     const Eigen::Quaterniond& q_Ck_Ckm1) {
  const auto start = std::chrono::steady_clock::now();
  KeyframeFeatures features = extractor_.Extract(image);
  const double extract_ms = MsSince(start);
  TrackingResult result = TrackFeatures(std::move(features), camera, q_Ck_Ckm1);
  result.extract_ms = extract_ms;
  return result;
}

TrackingResult FeatureTracker::TrackFeatures(KeyframeFeatures features, const Camera& camera,
                                             const Eigen::Quaterniond& q_Ck_Ckm1) {
  const auto start = std::chrono::steady_clock::now();
  TrackingResult result;
  result.features = std::move(features);
  const KeyframeFeatures& cur = result.features;
  const int num_cur = cur.size();
  const int num_prev = has_previous_ ? prev_features_.size() : 0;
  result.num_previous = num_prev;

  // Bearings of the current keypoints (kept for the next call).
  cur_points_.resize(static_cast<std::size_t>(num_cur));
  cur_valid_.assign(static_cast<std::size_t>(num_cur), 0);
  cur_bearings_.resize(static_cast<std::size_t>(num_cur));
  for (int j = 0; j < num_cur; ++j) {
    const auto u = static_cast<std::size_t>(j);
    cur_points_[u] = Eigen::Vector2d(cur.keypoints[u].pt.x, cur.keypoints[u].pt.y);
    cur_valid_[u] = camera.Unproject(cur_points_[u], &cur_bearings_[u]) ? 1 : 0;
  }

  std::vector<FeatureMatch> candidates;
  const bool comparable = num_prev > 0 && num_cur > 0 &&
                          prev_features_.descriptor_type == cur.descriptor_type &&
                          prev_features_.descriptors.cols == cur.descriptors.cols;
  if (comparable) {
    const Eigen::Matrix3d R_Ck_Ckm1 = q_Ck_Ckm1.normalized().toRotationMatrix();
    const double radius = options_.matcher.window_radius_px;
    const double radius2 = radius * radius;
    const int descriptor_bytes = cur.descriptors.cols;

    // Prediction: rotate each previous bearing into the current frame and project it.
    predicted_.resize(static_cast<std::size_t>(num_prev));
    predicted_valid_.assign(static_cast<std::size_t>(num_prev), 0);
    for (int i = 0; i < num_prev; ++i) {
      const auto u = static_cast<std::size_t>(i);
      if (!prev_bearing_valid_[u]) continue;
      const Eigen::Vector3d b_C = R_Ck_Ckm1 * prev_bearings_[u];
      Eigen::Vector2d p;
      if (camera.Project(b_C, &p) != Camera::ProjectionResult::kValid) continue;
      predicted_[u] = p;
      predicted_valid_[u] = 1;
    }
    cur_grid_.Build(cur_points_, cur_valid_, camera.width(), camera.height(), radius);

    // Forward search per previous keypoint; the same (i, j) pairs give the reverse best per
    // current keypoint (the window condition |pred_i - x_j| <= r is symmetric).
    forward_.assign(static_cast<std::size_t>(num_prev), FeatureMatch());
    reverse_best_.assign(static_cast<std::size_t>(num_cur), -1);
    reverse_dist_.assign(static_cast<std::size_t>(num_cur), INT_MAX);
    for (int i = 0; i < num_prev; ++i) {
      const auto u = static_cast<std::size_t>(i);
      if (!predicted_valid_[u]) continue;
      const Eigen::Vector2d& p = predicted_[u];
      const int cx0 = std::max(0, static_cast<int>(std::floor((p.x() - radius) / radius)));
      const int cx1 = std::min(cur_grid_.cols - 1,
                               static_cast<int>(std::floor((p.x() + radius) / radius)));
      const int cy0 = std::max(0, static_cast<int>(std::floor((p.y() - radius) / radius)));
      const int cy1 = std::min(cur_grid_.rows - 1,
                               static_cast<int>(std::floor((p.y() + radius) / radius)));
      const uchar* d_prev = prev_features_.descriptors.ptr<uchar>(i);
      window_.clear();
      for (int cy = cy0; cy <= cy1; ++cy) {
        for (int cx = cx0; cx <= cx1; ++cx) {
          const int c = cy * cur_grid_.cols + cx;
          for (int k = cur_grid_.offsets[static_cast<std::size_t>(c)];
               k < cur_grid_.offsets[static_cast<std::size_t>(c) + 1]; ++k) {
            const int j = cur_grid_.items[static_cast<std::size_t>(k)];
            const auto v = static_cast<std::size_t>(j);
            if ((cur_points_[v] - p).squaredNorm() > radius2) continue;
            const int d =
                cv::hal::normHamming(d_prev, cur.descriptors.ptr<uchar>(j), descriptor_bytes);
            window_.emplace_back(j, d);
            if (d < reverse_dist_[v] || (d == reverse_dist_[v] && i < reverse_best_[v])) {
              reverse_dist_[v] = d;
              reverse_best_[v] = i;
            }
          }
        }
      }
      if (window_.empty()) continue;
      // Best candidate (ties: lowest index, for determinism independent of cell order).
      std::pair<int, int> best = window_[0];
      for (const auto& w : window_) {
        if (w.second < best.second || (w.second == best.second && w.first < best.first)) {
          best = w;
        }
      }
      if (best.second > options_.matcher.max_hamming_distance) continue;
      // Ratio test against the best candidate that is a different image point.
      int second = INT_MAX;
      const Eigen::Vector2d& x_best = cur_points_[static_cast<std::size_t>(best.first)];
      for (const auto& w : window_) {
        if (w.first == best.first) continue;
        if ((cur_points_[static_cast<std::size_t>(w.first)] - x_best).squaredNorm() <
            kSamePointPx * kSamePointPx) {
          continue;
        }
        second = std::min(second, w.second);
      }
      if (second != INT_MAX && !(best.second < options_.matcher.ratio * second)) continue;
      forward_[u] = FeatureMatch{i, best.first, best.second};
    }

    // Mutual check, or (without it) one match per current keypoint: the closest descriptor.
    std::vector<int> taken(static_cast<std::size_t>(num_cur), -1);
    for (int i = 0; i < num_prev; ++i) {
      const FeatureMatch& m = forward_[static_cast<std::size_t>(i)];
      if (m.cur_index < 0) continue;
      const auto v = static_cast<std::size_t>(m.cur_index);
      if (options_.matcher.mutual) {
        if (reverse_best_[v] != i) continue;
        candidates.push_back(m);
      } else {
        if (taken[v] >= 0) {
          FeatureMatch& other = candidates[static_cast<std::size_t>(taken[v])];
          if (m.distance < other.distance) other = m;
          continue;
        }
        taken[v] = static_cast<int>(candidates.size());
        candidates.push_back(m);
      }
    }
    std::sort(candidates.begin(), candidates.end(),
              [](const FeatureMatch& x, const FeatureMatch& y) { return x.cur_index < y.cur_index; });
    result.num_candidates = static_cast<int>(candidates.size());

    // RANSAC on bearings: previous bearings rotated into the current frame vs current ones.
    ransac_a_.resize(candidates.size());
    ransac_f_.resize(candidates.size());
    for (std::size_t k = 0; k < candidates.size(); ++k) {
      ransac_a_[k] = R_Ck_Ckm1 * prev_bearings_[static_cast<std::size_t>(candidates[k].prev_index)];
      ransac_f_[k] = cur_bearings_[static_cast<std::size_t>(candidates[k].cur_index)];
    }
    const double focal = 0.5 * (camera.fx() + camera.fy());
    const TranslationRansacResult ransac = RansacTranslationKnownRotation(
        ransac_a_, ransac_f_, options_.ransac.threshold_px / focal, options_.ransac);
    result.ransac_verified = ransac.verified;
    result.rotation_only = ransac.rotation_only;
    result.t_dir = ransac.t_dir;
    for (std::size_t k = 0; k < candidates.size(); ++k) {
      if (ransac.inliers[k]) result.matches.push_back(candidates[k]);
    }
    result.num_matched = static_cast<int>(result.matches.size());
    result.num_rejected_ransac = result.num_candidates - result.num_matched;
  }

  // Track ids: continued for matches, new (counting up, in keypoint order) for the others.
  result.track_ids.assign(static_cast<std::size_t>(num_cur), -1);
  for (const FeatureMatch& m : result.matches) {
    result.track_ids[static_cast<std::size_t>(m.cur_index)] =
        prev_track_ids_[static_cast<std::size_t>(m.prev_index)];
  }
  for (int64_t& id : result.track_ids) {
    if (id < 0) {
      id = next_track_id_++;
      ++result.num_new;
    }
  }

  // The current keyframe becomes the previous one.
  prev_features_ = result.features;  // cv::Mat shares the descriptor data (read-only here)
  prev_track_ids_ = result.track_ids;
  prev_bearings_.swap(cur_bearings_);
  prev_bearing_valid_.swap(cur_valid_);
  has_previous_ = true;
  result.match_ms = MsSince(start);
  return result;
}

}  // namespace vilma::localizer
