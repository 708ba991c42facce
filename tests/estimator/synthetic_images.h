// Smooth synthetic textures for the front-end tests: Gaussian blobs on a low-frequency
// sinusoid, rendered through an arbitrary pixel map so that tests can shift, rotate, scale and
// relight the same scene exactly. Deterministic (own LCG, no std distributions).
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <string>
#include <vector>

namespace vilma::estimator::testing {

class SmoothTexture {
 public:
  // Blobs of sigma [min_sigma, max_sigma] px scattered over [0, width] x [0, height] (plus a
  // margin so that warped renderings stay textured).
  SmoothTexture(int width, int height, int num_blobs, std::uint32_t seed, double min_sigma = 5.0,
                double max_sigma = 14.0, double min_amplitude = 15.0,
                double max_amplitude = 35.0) {
    state_ = seed;
    for (int i = 0; i < num_blobs; ++i) {
      Blob b;
      // y before x: GCC's order of the former one-call form (docs/testing.md "Random test data").
      const double c_y = Uniform(-0.2 * height, 1.2 * height);
      const double c_x = Uniform(-0.2 * width, 1.2 * width);
      b.c = Eigen::Vector2d(c_x, c_y);
      b.sigma = Uniform(min_sigma, max_sigma);
      b.amplitude = (i % 2 == 0 ? 1.0 : -1.0) * Uniform(min_amplitude, max_amplitude);
      blobs_.push_back(b);
    }
  }

  // Adds a plaid of three plane waves (wavelengths 64, 76, 90 px in three directions) of the
  // given amplitude: smooth on every pyramid level, yet with gradients well above the 8-bit
  // quantization on level 0.
  SmoothTexture& WithPlaid(double amplitude, double wavelength_scale = 1.0) {
    plaid_wavelength_scale_ = wavelength_scale;
    plaid_amplitude_ = amplitude;
    return *this;
  }

  // Texture value (grey levels, about 110 +- (3 * plaid amplitude + blobs)) at a point.
  double operator()(const Eigen::Vector2d& q) const {
    constexpr double kTwoPi = 6.283185307179586;
    double v = 110.0 + 30.0 * std::sin(kTwoPi * q.x() / 97.0 + 0.3) *
                           std::cos(kTwoPi * q.y() / 83.0 - 0.5);
    if (plaid_amplitude_ != 0.0) {
      const double s = plaid_wavelength_scale_;
      const double waves[3][3] = {{64.0 * s, 0.17, 0.4}, {76.0 * s, 1.22, 1.9}, {90.0 * s, 2.27, 3.1}};
      for (const auto& w : waves) {
        const double along = q.x() * std::cos(w[1]) + q.y() * std::sin(w[1]);
        v += plaid_amplitude_ * std::sin(kTwoPi * along / w[0] + w[2]);
      }
    }
    for (const Blob& b : blobs_) {
      const Eigen::Vector2d d = q - b.c;
      const double r = 4.0 * b.sigma;
      if (std::abs(d.x()) > r || std::abs(d.y()) > r) continue;
      v += b.amplitude * std::exp(-d.squaredNorm() / (2.0 * b.sigma * b.sigma));
    }
    return v;
  }

  // image(x) = round(gain * texture(source_from_pixel(x)) + offset), clamped to 0 .. 255.
  template <typename Map>
  cv::Mat Render(int width, int height, Map source_from_pixel, double gain = 1.0,
                 double offset = 0.0) const {
    cv::Mat image(height, width, CV_8UC1);
    for (int y = 0; y < height; ++y) {
      for (int x = 0; x < width; ++x) {
        const double v = gain * (*this)(source_from_pixel(Eigen::Vector2d(x, y))) + offset;
        image.at<std::uint8_t>(y, x) =
            static_cast<std::uint8_t>(std::clamp(std::lround(v), 0L, 255L));
      }
    }
    return image;
  }

  cv::Mat Render(int width, int height) const {
    return Render(width, height, [](const Eigen::Vector2d& p) { return p; });
  }

 private:
  struct Blob {
    Eigen::Vector2d c;
    double sigma = 1.0;
    double amplitude = 0.0;
  };
  double Uniform(double lo, double hi) {
    state_ = state_ * 1664525u + 1013904223u;  // Numerical Recipes LCG
    return lo + (hi - lo) * (static_cast<double>(state_ >> 8) / static_cast<double>(1u << 24));
  }
  std::uint32_t state_ = 1;
  double plaid_amplitude_ = 0.0;
  double plaid_wavelength_scale_ = 1.0;
  std::vector<Blob> blobs_;
};

// Sorted cam0 image paths of the EuRoC micro slice (VILMA_SHARED_DATA_DIR), empty when the
// data is absent.
inline std::vector<std::string> EurocCam0Images() {
  std::vector<std::string> paths;
  const std::filesystem::path dir =
      std::filesystem::path(VILMA_SHARED_DATA_DIR) / "euroc_V1_01_micro/mav0/cam0/data";
  std::error_code ec;
  if (!std::filesystem::is_directory(dir, ec)) return paths;
  for (const auto& entry : std::filesystem::directory_iterator(dir, ec)) {
    if (entry.path().extension() == ".png") paths.push_back(entry.path().string());
  }
  std::sort(paths.begin(), paths.end());
  return paths;
}

}  // namespace vilma::estimator::testing
