#include "vilma/localizer/keyframe_features.h"

#include <catch2/catch.hpp>
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

}  // namespace
}  // namespace vilma::localizer
