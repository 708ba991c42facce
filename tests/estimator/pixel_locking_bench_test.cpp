// Pixel locking of the patch alignment, measured on a real EuRoC frame (hidden; run with
// `vilma_estimator_tests "[.pixel_locking]"`; docs/estimator-stereo-diagnosis.md "Pixel locking
// and a bicubic sampler"). The frame is shifted by a known sub-pixel amount in x (a phase ramp
// in the Fourier domain, i.e. band-limited, then rounded to 8 bits as a camera would); a patch
// cut at each detected corner of the original is aligned in the shifted frame, starting at the
// true position. The mean / median error of the found x says whether the photometric minimum
// is pulled toward the template's own sub-pixel phase (errors against the shift's sign for
// shifts below half a pixel) — with the filter's own sampling, pyramid and illumination model,
// not a re-implementation. VILMA_PIXEL_LOCKING_IMAGE=PNG takes another frame.
#include <catch2/catch.hpp>
#include <Eigen/Core>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <vector>

#include "estimator/synthetic_images.h"
#include "test_skip.h"
#include "vilma/estimator/feature_detector.h"
#include "vilma/estimator/multilevel_patch.h"

namespace vilma::estimator {
namespace {

// Adds zero-mean Gaussian noise of sigma grey levels (fixed seed), rounded and saturated.
cv::Mat WithNoise(const cv::Mat& gray8, double sigma, uint64_t seed) {
  if (sigma <= 0.0) return gray8.clone();
  cv::Mat noise(gray8.size(), CV_64F);
  cv::RNG rng(seed);
  rng.fill(noise, cv::RNG::NORMAL, 0.0, sigma);
  cv::Mat f;
  gray8.convertTo(f, CV_64F);
  cv::Mat out;
  cv::Mat(f + noise).convertTo(out, CV_8U);
  return out;
}

// g(x, y) = f(x - shift_px, y): a phase ramp exp(-2 pi i k_x shift) on the DFT (circular at the
// borders, which the corners stay away from), rounded and clipped to 8 bits.
cv::Mat ShiftX(const cv::Mat& gray8, double shift_px) {
  cv::Mat f;
  gray8.convertTo(f, CV_64F);
  cv::Mat spectrum;
  cv::dft(f, spectrum, cv::DFT_COMPLEX_OUTPUT);
  const int cols = spectrum.cols;
  for (int r = 0; r < spectrum.rows; ++r) {
    auto* row = spectrum.ptr<cv::Vec2d>(r);
    for (int c = 0; c < cols; ++c) {
      const double k = static_cast<double>(c <= cols / 2 ? c : c - cols) / cols;
      const double phase = -2.0 * M_PI * k * shift_px;
      const double re = row[c][0], im = row[c][1];
      row[c][0] = re * std::cos(phase) - im * std::sin(phase);
      row[c][1] = re * std::sin(phase) + im * std::cos(phase);
    }
  }
  cv::Mat shifted;
  cv::idft(spectrum, shifted, cv::DFT_SCALE | cv::DFT_REAL_OUTPUT);
  cv::Mat out;
  shifted.convertTo(out, CV_8U);  // rounds and saturates
  return out;
}

TEST_CASE("patch alignment: sub-pixel shifts of a real frame (pixel locking figures)",
          "[.pixel_locking]") {
  // VILMA_PIXEL_LOCKING_IMAGE=PNG measures on another frame (e.g. a simulated one).
  const char* image_env = std::getenv("VILMA_PIXEL_LOCKING_IMAGE");
  const auto paths = testing::EurocCam0Images();
  if (image_env == nullptr && paths.empty()) {
    VILMA_SKIP("EuRoC slice not found under " VILMA_SHARED_DATA_DIR);
  }
  const std::string path = image_env != nullptr ? std::string(image_env) : paths[0];
  INFO("image " << path);
  std::printf("image %s\n", path.c_str());
  const cv::Mat frame = cv::imread(path, cv::IMREAD_GRAYSCALE);
  REQUIRE(!frame.empty());
  for (const double noise_sigma : {0.0, 2.0}) {
    ImagePyramid original;
    original.Build(WithNoise(frame, noise_sigma, 1), 4);
    const auto corners = DetectFeatures(original, {}, 60, FeatureDetectorOptions());
    std::vector<MultilevelPatch> patches;
    std::vector<Eigen::Vector2d> pixels;
    const double margin = 40.0;
    for (const FeatureCandidate& c : corners) {
      if (c.pixel.x() < margin || c.pixel.y() < margin || c.pixel.x() > frame.cols - margin ||
          c.pixel.y() > frame.rows - margin || c.score < 20.0) {
        continue;
      }
      MultilevelPatch patch;
      if (!patch.Extract(original, c.pixel, Eigen::Matrix2d::Identity(), PatchOptions())) {
        continue;
      }
      patches.push_back(patch);
      pixels.push_back(c.pixel);
    }
    REQUIRE(patches.size() >= 20);
    std::printf("pixel noise sigma %.1f grey levels (template and shifted frame, independent)\n"
                "| shift [px] | patches | converged | mean error [px] | median error [px] |\n"
                "|---|---|---|---|---|\n", noise_sigma);
    for (const double shift : {0.0, 0.1, 0.2, 0.3, 0.5, 0.7, 0.9}) {
      ImagePyramid moved;
      moved.Build(WithNoise(ShiftX(frame, shift), noise_sigma, 2), 4);
      std::vector<double> errors;
      for (std::size_t i = 0; i < patches.size(); ++i) {
        const Eigen::Vector2d truth = pixels[i] + Eigen::Vector2d(shift, 0.0);
        const AlignmentResult r = AlignPatch(patches[i], moved, truth,
                                             Eigen::Matrix2d::Identity(), PhotometricOptions(), 30);
        if (r.converged) errors.push_back(r.pixel.x() - truth.x());
      }
      REQUIRE(errors.size() >= patches.size() * 8 / 10);
      double mean = 0.0;
      for (const double e : errors) mean += e / static_cast<double>(errors.size());
      std::sort(errors.begin(), errors.end());
      const double median = errors[errors.size() / 2];
      std::printf("| %.1f | %zu | %zu | %+.4f | %+.4f |\n", shift, patches.size(), errors.size(),
                  mean, median);
      // The alignment must land near the true shift; the bias itself is the figure.
      CHECK(std::abs(median) < 0.25);
    }
  }
}

}  // namespace
}  // namespace vilma::estimator
