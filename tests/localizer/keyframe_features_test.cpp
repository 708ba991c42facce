#include "vilma/localizer/keyframe_features.h"

#include <catch2/catch.hpp>
#include <cmath>
#include <opencv2/imgproc.hpp>
#include <set>
#include <string>

#include "localizer/synthetic_texture.h"
#include "vilma/core/asl_dataset.h"
#include "vilma/core/error.h"
#include "test_skip.h"

namespace vilma::localizer {
namespace {

void CheckSpread(const KeyframeFeatures& f, const KeyframeFeatureOptions& o, int width,
                 int height) {
  const int cols = o.detector.grid_cols;
  const int rows = o.detector.grid_rows;
  std::vector<int> count(static_cast<std::size_t>(cols * rows), 0);
  for (const cv::KeyPoint& kp : f.keypoints) {
    const int cx = std::min(cols - 1, static_cast<int>((kp.pt.x + 0.5) * cols / width));
    const int cy = std::min(rows - 1, static_cast<int>((kp.pt.y + 0.5) * rows / height));
    ++count[static_cast<std::size_t>(cy * cols + cx)];
  }
  int occupied = 0;
  for (int c : count) {
    CHECK(c <= o.detector.max_per_cell);
    occupied += c > 0 ? 1 : 0;
  }
  // Every cell of a fully textured image gets keypoints.
  CHECK(occupied == cols * rows);
}

TEST_CASE("ExtractFeatures spreads keypoints over the grid with 64-byte BRISK descriptors",
          "[features]") {
  const cv::Mat image = test::TexturedImage(752, 480, 11);
  const std::string type = GENERATE(std::string("orb"), std::string("fast"));
  KeyframeFeatureOptions o;
  o.detector.type = type;
  const KeyframeFeatures f = ExtractFeatures(image, o);
  INFO("detector " << type << ": " << f.size() << " keypoints");
  CHECK(f.size() >= 500);
  CHECK(f.size() <= o.detector.max_keypoints);
  CHECK(f.descriptor_type == "brisk");
  CHECK(f.descriptors.type() == CV_8U);
  CHECK(f.descriptors.cols == 64);
  CHECK(f.descriptors.rows == f.size());
  CheckSpread(f, o, image.cols, image.rows);
  for (std::size_t i = 0; i < f.keypoints.size(); ++i) {
    const cv::KeyPoint& kp = f.keypoints[i];
    CHECK(kp.pt.x >= o.detector.border_px);
    CHECK(kp.pt.y >= o.detector.border_px);
    CHECK(kp.pt.x <= image.cols - 1 - o.detector.border_px);
    CHECK(kp.pt.y <= image.rows - 1 - o.detector.border_px);
    CHECK(kp.size > 0.0f);
    CHECK(kp.angle >= 0.0f);
    if (i > 0) CHECK(kp.response <= f.keypoints[i - 1].response);  // best score first
  }
}

TEST_CASE("ExtractFeatures is deterministic and honours the per-cell and total caps",
          "[features]") {
  const cv::Mat image = test::TexturedImage(752, 480, 12);
  KeyframeFeatureOptions o;
  o.detector.grid_cols = 4;
  o.detector.grid_rows = 3;
  o.detector.max_per_cell = 5;
  const FeatureExtractor extractor(o);
  const KeyframeFeatures a = extractor.Extract(image);
  const KeyframeFeatures b = ExtractFeatures(image.clone(), o);
  REQUIRE(a.size() == b.size());
  CHECK(a.size() == 4 * 3 * 5);
  for (int i = 0; i < a.size(); ++i) {
    const auto u = static_cast<std::size_t>(i);
    CHECK(a.keypoints[u].pt == b.keypoints[u].pt);
    CHECK(a.keypoints[u].angle == b.keypoints[u].angle);
    CHECK(a.keypoints[u].response == b.keypoints[u].response);
  }
  CHECK(cv::norm(a.descriptors, b.descriptors, cv::NORM_HAMMING) == 0.0);
  CheckSpread(a, o, image.cols, image.rows);

  o.detector.max_keypoints = 17;
  const KeyframeFeatures capped = ExtractFeatures(image, o);
  REQUIRE(capped.size() == 17);
  // The cap goes round robin: each of the 12 cells keeps its best, 5 cells also a second.
  std::vector<int> per_cell(12, 0);
  for (const cv::KeyPoint& kp : capped.keypoints) {
    ++per_cell[static_cast<std::size_t>(std::min(2, static_cast<int>(kp.pt.y * 3 / image.rows)) * 4 +
                                        std::min(3, static_cast<int>(kp.pt.x * 4 / image.cols)))];
  }
  for (int c : per_cell) {
    CHECK(c >= 1);
    CHECK(c <= 2);
  }
}

TEST_CASE("SelectGridded keeps the best per cell", "[features]") {
  std::vector<cv::KeyPoint> kps;
  // Cell (0, 0) of a 2x2 grid over 100x100 gets 5 keypoints, cell (1, 1) gets 1.
  for (int i = 0; i < 5; ++i) kps.emplace_back(cv::Point2f(10.f + i, 10.f), 7.f, -1.f, 1.0f * i);
  kps.emplace_back(cv::Point2f(80.f, 80.f), 7.f, -1.f, 0.5f);
  const auto selected = SelectGridded(kps, 100, 100, 2, 2, 2, 100);
  REQUIRE(selected.size() == 3);
  CHECK(selected[0].response == 4.0f);
  CHECK(selected[1].response == 3.0f);
  CHECK(selected[2].response == 0.5f);
  const auto one = SelectGridded(kps, 100, 100, 2, 2, 2, 1);
  REQUIRE(one.size() == 1);
  CHECK(one[0].response == 4.0f);
  // Under the global cap the weak cell keeps its best before the strong cell its second.
  const auto two = SelectGridded(kps, 100, 100, 2, 2, 2, 2);
  REQUIRE(two.size() == 2);
  CHECK(two[0].response == 4.0f);
  CHECK(two[1].response == 0.5f);
  // Suppression: keypoints 1 px apart collapse to the best one with min_distance 1.5.
  const auto sparse = SelectGridded(kps, 100, 100, 2, 2, 10, 100, 1.5);
  REQUIRE(sparse.size() == 4);  // x = 14 (best), 12, 10 and the far one
  CHECK(sparse[0].pt.x == 14.f);
  CHECK(sparse[1].pt.x == 12.f);
}

TEST_CASE("ExtractFeatures rejects non-grey images and handles a blank one", "[features]") {
  const KeyframeFeatureOptions o;
  CHECK_THROWS_AS(ExtractFeatures(cv::Mat(), o), InputError);
  CHECK_THROWS_AS(ExtractFeatures(cv::Mat(480, 752, CV_8UC3, cv::Scalar(1, 2, 3)), o),
                  InputError);
  const KeyframeFeatures blank = ExtractFeatures(cv::Mat(480, 752, CV_8UC1, cv::Scalar(90)), o);
  CHECK(blank.size() == 0);
  CHECK(blank.descriptors.rows == 0);
  KeyframeFeatureOptions bad;
  bad.detector.max_per_cell = 0;
  CHECK_THROWS_AS(FeatureExtractor(bad), InputError);
}

TEST_CASE("ExtractFeatures on a real EuRoC frame fills the grid", "[features]") {
  const std::string root = std::string(VILMA_SHARED_DATA_DIR) + "/euroc_V1_01_micro";
  AslDataset dataset;
  try {
    dataset = AslDataset::Open(root);
  } catch (const std::exception&) {
    VILMA_SKIP("EuRoC slice not found under " VILMA_SHARED_DATA_DIR);
  }
  REQUIRE(!dataset.cameras().empty());
  const cv::Mat image = AslDataset::LoadImage(dataset.cameras()[0].frames[0].image_path);
  const KeyframeFeatureOptions o;
  const KeyframeFeatures f = ExtractFeatures(image, o);
  WARN("EuRoC cam0 frame 0: " << f.size() << " keypoints");
  CHECK(f.size() >= 300);
  // Real images have weak cells (the dark floor); most cells still get keypoints.
  std::set<int> cells;
  for (const auto& kp : f.keypoints) {
    cells.insert(static_cast<int>(kp.pt.y * o.detector.grid_rows / image.rows) * 100 +
                 static_cast<int>(kp.pt.x * o.detector.grid_cols / image.cols));
  }
  CHECK(static_cast<int>(cells.size()) >= o.detector.grid_cols * o.detector.grid_rows * 3 / 4);
}


// A grey image of dark squares on a bright background whose corners lie at known sub-pixel
// positions: drawn 8x larger (fillConvexPoly with 4 fractional bits) and area-averaged down, so
// every pixel holds the covered fraction as a camera pixel integrates light. Pixel centres are
// integers (KeyframeFeatures' convention): the low-resolution point x lies at 8 (x + 0.5) - 0.5
// in the large image.
cv::Mat SquaresImage(int width, int height, const cv::Point2d& offset,
                     std::vector<cv::Point2d>* corners) {
  constexpr int kScale = 8;
  constexpr int kShiftBits = 4;
  cv::Mat large(height * kScale, width * kScale, CV_8UC1, cv::Scalar(190));
  int k = 0;
  for (double cy = 60.0; cy < height - 50.0; cy += 60.0) {
    for (double cx = 60.0; cx < width - 50.0; cx += 60.0, ++k) {
      const double angle = (10.0 + 13.0 * k) * CV_PI / 180.0;  // no corner axis-aligned
      const double half = 14.0;
      std::vector<cv::Point> poly;
      for (int i = 0; i < 4; ++i) {
        const double a = angle + i * CV_PI / 2.0;
        // Corner of the square: centre + half * sqrt(2) along the diagonal.
        const cv::Point2d c(cx + offset.x + half * std::sqrt(2.0) * std::cos(a),
                            cy + offset.y + half * std::sqrt(2.0) * std::sin(a));
        corners->push_back(c);
        const double lx = kScale * (c.x + 0.5) - 0.5;
        const double ly = kScale * (c.y + 0.5) - 0.5;
        poly.emplace_back(cvRound(lx * (1 << kShiftBits)), cvRound(ly * (1 << kShiftBits)));
      }
      cv::fillConvexPoly(large, poly, cv::Scalar(60), cv::LINE_8, kShiftBits);
    }
  }
  cv::Mat image;
  cv::resize(large, image, cv::Size(width, height), 0, 0, cv::INTER_AREA);
  return image;
}

// Per true corner, the error vector (keypoint - corner) of the nearest keypoint within 3 px;
// NaN where no keypoint is that close.
std::vector<cv::Point2d> CornerErrors(const KeyframeFeatures& f,
                                      const std::vector<cv::Point2d>& corners) {
  std::vector<cv::Point2d> errors(corners.size(), cv::Point2d(NAN, NAN));
  std::vector<double> best(corners.size(), 3.0);
  for (const cv::KeyPoint& kp : f.keypoints) {
    for (std::size_t i = 0; i < corners.size(); ++i) {
      const cv::Point2d e(kp.pt.x - corners[i].x, kp.pt.y - corners[i].y);
      if (std::hypot(e.x, e.y) < best[i]) {
        best[i] = std::hypot(e.x, e.y);
        errors[i] = e;
      }
    }
  }
  return errors;
}

struct PositionStats {
  double mean_error = 0.0;      // mean distance to the true corner [px]
  // Mean distance of a corner's error to that corner's mean error over the sub-pixel shifts:
  // the part of the error that changes while the feature moves by less than a pixel [px].
  double mean_variation = 0.0;
  double max_variation = 0.0;
  int corners_found = 0;        // corners found at every shift
  int integral = 0;             // keypoints at integer pixel positions
  int total = 0;                // keypoints
};

struct ShiftedImage {
  cv::Mat image;
  std::vector<cv::Point2d> corners;
};

// The squares image shifted by k/8 px (x) and 0.6 k/8 px (y), k = 0..7, with a camera-like blur.
std::vector<ShiftedImage> ShiftedSquares() {
  constexpr int kShifts = 8;
  std::vector<ShiftedImage> images(kShifts);
  for (int k = 0; k < kShifts; ++k) {
    const double f = static_cast<double>(k) / kShifts;
    ShiftedImage& s = images[static_cast<std::size_t>(k)];
    s.image = SquaresImage(480, 360, cv::Point2d(f, 0.6 * f), &s.corners);
    cv::GaussianBlur(s.image, s.image, cv::Size(0, 0), 0.8);
  }
  return images;
}

PositionStats MeasureOverShifts(const std::vector<ShiftedImage>& images,
                                const KeyframeFeatureOptions& o) {
  const int kShifts = static_cast<int>(images.size());
  std::vector<std::vector<cv::Point2d>> errors;
  PositionStats s;
  int matched = 0;
  for (const ShiftedImage& shifted : images) {
    const std::vector<cv::Point2d>& corners = shifted.corners;
    const KeyframeFeatures features = ExtractFeatures(shifted.image, o);
    s.total += features.size();
    for (const cv::KeyPoint& kp : features.keypoints) {
      if (kp.pt.x == std::round(kp.pt.x) && kp.pt.y == std::round(kp.pt.y)) ++s.integral;
    }
    errors.push_back(CornerErrors(features, corners));
    for (const cv::Point2d& e : errors.back()) {
      if (std::isnan(e.x)) continue;
      s.mean_error += std::hypot(e.x, e.y);
      ++matched;
    }
  }
  if (matched > 0) s.mean_error /= matched;
  int n = 0;
  for (std::size_t c = 0; c < errors[0].size(); ++c) {
    cv::Point2d mean(0.0, 0.0);
    bool all = true;
    for (int k = 0; k < kShifts; ++k) {
      all = all && !std::isnan(errors[static_cast<std::size_t>(k)][c].x);
      if (all) mean += errors[static_cast<std::size_t>(k)][c];
    }
    if (!all) continue;
    ++s.corners_found;
    mean *= 1.0 / kShifts;
    for (int k = 0; k < kShifts; ++k) {
      const cv::Point2d d = errors[static_cast<std::size_t>(k)][c] - mean;
      s.mean_variation += std::hypot(d.x, d.y);
      s.max_variation = std::max(s.max_variation, std::hypot(d.x, d.y));
      ++n;
    }
  }
  if (n > 0) s.mean_variation /= n;
  return s;
}

TEST_CASE("ExtractFeatures: with subpixel corner_subpix a keypoint follows sub-pixel motion",
          "[features]") {
  // The squares shifted by fractions of a pixel. Without refinement the detector returns the
  // same integer pixel while a feature moves by less than a pixel: an error that changes in a
  // saw-tooth along a track and persists between consecutive keyframes (docs/optimization.md,
  // "Street"). The part of the error that stays (FAST fires ~1.5 px inside an L-corner; the
  // Foerstner point of a blurred L-corner lies ~0.2 px inside) moves with the surface and is
  // absorbed by the landmark.
  const std::vector<ShiftedImage> images = ShiftedSquares();
  KeyframeFeatureOptions o;
  o.detector.subpixel = "none";
  const PositionStats integral = MeasureOverShifts(images, o);
  o.detector.subpixel = "corner_subpix";
  const PositionStats refined = MeasureOverShifts(images, o);
  INFO("none: " << integral.corners_found << " corners at every shift, mean error "
                << integral.mean_error << " px, variation mean " << integral.mean_variation
                << " max " << integral.max_variation << " px; corner_subpix: "
                << refined.corners_found << " corners, mean error " << refined.mean_error
                << " px, variation mean " << refined.mean_variation << " max "
                << refined.max_variation << " px");
  // 35 squares, 140 corners.
  CHECK(integral.integral == integral.total);
  CHECK(integral.corners_found >= 40);
  CHECK(integral.mean_variation > 0.25);
  CHECK(integral.mean_error > 1.0);
  CHECK(refined.corners_found >= integral.corners_found);
  CHECK(refined.integral < refined.total / 10);
  CHECK(refined.mean_variation < 0.05);
  CHECK(refined.max_variation < 0.25);
  CHECK(refined.mean_error < 0.3);
}

TEST_CASE("RefineSubpixel keeps a keypoint that would move farther than subpixel_max_shift_px",
          "[features]") {
  std::vector<cv::Point2d> corners;
  const cv::Mat image = SquaresImage(480, 360, cv::Point2d(0.3, 0.2), &corners);
  DetectorOptions d;
  d.subpixel = "corner_subpix";
  d.subpixel_window_px = 3;
  // 1.5 px from a corner along both axes: cornerSubPix pulls it onto the corner (~2.1 px).
  const cv::Point2f start(static_cast<float>(corners[0].x + 1.5),
                          static_cast<float>(corners[0].y + 1.5));
  std::vector<cv::KeyPoint> keypoints{cv::KeyPoint(start, 12.0f)};
  d.subpixel_max_shift_px = 5.0;
  RefineSubpixel(image, d, &keypoints);
  CHECK(std::hypot(keypoints[0].pt.x - corners[0].x, keypoints[0].pt.y - corners[0].y) < 0.15);
  keypoints = {cv::KeyPoint(start, 12.0f)};
  d.subpixel_max_shift_px = 1.0;
  RefineSubpixel(image, d, &keypoints);
  CHECK(keypoints[0].pt == start);
  d.subpixel = "none";
  keypoints = {cv::KeyPoint(start, 12.0f)};
  d.subpixel_max_shift_px = 5.0;
  RefineSubpixel(image, d, &keypoints);
  CHECK(keypoints[0].pt == start);
}

}  // namespace
}  // namespace vilma::localizer
