// Keyframe features: gridded keypoints with 512-bit BRISK descriptors (docs/localizer.md,
// "Keyframe features"). Keypoints are pixel coordinates of the raw (distorted) image with
// (0, 0) at the centre of the top-left pixel, as in core/camera.h.
#pragma once

#include <limits>
#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <string>
#include <vector>

#include "vilma/localizer/feature_options.h"

namespace vilma::localizer {

struct KeyframeFeatures {
  // pt [px], size (diameter of the detection neighbourhood at its pyramid level) [px],
  // angle (BRISK orientation) [deg], response (detector score: Harris or FAST), octave.
  std::vector<cv::KeyPoint> keypoints;
  // One row per keypoint, CV_8U, 64 columns for BRISK (512 bits).
  cv::Mat descriptors;
  std::string descriptor_type = "brisk";

  int size() const { return static_cast<int>(keypoints.size()); }
};

// Holds the OpenCV detector and descriptor objects (building BRISK's sampling pattern takes
// about a millisecond, so a long-lived extractor reuses it). Not thread-safe: one per thread.
class FeatureExtractor {
 public:
  // Throws InputError if options.Validate() fails.
  explicit FeatureExtractor(const KeyframeFeatureOptions& options);

  // `image`: 8-bit single channel. Deterministic: the same image and options give the same
  // features in the same order (sorted by score, best first; ties by position; fill-level
  // keypoints, DetectorOptions::fill_levels, after all others).
  KeyframeFeatures Extract(const cv::Mat& image) const;

  const KeyframeFeatureOptions& options() const { return options_; }

 private:
  // The fill levels' keypoints (DetectorOptions::fill_levels) in `image`'s pixels, inside the
  // border, appended to `keypoints`.
  void AppendFillKeypoints(const cv::Mat& image, std::vector<cv::KeyPoint>* keypoints) const;

  KeyframeFeatureOptions options_;
  cv::Ptr<cv::Feature2D> detector_;
  cv::Ptr<cv::Feature2D> fill_detector_;  // DetectorOptions::fill_levels > 0 only
  cv::Ptr<cv::Feature2D> descriptor_;
};

// Convenience for one-off calls (builds a FeatureExtractor).
KeyframeFeatures ExtractFeatures(const cv::Mat& image, const KeyframeFeatureOptions& options);

// Moves each keypoint to its sub-pixel corner position on `image` (8-bit, the image the
// keypoints were detected in) as options.subpixel says; "none" leaves them. A keypoint whose
// refinement moves farther than subpixel_max_shift_px or leaves the border keeps its position.
void RefineSubpixel(const cv::Mat& image, const DetectorOptions& options,
                    std::vector<cv::KeyPoint>* keypoints);

// Keeps at most `max_per_cell` keypoints per cell of a grid_cols x grid_rows grid over a
// width x height image, best response first, then at most `max_total` overall (best first);
// a keypoint closer than `min_distance` [px] to a better one is dropped. Keypoints of octave
// >= fill_octave (DetectorOptions::fill_levels) come after all others in each of these steps,
// whatever their response. The result is sorted by that tier, then by response (descending),
// ties broken by y, x, size; deterministic. num_before_cap (optional): how many were kept
// before the max_total cap (after the suppression and the cell caps).
std::vector<cv::KeyPoint> SelectGridded(const std::vector<cv::KeyPoint>& keypoints, int width,
                                        int height, int grid_cols, int grid_rows, int max_per_cell,
                                        int max_total, double min_distance = 0.0,
                                        int fill_octave = std::numeric_limits<int>::max(),
                                        int* num_before_cap = nullptr);

}  // namespace vilma::localizer
