// The multilevel patch on real EuRoC frames: alignment between two frames of the static start,
// and the front end's microbenchmark (hidden). Split from multilevel_patch_test.cpp (synthetic
// textures) to keep each file under ~600 lines.
#include <catch2/catch.hpp>
#include <Eigen/Core>
#include <algorithm>
#include <chrono>
#include <opencv2/imgcodecs.hpp>
#include <vector>

#include "estimator/synthetic_images.h"
#include "test_skip.h"
#include "vilma/estimator/feature_detector.h"
#include "vilma/estimator/multilevel_patch.h"

namespace vilma::estimator {
namespace {

using JacobianN2 = Eigen::Matrix<double, Eigen::Dynamic, 2>;

TEST_CASE("AlignPatch on two consecutive EuRoC frames finds no motion", "[patch]") {
  // The camera stands still at the start of V1_01: the true motion is zero, up to sensor noise.
  const auto paths = testing::EurocCam0Images();
  if (paths.size() < 2) {
    VILMA_SKIP("EuRoC slice not found under " VILMA_SHARED_DATA_DIR);
  }
  const cv::Mat frame0 = cv::imread(paths[0], cv::IMREAD_GRAYSCALE);
  const cv::Mat frame1 = cv::imread(paths[1], cv::IMREAD_GRAYSCALE);
  REQUIRE(!frame0.empty());
  REQUIRE(!frame1.empty());
  ImagePyramid pyramid0, pyramid1;
  pyramid0.Build(frame0, 4);
  pyramid1.Build(frame1, 4);
  // Features as the tracker picks them: the detector's candidates, of which the filter keeps
  // those with a Shi-Tomasi score of at least 20 (FilterOptions::min_shi_tomasi).
  constexpr double kMinShiTomasi = 20.0;
  const auto features = DetectFeatures(pyramid0, {}, 48, FeatureDetectorOptions());
  REQUIRE(features.size() >= 20);
  std::vector<double> errors;  // features the filter would track
  double worst_all = 0.0;      // every candidate
  int converged = 0;
  for (const FeatureCandidate& f : features) {
    MultilevelPatch patch;
    REQUIRE(patch.Extract(pyramid0, f.pixel, Eigen::Matrix2d::Identity(), PatchOptions()));
    const AlignmentResult result =
        AlignPatch(patch, pyramid1, f.pixel + Eigen::Vector2d(1.2, -0.8),
                   Eigen::Matrix2d::Identity(), PhotometricOptions());
    if (result.converged) ++converged;
    const double error = (result.pixel - f.pixel).norm();
    worst_all = std::max(worst_all, error);
    if (f.score >= kMinShiTomasi) errors.push_back(error);
  }
  REQUIRE(errors.size() >= 20);
  std::sort(errors.begin(), errors.end());
  const double median = errors[errors.size() / 2];
  const double p90 = errors[errors.size() * 9 / 10];
  INFO(features.size() << " candidates, " << converged << " converged, worst " << worst_all
                       << " px; " << errors.size() << " with score >= " << kMinShiTomasi
                       << ": median " << median << " px, 90th percentile " << p90 << " px");
  CHECK(converged == static_cast<int>(features.size()));
  // No gross failure even on the weakest candidates (they drift by tenths of a pixel).
  CHECK(worst_all < 1.0);
  CHECK(median < 0.05);
  CHECK(p90 < 0.1);
}

// Microbenchmark (hidden; run with: vilma_estimator_tests "[.benchmark]").
TEST_CASE("Front-end timings", "[patch][.benchmark]") {
  using Clock = std::chrono::steady_clock;
  const auto paths = testing::EurocCam0Images();
  cv::Mat frame0, frame1;
  if (paths.size() >= 2) {
    frame0 = cv::imread(paths[0], cv::IMREAD_GRAYSCALE);
    frame1 = cv::imread(paths[1], cv::IMREAD_GRAYSCALE);
  } else {
    const testing::SmoothTexture texture(752, 480, 300, 9u);
    frame0 = texture.Render(752, 480);
    frame1 = frame0.clone();
  }
  ImagePyramid pyramid0, pyramid1;
  pyramid0.Build(frame0, 4);
  pyramid1.Build(frame1, 4);
  auto micros = [](Clock::duration d) {
    return std::chrono::duration<double, std::micro>(d).count();
  };
  constexpr int kRuns = 200;
  auto t0 = Clock::now();
  for (int i = 0; i < kRuns; ++i) pyramid1.Build(i % 2 ? frame1 : frame0, 4);
  const double pyramid_us = micros(Clock::now() - t0) / kRuns;

  FeatureDetectorOptions detector;
  std::vector<FeatureCandidate> features;
  t0 = Clock::now();
  for (int i = 0; i < 20; ++i) features = DetectFeatures(pyramid0, {}, 25, detector);
  const double detect_us = micros(Clock::now() - t0) / 20;
  pyramid1.Build(frame1, 4);

  std::vector<MultilevelPatch> patches(features.size());
  t0 = Clock::now();
  for (int i = 0; i < kRuns; ++i) {
    for (std::size_t k = 0; k < features.size(); ++k) {
      patches[k].Extract(pyramid0, features[k].pixel, Eigen::Matrix2d::Identity(),
                         PatchOptions());
    }
  }
  const double extract_us = micros(Clock::now() - t0) / (kRuns * features.size());

  Eigen::VectorXd r;
  JacobianN2 J;
  double sink = 0.0;
  t0 = Clock::now();
  for (int i = 0; i < kRuns; ++i) {
    for (std::size_t k = 0; k < features.size(); ++k) {
      ComputePhotometricResidual(patches[k], pyramid1, features[k].pixel,
                                 Eigen::Matrix2d::Identity(), PhotometricOptions(), &r, &J);
      sink += r(0);
    }
  }
  const double residual_us = micros(Clock::now() - t0) / (kRuns * features.size());

  int iterations = 0;
  t0 = Clock::now();
  for (int i = 0; i < kRuns; ++i) {
    for (std::size_t k = 0; k < features.size(); ++k) {
      const AlignmentResult a =
          AlignPatch(patches[k], pyramid1, features[k].pixel + Eigen::Vector2d(1.2, -0.8),
                     Eigen::Matrix2d::Identity(), PhotometricOptions());
      iterations += a.iterations;
      sink += a.pixel.x();
    }
  }
  const double align_us = micros(Clock::now() - t0) / (kRuns * features.size());
  WARN("752x480, " << features.size() << " features, 6x6 patches on 4 levels:\n"
                   << "  pyramid build (4 levels): " << pyramid_us << " us\n"
                   << "  detection (FAST levels 0-2 + Shi-Tomasi + bucketing): " << detect_us
                   << " us\n"
                   << "  patch extraction: " << extract_us << " us/feature\n"
                   << "  residual + Jacobian: " << residual_us << " us/feature\n"
                   << "  AlignPatch from (1.2, -0.8) px off: " << align_us << " us/feature, "
                   << static_cast<double>(iterations) / (kRuns * features.size())
                   << " iterations\n"
                   << "  (sink " << sink << ")");
}

}  // namespace
}  // namespace vilma::estimator
