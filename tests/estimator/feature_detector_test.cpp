#include "vilma/estimator/feature_detector.h"

#include <algorithm>
#include <catch2/catch.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "estimator/synthetic_images.h"
#include "test_skip.h"

namespace vilma::estimator {
namespace {

// Overlapping rectangles of random grey levels: plenty of FAST corners everywhere.
cv::Mat RectanglesImage(int width, int height, std::uint32_t seed) {
  cv::Mat image(height, width, CV_8UC1, cv::Scalar(128));
  std::uint32_t state = seed;
  auto next = [&state](int lo, int hi) {
    state = state * 1664525u + 1013904223u;
    return lo + static_cast<int>((state >> 8) % static_cast<std::uint32_t>(hi - lo + 1));
  };
  for (int i = 0; i < 400; ++i) {
    const int x = next(-20, width);
    const int y = next(-20, height);
    cv::rectangle(image, cv::Rect(x, y, next(8, 60), next(8, 60)), cv::Scalar(next(20, 235)),
                  cv::FILLED);
  }
  cv::GaussianBlur(image, image, cv::Size(3, 3), 0.8);
  return image;
}

int BucketOf(const Eigen::Vector2d& p, const FeatureDetectorOptions& o, int w, int h) {
  const int bx = std::min(static_cast<int>(p.x() * o.grid_cols / w), o.grid_cols - 1);
  const int by = std::min(static_cast<int>(p.y() * o.grid_rows / h), o.grid_rows - 1);
  return by * o.grid_cols + bx;
}

void CheckSpreadAndSpacing(const std::vector<FeatureCandidate>& features,
                           const std::vector<Eigen::Vector2d>& occupied,
                           const FeatureDetectorOptions& o, int w, int h) {
  std::vector<int> buckets;
  for (const Eigen::Vector2d& p : occupied) buckets.push_back(BucketOf(p, o, w, h));
  for (std::size_t i = 0; i < features.size(); ++i) {
    const FeatureCandidate& f = features[i];
    INFO("feature " << i << " at " << f.pixel.transpose());
    CHECK(f.pixel.x() >= o.border_px);
    CHECK(f.pixel.y() >= o.border_px);
    CHECK(f.pixel.x() <= w - 1 - o.border_px);
    CHECK(f.pixel.y() <= h - 1 - o.border_px);
    CHECK(f.level >= o.min_level);
    CHECK(f.level <= o.max_level);
    CHECK(f.score > o.min_shi_tomasi_score);
    if (i > 0) CHECK(f.score <= features[i - 1].score);
    const int b = BucketOf(f.pixel, o, w, h);
    CHECK(std::find(buckets.begin(), buckets.end(), b) == buckets.end());
    buckets.push_back(b);
    for (const Eigen::Vector2d& q : occupied) CHECK((q - f.pixel).norm() >= o.min_distance_px);
    for (std::size_t j = 0; j < i; ++j) {
      CHECK((features[j].pixel - f.pixel).norm() >= o.min_distance_px);
    }
  }
}

TEST_CASE("Detector spreads features over the buckets with spacing", "[detector]") {
  const cv::Mat image = RectanglesImage(752, 480, 11u);
  ImagePyramid pyramid;
  pyramid.Build(image, 4);
  FeatureDetectorOptions options;
  REQUIRE(options.Validate().empty());
  const auto features = DetectFeatures(pyramid, {}, 100, options);
  const int num_buckets = options.grid_cols * options.grid_rows;
  // One per bucket at most; a textured image fills almost every bucket.
  CHECK(static_cast<int>(features.size()) <= num_buckets);
  CHECK(static_cast<int>(features.size()) >= num_buckets * 3 / 4);
  CheckSpreadAndSpacing(features, {}, options, 752, 480);

  SECTION("max_new caps the count and keeps the best") {
    const auto few = DetectFeatures(pyramid, {}, 5, options);
    REQUIRE(few.size() == 5);
    for (int i = 0; i < 5; ++i) CHECK(few[i].pixel == features[i].pixel);
  }
  SECTION("a high score threshold rejects everything") {
    FeatureDetectorOptions strict = options;
    strict.min_shi_tomasi_score = 1e9;
    CHECK(DetectFeatures(pyramid, {}, 100, strict).empty());
  }
}

TEST_CASE("Detector keeps away from tracked features and their buckets", "[detector]") {
  const cv::Mat image = RectanglesImage(752, 480, 23u);
  ImagePyramid pyramid;
  pyramid.Build(image, 4);
  FeatureDetectorOptions options;
  const auto first = DetectFeatures(pyramid, {}, 100, options);
  REQUIRE(first.size() > 20);
  std::vector<Eigen::Vector2d> occupied;
  for (std::size_t i = 0; i < first.size(); i += 2) occupied.push_back(first[i].pixel);
  occupied.push_back(Eigen::Vector2d(376.0, 240.0));
  const auto second = DetectFeatures(pyramid, occupied, 100, options);
  CHECK(!second.empty());
  CheckSpreadAndSpacing(second, occupied, options, 752, 480);
}

// The test of each candidate (the filter's stereo.candidates_per_slot): a refused candidate is
// passed over and the next-best candidate of its bucket may take the bucket; after max_refusals
// refusals candidates are taken untested.
TEST_CASE("Detector passes over refused candidates, up to max_refusals", "[detector]") {
  const cv::Mat image = RectanglesImage(752, 480, 11u);
  ImagePyramid pyramid;
  pyramid.Build(image, 4);
  FeatureDetectorOptions options;
  const auto plain = DetectFeatures(pyramid, {}, 100, options);
  REQUIRE(plain.size() > 20);
  int refusals = -1;
  // Accepting everything changes nothing.
  const auto all = DetectFeatures(
      pyramid, {}, 100, options, [](const FeatureCandidate&) { return true; }, 10, &refusals);
  CHECK(refusals == 0);
  REQUIRE(all.size() == plain.size());
  for (std::size_t i = 0; i < all.size(); ++i) CHECK(all[i].pixel == plain[i].pixel);
  // Refusing the best candidate: another of its bucket takes its place, the rest is unchanged.
  const Eigen::Vector2d best = plain[0].pixel;
  auto not_best = [&best](const FeatureCandidate& c) { return c.pixel != best; };
  const auto without = DetectFeatures(pyramid, {}, 100, options, not_best, 1, &refusals);
  CHECK(refusals == 1);
  const int best_bucket = BucketOf(best, options, 752, 480);
  int in_bucket = 0;
  for (const FeatureCandidate& c : without) {
    CHECK(c.pixel != best);
    if (BucketOf(c.pixel, options, 752, 480) == best_bucket) ++in_bucket;
  }
  CHECK(in_bucket == 1);
  CheckSpreadAndSpacing(without, {}, options, 752, 480);
  // With no refusals left the refused candidate is taken untested, as without the test.
  const auto none_left = DetectFeatures(pyramid, {}, 100, options, not_best, 0, &refusals);
  CHECK(refusals == 0);
  REQUIRE(!none_left.empty());
  CHECK(none_left[0].pixel == best);
  // Refusing the left half of the image: up to max_refusals candidates there are passed over.
  auto right_half = [](const FeatureCandidate& c) { return c.pixel.x() >= 376.0; };
  const auto right = DetectFeatures(pyramid, {}, 100, options, right_half, 1000, &refusals);
  CHECK(refusals > 0);
  REQUIRE(!right.empty());
  for (const FeatureCandidate& c : right) CHECK(c.pixel.x() >= 376.0);
  const auto some = DetectFeatures(pyramid, {}, 100, options, right_half, 3, &refusals);
  CHECK(refusals == 3);
  CHECK(std::any_of(some.begin(), some.end(),
                    [](const FeatureCandidate& c) { return c.pixel.x() < 376.0; }));
}

TEST_CASE("Detector is deterministic", "[detector]") {
  const cv::Mat image = RectanglesImage(752, 480, 5u);
  FeatureDetectorOptions options;
  options.min_level = 0;
  options.max_level = 3;
  ImagePyramid a;
  ImagePyramid b;
  a.Build(image, 4);
  b.Build(image.clone(), 4);
  const auto fa = DetectFeatures(a, {}, 40, options);
  const auto fb = DetectFeatures(b, {}, 40, options);
  REQUIRE(fa.size() == fb.size());
  REQUIRE(!fa.empty());
  for (std::size_t i = 0; i < fa.size(); ++i) {
    CHECK(fa[i].pixel == fb[i].pixel);
    CHECK(fa[i].level == fb[i].level);
    CHECK(fa[i].score == fb[i].score);
  }
}

TEST_CASE("Detector options are validated", "[detector]") {
  FeatureDetectorOptions o;
  CHECK(o.Validate().empty());
  o.max_level = -1;
  CHECK(o.Validate().find("max_level") != std::string::npos);
  o = FeatureDetectorOptions();
  o.grid_cols = 0;
  CHECK(!o.Validate().empty());
  o = FeatureDetectorOptions();
  o.patch.patch_size = 1;
  CHECK(o.Validate().find("patch.patch_size") != std::string::npos);
  ImagePyramid pyramid;
  pyramid.Build(cv::Mat(64, 64, CV_8UC1, cv::Scalar(0)), 2);
  CHECK_THROWS_AS(DetectFeatures(pyramid, {}, 10, o), std::invalid_argument);
  CHECK(DetectFeatures(pyramid, {}, 10, FeatureDetectorOptions()).empty());  // flat image
}

TEST_CASE("Detector finds at least 20 features on a EuRoC cam0 frame", "[detector]") {
  const auto paths = testing::EurocCam0Images();
  if (paths.empty()) {
    VILMA_SKIP("EuRoC slice not found under " VILMA_SHARED_DATA_DIR);
  }
  const cv::Mat image = cv::imread(paths.front(), cv::IMREAD_GRAYSCALE);
  REQUIRE(!image.empty());
  ImagePyramid pyramid;
  pyramid.Build(image, 4);
  FeatureDetectorOptions options;
  const auto features = DetectFeatures(pyramid, {}, 48, options);
  INFO("found " << features.size());
  CHECK(features.size() >= 20);
  CheckSpreadAndSpacing(features, {}, options, image.cols, image.rows);
}

}  // namespace
}  // namespace vilma::estimator
