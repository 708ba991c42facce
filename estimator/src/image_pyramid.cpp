// Image pyramid by 2x2 box averaging; see image_pyramid.h for the pixel-centre convention.
#include "vilma/estimator/image_pyramid.h"

#include <cstdint>
#include <stdexcept>
#include <string>

namespace vilma::estimator {
namespace {

// dst(x, y) = round((src(2x, 2y) + src(2x+1, 2y) + src(2x, 2y+1) + src(2x+1, 2y+1)) / 4).
// Pixel (x, y) of level l+1 covers exactly pixels 2x..2x+1, 2y..2y+1 of level l, which is what
// makes p_{l+1} = (p_l + 0.5) / 2 - 0.5 hold. An odd last row/column of src is dropped.
// The inner loop is branch-free on contiguous rows so that the compiler vectorizes it.
void HalveBox(const cv::Mat& src, cv::Mat* dst) {
  const int w = dst->cols;
  const int h = dst->rows;
  for (int y = 0; y < h; ++y) {
    const std::uint8_t* __restrict r0 = src.ptr<std::uint8_t>(2 * y);
    const std::uint8_t* __restrict r1 = src.ptr<std::uint8_t>(2 * y + 1);
    std::uint8_t* __restrict d = dst->ptr<std::uint8_t>(y);
    for (int x = 0; x < w; ++x) {
      const unsigned sum = static_cast<unsigned>(r0[2 * x]) + r0[2 * x + 1] + r1[2 * x] +
                           r1[2 * x + 1];
      d[x] = static_cast<std::uint8_t>((sum + 2u) >> 2);
    }
  }
}

}  // namespace

void ImagePyramid::Build(const cv::Mat& image_gray8, int num_levels) {
  if (image_gray8.empty() || image_gray8.type() != CV_8UC1) {
    throw std::invalid_argument("ImagePyramid::Build: image must be a non-empty CV_8UC1 image");
  }
  if (num_levels < 1) {
    throw std::invalid_argument("ImagePyramid::Build: num_levels must be >= 1, got " +
                                std::to_string(num_levels));
  }
  if ((image_gray8.cols >> (num_levels - 1)) < 1 || (image_gray8.rows >> (num_levels - 1)) < 1) {
    throw std::invalid_argument("ImagePyramid::Build: image too small for " +
                                std::to_string(num_levels) + " levels");
  }
  if (levels_.size() != static_cast<std::size_t>(num_levels)) {
    levels_.resize(static_cast<std::size_t>(num_levels));
  }
  // create() and copyTo() reuse the existing buffers when size and type are unchanged.
  image_gray8.copyTo(levels_[0]);
  for (int l = 1; l < num_levels; ++l) {
    const cv::Mat& src = levels_[static_cast<std::size_t>(l - 1)];
    cv::Mat& dst = levels_[static_cast<std::size_t>(l)];
    dst.create(src.rows / 2, src.cols / 2, CV_8UC1);
    HalveBox(src, &dst);
  }
}

Eigen::Vector2d ImagePyramid::LevelFromBase(const Eigen::Vector2d& p_0, int level) {
  const double scale = 1.0 / static_cast<double>(1 << level);
  return ((p_0.array() + 0.5) * scale - 0.5).matrix();
}

Eigen::Vector2d ImagePyramid::BaseFromLevel(const Eigen::Vector2d& p_l, int level) {
  const double scale = static_cast<double>(1 << level);
  return ((p_l.array() + 0.5) * scale - 0.5).matrix();
}

}  // namespace vilma::estimator
