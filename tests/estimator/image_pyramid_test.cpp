#include "vilma/estimator/image_pyramid.h"

#include <catch2/catch.hpp>

#include "estimator/synthetic_images.h"

namespace vilma::estimator {
namespace {

TEST_CASE("Pyramid levels halve the image by 2x2 box averaging", "[pyramid]") {
  const testing::SmoothTexture texture(752, 480, 120, 7u);
  const cv::Mat image = texture.Render(752, 480);
  ImagePyramid pyramid;
  pyramid.Build(image, 4);
  REQUIRE(pyramid.num_levels() == 4);
  const int expected[4][2] = {{752, 480}, {376, 240}, {188, 120}, {94, 60}};
  for (int l = 0; l < 4; ++l) {
    CHECK(pyramid.level(l).cols == expected[l][0]);
    CHECK(pyramid.level(l).rows == expected[l][1]);
    CHECK(pyramid.level(l).type() == CV_8UC1);
    CHECK(pyramid.level(l).isContinuous());
  }
  CHECK(cv::countNonZero(pyramid.level(0) != image) == 0);
  // Every pixel of level l+1 is the rounded mean of its 2x2 block on level l.
  for (int l = 1; l < 4; ++l) {
    const cv::Mat& src = pyramid.level(l - 1);
    const cv::Mat& dst = pyramid.level(l);
    int mismatches = 0;
    for (int y = 0; y < dst.rows; ++y) {
      for (int x = 0; x < dst.cols; ++x) {
        const int sum = src.at<uchar>(2 * y, 2 * x) + src.at<uchar>(2 * y, 2 * x + 1) +
                        src.at<uchar>(2 * y + 1, 2 * x) + src.at<uchar>(2 * y + 1, 2 * x + 1);
        if (dst.at<uchar>(y, x) != (sum + 2) / 4) ++mismatches;
      }
    }
    CHECK(mismatches == 0);
  }
}

TEST_CASE("Pyramid handles odd sizes and reuses its buffers", "[pyramid]") {
  cv::Mat odd(101, 77, CV_8UC1, cv::Scalar(9));
  ImagePyramid pyramid;
  pyramid.Build(odd, 3);
  CHECK(pyramid.level(1).cols == 38);
  CHECK(pyramid.level(1).rows == 50);
  CHECK(pyramid.level(2).cols == 19);
  CHECK(pyramid.level(2).rows == 25);
  CHECK(pyramid.level(2).at<uchar>(24, 18) == 9);

  const testing::SmoothTexture texture(160, 120, 20, 3u);
  ImagePyramid reuse;
  reuse.Build(texture.Render(160, 120), 3);
  const uchar* data[3] = {reuse.level(0).data, reuse.level(1).data, reuse.level(2).data};
  reuse.Build(texture.Render(160, 120, [](const Eigen::Vector2d& p) {
    return Eigen::Vector2d(p.x() + 3.0, p.y());
  }), 3);
  for (int l = 0; l < 3; ++l) CHECK(reuse.level(l).data == data[l]);

  CHECK_THROWS_AS(pyramid.Build(cv::Mat(), 2), std::invalid_argument);
  CHECK_THROWS_AS(pyramid.Build(cv::Mat(8, 8, CV_8UC3), 2), std::invalid_argument);
  CHECK_THROWS_AS(pyramid.Build(cv::Mat(8, 8, CV_8UC1), 5), std::invalid_argument);
}

TEST_CASE("Pixel coordinate conversions between levels", "[pyramid]") {
  // Pixel centres: level-0 pixels 0 and 1 average into level-1 pixel 0, whose centre is the
  // midpoint 0.5 of theirs.
  CHECK(ImagePyramid::LevelFromBase(Eigen::Vector2d(0.5, 0.5), 1).isApprox(Eigen::Vector2d(0, 0)));
  CHECK(ImagePyramid::LevelFromBase(Eigen::Vector2d(-0.5, -0.5), 3).isApprox(
      Eigen::Vector2d(-0.5, -0.5)));
  CHECK(ImagePyramid::LevelFromBase(Eigen::Vector2d(7.5, 23.5), 3).isApprox(
      Eigen::Vector2d(0.5, 2.5)));
  const Eigen::Vector2d p(123.37, 45.81);
  for (int l = 0; l < 5; ++l) {
    CHECK((ImagePyramid::BaseFromLevel(ImagePyramid::LevelFromBase(p, l), l) - p).norm() <
          1e-12);
  }
}

TEST_CASE("A bright dot lands at LevelFromBase on every level", "[pyramid]") {
  SECTION("single pixel: the brightest pixel of each level contains LevelFromBase") {
    cv::Mat image(240, 320, CV_8UC1, cv::Scalar(0));
    const Eigen::Vector2d p_0(141, 77);
    image.at<uchar>(77, 141) = 255;
    ImagePyramid pyramid;
    pyramid.Build(image, 4);
    for (int l = 0; l < 4; ++l) {
      cv::Point max_loc;
      cv::minMaxLoc(pyramid.level(l), nullptr, nullptr, nullptr, &max_loc);
      const Eigen::Vector2d p_l = ImagePyramid::LevelFromBase(p_0, l);
      CHECK(max_loc.x == static_cast<int>(std::lround(p_l.x())));
      CHECK(max_loc.y == static_cast<int>(std::lround(p_l.y())));
    }
  }
  SECTION("sub-pixel blob: the intensity centroid of each level is at LevelFromBase") {
    const Eigen::Vector2d p_0(151.3, 88.7);
    cv::Mat image(240, 320, CV_8UC1);
    for (int y = 0; y < 240; ++y) {
      for (int x = 0; x < 320; ++x) {
        const double d2 = (Eigen::Vector2d(x, y) - p_0).squaredNorm();
        image.at<uchar>(y, x) = static_cast<uchar>(std::lround(250.0 * std::exp(-d2 / 200.0)));
      }
    }
    ImagePyramid pyramid;
    pyramid.Build(image, 4);
    for (int l = 0; l < 4; ++l) {
      const cv::Mat& level = pyramid.level(l);
      Eigen::Vector2d sum = Eigen::Vector2d::Zero();
      double mass = 0.0;
      for (int y = 0; y < level.rows; ++y) {
        for (int x = 0; x < level.cols; ++x) {
          sum += level.at<uchar>(y, x) * Eigen::Vector2d(x, y);
          mass += level.at<uchar>(y, x);
        }
      }
      const Eigen::Vector2d centroid = sum / mass;
      INFO("level " << l << " centroid " << centroid.transpose());
      CHECK((centroid - ImagePyramid::LevelFromBase(p_0, l)).norm() < 0.05);
    }
  }
}

}  // namespace
}  // namespace vilma::estimator
