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

TEST_CASE("mip levels of odd-sided textures stay in place across levels of detail",
          "[sim][texture]") {
  // A ramp that rises two grey levels per texel along u (and along v, on a second texture):
  // every level's box average at a point equals the point's level-0 coordinate, so a lookup
  // at any level of detail returns its own u (v), up to the 8-bit rounding of the stored
  // levels (a quarter texel), the same everywhere. A level whose texels do not cover exactly
  // 2 x 2 texels of the level above (101 -> 50 by resizing: 2.02) returns values shifted toward
  // the far edge, growing to a texel per odd level across the texture: an image motion
  // ("texture swimming") as the camera's distance, and with it the level of detail, changes.
  for (const cv::Size size : {cv::Size(101, 65), cv::Size(127, 93)}) {
    cv::Mat ramp_u(size, CV_32FC1), ramp_v(size, CV_32FC1);
    for (int v = 0; v < size.height; ++v) {
      for (int u = 0; u < size.width; ++u) {
        ramp_u.at<float>(v, u) = 2.0f * static_cast<float>(u);
        ramp_v.at<float>(v, u) = 2.0f * static_cast<float>(v);
      }
    }
    const MipTexture mip_u(ramp_u), mip_v(ramp_v);
    // Mean lookup error [texels] over the fractions [f0, f1) of the side, along u and v.
    auto mean_error = [&](float lod, float f0, float f1) {
      double sum = 0.0;
      int n = 0;
      for (float f = f0; f < f1; f += 0.002f, n += 2) {
        const float u = f * size.width, v = f * size.height;
        sum += 0.5f * mip_u.Sample(u, 0.5f * size.height, lod) - u;
        sum += 0.5f * mip_v.Sample(0.5f * size.width, v, lod) - v;
      }
      return sum / n;
    };
    INFO("texture " << size.width << " x " << size.height);
    for (const float lod : {0.0f, 0.5f, 1.0f, 1.5f, 2.0f, 2.5f, 3.0f}) {
      INFO("lod " << lod);
      // Near the origin and toward the far edges (short of the last coarse texels, which the
      // replicated border texel legitimately biases).
      const double near = mean_error(lod, 0.05f, 0.3f);
      const double far = mean_error(lod, 0.5f, 0.8f);
      CHECK(std::abs(far - near) < 0.15);
      CHECK(std::abs(near) <= 0.3);  // the 8-bit rounding of the box averages
    }
  }
}
