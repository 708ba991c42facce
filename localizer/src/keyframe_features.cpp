#include "vilma/localizer/keyframe_features.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <tuple>

#include "vilma/core/error.h"

namespace vilma::localizer {
namespace {

// Total order so that the selection does not depend on the detector's output order.
bool BetterKeypoint(const cv::KeyPoint& a, const cv::KeyPoint& b) {
  if (a.response != b.response) return a.response > b.response;
  if (a.pt.y != b.pt.y) return a.pt.y < b.pt.y;
  if (a.pt.x != b.pt.x) return a.pt.x < b.pt.x;
  if (a.size != b.size) return a.size < b.size;
  return a.octave < b.octave;
}

// True when the descriptor pattern would not fit: closer than border_px to the image border.
bool OutsideBorder(const cv::KeyPoint& kp, const cv::Mat& image, int border_px) {
  const float b = static_cast<float>(border_px);
  return kp.pt.x < b || kp.pt.y < b || kp.pt.x > static_cast<float>(image.cols - 1) - b ||
         kp.pt.y > static_cast<float>(image.rows - 1) - b;
}

// The fill levels' pyramid runs on the image scaled by 1 / scale_factor^num_levels.
double FillScale(const DetectorOptions& d) { return std::pow(d.scale_factor, d.num_levels); }

}  // namespace

void RefineSubpixel(const cv::Mat& image, const DetectorOptions& options,
                    std::vector<cv::KeyPoint>* keypoints) {
  if (options.subpixel == "none" || keypoints->empty()) return;
  std::vector<cv::Point2f> points;
  points.reserve(keypoints->size());
  for (const cv::KeyPoint& kp : *keypoints) points.push_back(kp.pt);
  // cornerSubPix solves sum_i (g_i g_i^T) q = sum_i (g_i g_i^T) p_i over the window's pixels
  // p_i with gradients g_i (a corner point q makes every g_i orthogonal to p_i - q), Gaussian
  // weighted, re-centred at q until the step is below 0.01 px. Each keypoint is refined on its
  // own; the others do not move it.
  const int w = options.subpixel_window_px;
  cv::cornerSubPix(image, points, cv::Size(w, w), cv::Size(-1, -1),
                   cv::TermCriteria(cv::TermCriteria::COUNT | cv::TermCriteria::EPS, 20, 0.01));
  const float b = static_cast<float>(options.border_px);
  const double max_shift2 = options.subpixel_max_shift_px * options.subpixel_max_shift_px;
  for (std::size_t i = 0; i < points.size(); ++i) {
    cv::KeyPoint& kp = (*keypoints)[i];
    const cv::Point2f& q = points[i];
    const cv::Point2f d = q - kp.pt;
    // Not a corner (an edge slides along itself, a blob has no stable point), or outside the
    // border: keep the detector's position.
    if (!std::isfinite(q.x) || !std::isfinite(q.y) ||
        static_cast<double>(d.dot(d)) > max_shift2 || q.x < b || q.y < b ||
        q.x > static_cast<float>(image.cols - 1) - b ||
        q.y > static_cast<float>(image.rows - 1) - b) {
      continue;
    }
    kp.pt = q;
  }
}

std::vector<cv::KeyPoint> SelectGridded(const std::vector<cv::KeyPoint>& keypoints, int width,
                                        int height, int grid_cols, int grid_rows, int max_per_cell,
                                        int max_total, double min_distance, int fill_octave,
                                        int* num_before_cap) {
  // Fill keypoints (octave >= fill_octave) after all others: in the suppression, in each
  // cell's ranking and in the global cap.
  const auto is_fill = [fill_octave](const cv::KeyPoint& kp) { return kp.octave >= fill_octave; };
  std::vector<cv::KeyPoint> sorted = keypoints;
  std::sort(sorted.begin(), sorted.end(), [&](const cv::KeyPoint& a, const cv::KeyPoint& b) {
    if (is_fill(a) != is_fill(b)) return !is_fill(a);
    return BetterKeypoint(a, b);
  });
  std::vector<int> cell_count(static_cast<std::size_t>(grid_cols * grid_rows), 0);
  std::vector<cv::KeyPoint> selected;
  const double cell_w = static_cast<double>(width) / grid_cols;
  const double cell_h = static_cast<double>(height) / grid_rows;
  // 1. Non-maximum suppression, best first: drop a keypoint closer than min_distance to a
  // better one kept before. Occupancy grid with cells of side min_distance: such a neighbour
  // lies in one of the 3x3 cells around.
  std::vector<cv::KeyPoint> kept;
  kept.reserve(sorted.size());
  if (min_distance > 0.0) {
    const double occ = min_distance;
    const int occ_cols = static_cast<int>(std::ceil((width + 1) / occ)) + 1;
    const int occ_rows = static_cast<int>(std::ceil((height + 1) / occ)) + 1;
    std::vector<std::vector<int>> occupancy(static_cast<std::size_t>(occ_cols * occ_rows));
    const double min_distance2 = min_distance * min_distance;
    for (const cv::KeyPoint& kp : sorted) {
      const int ox = std::clamp(static_cast<int>((kp.pt.x + 0.5) / occ), 0, occ_cols - 1);
      const int oy = std::clamp(static_cast<int>((kp.pt.y + 0.5) / occ), 0, occ_rows - 1);
      bool close = false;
      for (int y = std::max(0, oy - 1); y <= std::min(occ_rows - 1, oy + 1) && !close; ++y) {
        for (int x = std::max(0, ox - 1); x <= std::min(occ_cols - 1, ox + 1) && !close; ++x) {
          for (int other : occupancy[static_cast<std::size_t>(y * occ_cols + x)]) {
            const cv::Point2f d = kept[static_cast<std::size_t>(other)].pt - kp.pt;
            if (static_cast<double>(d.dot(d)) < min_distance2) {
              close = true;
              break;
            }
          }
        }
      }
      if (close) continue;
      occupancy[static_cast<std::size_t>(oy * occ_cols + ox)].push_back(
          static_cast<int>(kept.size()));
      kept.push_back(kp);
    }
  } else {
    kept = sorted;
  }
  // 2. Rank of each keypoint within its cell (0 = best); at most max_per_cell per cell.
  std::vector<std::tuple<int, int, int>> rank_index;  // (fill tier, rank in cell, index in `kept`)
  rank_index.reserve(kept.size());
  for (std::size_t i = 0; i < kept.size(); ++i) {
    const cv::KeyPoint& kp = kept[i];
    const int cx = std::clamp(static_cast<int>((kp.pt.x + 0.5) / cell_w), 0, grid_cols - 1);
    const int cy = std::clamp(static_cast<int>((kp.pt.y + 0.5) / cell_h), 0, grid_rows - 1);
    int& count = cell_count[static_cast<std::size_t>(cy * grid_cols + cx)];
    if (count >= max_per_cell) continue;
    rank_index.emplace_back(is_fill(kp) ? 1 : 0, count++, static_cast<int>(i));
  }
  // 3. The global cap takes every cell's best, then every cell's second best, ... so that
  // weakly textured cells keep their best keypoints ("round robin"); within a rank, best
  // score first (indices follow the score order). Fill keypoints only after all others.
  if (num_before_cap) *num_before_cap = static_cast<int>(rank_index.size());
  std::sort(rank_index.begin(), rank_index.end());
  if (static_cast<int>(rank_index.size()) > max_total) {
    rank_index.resize(static_cast<std::size_t>(max_total));
  }
  std::sort(rank_index.begin(), rank_index.end(),
            [](const auto& a, const auto& b) { return std::get<2>(a) < std::get<2>(b); });
  for (const auto& ri : rank_index) {
    selected.push_back(kept[static_cast<std::size_t>(std::get<2>(ri))]);
  }
  return selected;
}

FeatureExtractor::FeatureExtractor(const KeyframeFeatureOptions& options) : options_(options) {
  ThrowIfInvalid(options.Validate(), "keyframe feature options");
  const DetectorOptions& d = options.detector;
  if (d.type == "orb") {
    // ORB keeps `nfeatures` over its pyramid by Harris score; ask for a few times the final
    // count so that the grid selection has candidates in weakly textured cells too.
    const int edge = std::max(d.border_px, 3);
    detector_ = cv::ORB::create(std::max(8 * d.max_keypoints, 2000),
                                static_cast<float>(d.scale_factor), d.num_levels, edge,
                                /*firstLevel=*/0, /*WTA_K=*/2, cv::ORB::HARRIS_SCORE,
                                /*patchSize=*/31, d.fast_threshold);
  } else {
    detector_ = cv::FastFeatureDetector::create(d.fast_threshold, /*nonmaxSuppression=*/true,
                                                cv::FastFeatureDetector::TYPE_9_16);
  }
  if (d.type == "orb" && d.fill_levels > 0) {
    // The fill levels as a pyramid of their own on the image scaled by 1 / s^num_levels, so
    // that the first levels' detections stay exactly those without fill levels (ORB shares
    // its feature budget among its levels).
    const int edge = std::max(static_cast<int>(std::ceil(d.border_px / FillScale(d))), 3);
    fill_detector_ = cv::ORB::create(std::max(8 * d.max_keypoints, 2000),
                                     static_cast<float>(d.scale_factor), d.fill_levels, edge,
                                     /*firstLevel=*/0, /*WTA_K=*/2, cv::ORB::HARRIS_SCORE,
                                     /*patchSize=*/31, d.fast_threshold);
  }
  descriptor_ = cv::BRISK::create(/*thresh=*/30, /*octaves=*/0, /*patternScale=*/1.0f);
}

KeyframeFeatures FeatureExtractor::Extract(const cv::Mat& image) const {
  if (image.empty() || image.type() != CV_8UC1) {
    throw InputError(FormatInputError("ExtractFeatures", "image",
                                      "a non-empty 8-bit single-channel image"));
  }
  const DetectorOptions& d = options_.detector;
  std::vector<cv::KeyPoint> detected;
  detector_->detect(image, detected);
  // Border: the descriptor pattern must fit; BRISK would silently drop keypoints otherwise.
  detected.erase(
      std::remove_if(detected.begin(), detected.end(),
                     [&](const cv::KeyPoint& kp) { return OutsideBorder(kp, image, d.border_px); }),
      detected.end());
  KeyframeFeatures features;
  features.descriptor_type = options_.descriptor.type;
  int first_level_kept = 0;  // after suppression and the cell caps, before max_keypoints
  features.keypoints = SelectGridded(detected, image.cols, image.rows, d.grid_cols, d.grid_rows,
                                     d.max_per_cell, d.max_keypoints, d.min_distance_px,
                                     std::numeric_limits<int>::max(), &first_level_kept);
  if (fill_detector_ && first_level_kept < d.fill_below_keypoints) {
    // A close-up: select again with the fill levels' keypoints ranked after these.
    AppendFillKeypoints(image, &detected);
    features.keypoints =
        SelectGridded(detected, image.cols, image.rows, d.grid_cols, d.grid_rows, d.max_per_cell,
                      d.max_keypoints, d.min_distance_px, d.num_levels);
  }
  RefineSubpixel(image, d, &features.keypoints);
  // Score is the detector's; BRISK overwrites the angle with its own orientation and removes
  // keypoints whose (scaled) pattern leaves the image; the order of the others is kept.
  const float base_size = static_cast<float>(options_.descriptor.keypoint_size_px);
  for (cv::KeyPoint& kp : features.keypoints) {
    kp.size = options_.descriptor.scale_with_level
                  ? base_size * static_cast<float>(std::pow(d.scale_factor, std::max(kp.octave, 0)))
                  : base_size;
  }
  descriptor_->compute(image, features.keypoints, features.descriptors);
  if (features.keypoints.empty()) features.descriptors = cv::Mat(0, 64, CV_8U);
  return features;
}

void FeatureExtractor::AppendFillKeypoints(const cv::Mat& image,
                                           std::vector<cv::KeyPoint>* keypoints) const {
  const DetectorOptions& d = options_.detector;
  const double fill_scale = FillScale(d);
  cv::Mat small;
  cv::resize(image, small,
             cv::Size(std::max(1, static_cast<int>(std::lround(image.cols / fill_scale))),
                      std::max(1, static_cast<int>(std::lround(image.rows / fill_scale)))),
             0.0, 0.0, cv::INTER_AREA);
  std::vector<cv::KeyPoint> fill;
  fill_detector_->detect(small, fill);
  // Back in the full image: (0, 0) is the centre of the top-left pixel at both scales, so
  // x_full = (x_small + 0.5) s - 0.5; the octave continues the first levels' numbering.
  const float sx = static_cast<float>(image.cols) / static_cast<float>(small.cols);
  const float sy = static_cast<float>(image.rows) / static_cast<float>(small.rows);
  for (cv::KeyPoint kp : fill) {
    kp.pt.x = (kp.pt.x + 0.5f) * sx - 0.5f;
    kp.pt.y = (kp.pt.y + 0.5f) * sy - 0.5f;
    kp.size *= sx;
    kp.octave = std::max(kp.octave, 0) + d.num_levels;
    if (!OutsideBorder(kp, image, d.border_px)) keypoints->push_back(kp);
  }
}

KeyframeFeatures ExtractFeatures(const cv::Mat& image, const KeyframeFeatureOptions& options) {
  return FeatureExtractor(options).Extract(image);
}

}  // namespace vilma::localizer
