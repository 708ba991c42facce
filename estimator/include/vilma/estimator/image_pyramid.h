// Image pyramid for patch tracking. Level 0 is the camera image; level l+1 halves level l by
// 2x2 box averaging (as ROVIO). Pixel centres are at integer coordinates on every level, so a
// level-0 pixel p_0 is at p_l = (p_0 + 0.5) / 2^l - 0.5 on level l.
#pragma once

#include <Eigen/Core>
#include <opencv2/core.hpp>
#include <vector>

namespace vilma::estimator {

class ImagePyramid {
 public:
  ImagePyramid() = default;

  // Builds `num_levels` levels from an 8-bit grayscale image (copied into level 0). Reuses its
  // buffers: no allocation when called again with the same size and level count.
  void Build(const cv::Mat& image_gray8, int num_levels);

  int num_levels() const { return static_cast<int>(levels_.size()); }
  // CV_8UC1, continuous.
  const cv::Mat& level(int l) const { return levels_[static_cast<std::size_t>(l)]; }

  static Eigen::Vector2d LevelFromBase(const Eigen::Vector2d& p_0, int level);
  static Eigen::Vector2d BaseFromLevel(const Eigen::Vector2d& p_l, int level);

 private:
  std::vector<cv::Mat> levels_;
};

}  // namespace vilma::estimator
