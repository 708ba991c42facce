#include "vilma/sim/texture.h"

#include <catch2/catch.hpp>
#include <cmath>
#include <opencv2/imgproc.hpp>

using vilma::sim::GenerateTexture;
using vilma::sim::MipTexture;
using vilma::sim::TextureKind;
using vilma::sim::TextureSpec;

namespace {
TextureSpec Spec(uint64_t seed) {
  TextureSpec s;
  s.width = 400;
  s.height = 300;
  s.texel_size_m = 0.015;
  s.seed = seed;
  return s;
}
}  // namespace

TEST_CASE("natural textures are deterministic and differ between seeds", "[sim][texture]") {
  const cv::Mat a = GenerateTexture(Spec(7));
  const cv::Mat b = GenerateTexture(Spec(7));
  const cv::Mat c = GenerateTexture(Spec(8));
  REQUIRE(cv::norm(a, b, cv::NORM_INF) == 0.0);
  REQUIRE(cv::norm(a, c, cv::NORM_L1) / a.total() > 10.0);
}

TEST_CASE("natural textures have image-like statistics", "[sim][texture]") {
  const cv::Mat t = GenerateTexture(Spec(3));
  cv::Scalar mean, sd;
  cv::meanStdDev(t, mean, sd);
  CHECK(std::abs(mean[0] - 128.0) < 30.0);
  CHECK(sd[0] > 25.0);
  CHECK(sd[0] < 80.0);
  double lo, hi;
  cv::minMaxLoc(t, &lo, &hi);
  CHECK(lo >= 0.0);
  CHECK(hi <= 255.0);
  // Fine-scale content (gradients for trackers) at every scale: the high-pass energy is not
  // negligible, and the picture is not periodic: correlation with a shifted copy is low.
  cv::Mat blurred;
  cv::GaussianBlur(t, blurred, cv::Size(0, 0), 2.0);
  cv::Scalar hp_mean, hp_sd;
  cv::meanStdDev(t - blurred, hp_mean, hp_sd);
  CHECK(hp_sd[0] > 3.0);
  for (int shift : {32, 64, 100}) {
    const cv::Mat a = t(cv::Rect(0, 0, t.cols - shift, t.rows));
    const cv::Mat b = t(cv::Rect(shift, 0, t.cols - shift, t.rows));
    cv::Mat r;
    cv::matchTemplate(a, b, r, cv::TM_CCOEFF_NORMED);
    INFO("shift " << shift);
    CHECK(r.at<float>(0, 0) < 0.6);
  }
}

TEST_CASE("checker texture has its corner at the centre", "[sim][texture]") {
  TextureSpec s;
  s.kind = TextureKind::kChecker;
  s.width = s.height = 64;
  const cv::Mat t = GenerateTexture(s);
  CHECK(t.at<float>(31, 31) == t.at<float>(32, 32));
  CHECK(t.at<float>(31, 32) == t.at<float>(32, 31));
  CHECK(t.at<float>(31, 31) < t.at<float>(31, 32));
}

TEST_CASE("mip pyramid halves down to one texel and keeps the mean", "[sim][texture]") {
  cv::Mat level0 = GenerateTexture(Spec(5))(cv::Rect(0, 0, 256, 256)).clone();
  const MipTexture mip(level0);
  REQUIRE(mip.num_levels() == 9);
  CHECK(mip.level(8).cols == 1);
  // Levels are stored in 8 bits (rounded).
  CHECK(mip.level(8).at<uint8_t>(0, 0) == Approx(cv::mean(level0)[0]).margin(0.5));
  // Magnified lookups at texel centres return the texel; lod 1 returns the level-1 texel
  // at the matching centre.
  CHECK(mip.Sample(10.0f, 20.0f, 0.0f) == Approx(level0.at<float>(20, 10)).margin(0.5));
  CHECK(mip.Sample(10.5f, 20.5f, 1.0f) == Approx(mip.level(1).at<uint8_t>(10, 5)).margin(1e-3));
  // Bilinear halfway between texel centres.
  const float left = mip.Sample(10.0f, 20.0f, 0.0f), right = mip.Sample(11.0f, 20.0f, 0.0f);
  CHECK(mip.Sample(10.5f, 20.0f, 0.0f) == Approx(0.5f * (left + right)).margin(1e-3));
  // Trilinear blend halfway between two levels.
  const float a = mip.Sample(10.5f, 20.5f, 1.0f), b = mip.Sample(10.5f, 20.5f, 2.0f);
  CHECK(mip.Sample(10.5f, 20.5f, 1.5f) == Approx(0.5f * (a + b)).margin(1e-3));
}
