#include "vilma/sim/texture.h"

#include <algorithm>
#include <cmath>
#include <opencv2/imgproc.hpp>

#include "vilma/sim/random.h"

namespace vilma {
namespace sim {

std::string TextureSpec::Validate() const {
  if (width < 1 || height < 1 || width > 16384 || height > 16384)
    return "texture size: expected 1..16384 texels per side";
  if (!(texel_size_m > 0.0) || !std::isfinite(texel_size_m))
    return "texel_size_m: expected > 0";
  if (!(mean >= 0.0 && mean <= 255.0)) return "mean: expected 0..255";
  if (!(contrast >= 0.0) || !std::isfinite(contrast)) return "contrast: expected >= 0";
  return "";
}

namespace {

// One octave of value noise: random lattice values every `spacing` texels, interpolated
// bicubically (cv::resize) to the texture size.
void AddValueNoiseOctave(cv::Mat* image, double spacing, double amplitude, Rng* rng) {
  const int w = image->cols, h = image->rows;
  const int gw = std::max(2, static_cast<int>(std::ceil(w / spacing)) + 2);
  const int gh = std::max(2, static_cast<int>(std::ceil(h / spacing)) + 2);
  cv::Mat grid(gh, gw, CV_32FC1);
  for (int y = 0; y < gh; ++y) {
    float* row = grid.ptr<float>(y);
    for (int x = 0; x < gw; ++x) row[x] = static_cast<float>(rng->Normal() * amplitude);
  }
  // Resize a slightly larger area so that the lattice spacing is exactly `spacing`, then crop.
  const int big_w = static_cast<int>(std::round(gw * spacing));
  const int big_h = static_cast<int>(std::round(gh * spacing));
  cv::Mat big;
  cv::resize(grid, big, cv::Size(big_w, big_h), 0, 0, cv::INTER_CUBIC);
  const int ox = rng->UniformInt(std::max(1, big_w - w));
  const int oy = rng->UniformInt(std::max(1, big_h - h));
  *image += big(cv::Rect(ox, oy, w, h));
}

// Soft-edged value for an antialiased shape: coverage from signed distance d [texels].
inline float Coverage(double d) { return static_cast<float>(std::clamp(0.5 - d, 0.0, 1.0)); }

void Blend(cv::Mat* image, int x, int y, float value, float alpha) {
  float& p = image->at<float>(y, x);
  p += alpha * (value - p);
}

}  // namespace

cv::Mat GenerateTexture(const TextureSpec& spec) {
  cv::Mat image(spec.height, spec.width, CV_32FC1, cv::Scalar(spec.mean));
  const int w = spec.width, h = spec.height;
  if (spec.kind == TextureKind::kUniform) return image;
  if (spec.kind == TextureKind::kChecker) {
    const float dark = static_cast<float>(std::max(0.0, spec.mean - 90.0 * spec.contrast));
    const float bright = static_cast<float>(std::min(255.0, spec.mean + 90.0 * spec.contrast));
    for (int y = 0; y < h; ++y) {
      float* row = image.ptr<float>(y);
      for (int x = 0; x < w; ++x)
        row[x] = ((2 * x < w) == (2 * y < h)) ? dark : bright;
    }
    return image;
  }

  Rng rng(spec.seed);
  image.setTo(0.0);
  // 1/f noise: octaves from ~2 m features down to 2 texels. An amplitude spectrum ~1/f in 2D
  // puts the same energy into every octave (integral of f^-2 * f df over [f, 2f] is constant),
  // so every octave gets about the same amplitude (slightly more at coarse scales).
  const double largest = std::max(4.0, std::min(2.0 / spec.texel_size_m, 2.0 * std::max(w, h)));
  for (double spacing = largest; spacing >= 2.0; spacing *= 0.5) {
    AddValueNoiseOctave(&image, spacing, std::pow(spacing / largest, 0.15), &rng);
  }
  // Normalize the noise to unit standard deviation.
  cv::Scalar mean, stddev;
  cv::meanStdDev(image, mean, stddev);
  image = (image - mean[0]) * (1.0 / std::max(1e-9, stddev[0]));
  image *= 32.0;  // grey levels

  const double area_m2 = w * h * spec.texel_size_m * spec.texel_size_m;
  const double texels_per_m = 1.0 / spec.texel_size_m;
  // Rectangles (posters, panels, tiles): about one per 1.5 m^2, 5 cm to 1.2 m wide, some
  // filled with their own fine noise (printed content).
  const int num_rects = static_cast<int>(area_m2 / 1.5) + 1;
  for (int i = 0; i < num_rects; ++i) {
    const double rw = rng.Uniform(0.05, 1.2) * texels_per_m;
    const double rh = rw * rng.Uniform(0.3, 1.6);
    const double cx = rng.Uniform(0, w), cy = rng.Uniform(0, h);
    const float value = static_cast<float>(rng.Normal(0.0, 55.0));
    const float inner_amp = static_cast<float>(rng.Uniform() < 0.5 ? rng.Uniform(5.0, 30.0) : 0.0);
    const int x0 = std::max(0, static_cast<int>(cx - rw / 2 - 1));
    const int x1 = std::min(w - 1, static_cast<int>(cx + rw / 2 + 1));
    const int y0 = std::max(0, static_cast<int>(cy - rh / 2 - 1));
    const int y1 = std::min(h - 1, static_cast<int>(cy + rh / 2 + 1));
    const uint64_t inner_seed = rng.Next();
    for (int y = y0; y <= y1; ++y) {
      for (int x = x0; x <= x1; ++x) {
        const double d = std::max(std::abs(x - cx) - rw / 2, std::abs(y - cy) - rh / 2);
        const float a = Coverage(d);
        if (a <= 0.0f) continue;
        float v = value;
        if (inner_amp > 0.0f) {
          // Cheap hashed texel noise, blurred by the mip chain when minified.
          const uint64_t hsh = SplitMix64(inner_seed ^ (static_cast<uint64_t>(y) << 32) ^
                                          static_cast<uint64_t>(x >> 1) ^
                                          (static_cast<uint64_t>(y >> 1) << 20));
          v += inner_amp * (static_cast<float>(hsh & 0xFFFF) / 65535.0f - 0.5f) * 2.0f;
        }
        Blend(&image, x, y, v, a);
      }
    }
  }
  // Blobs (ellipses with soft or hard edges): dark and bright spots of many sizes.
  const int num_blobs = static_cast<int>(area_m2 / 0.5) + 2;
  for (int i = 0; i < num_blobs; ++i) {
    const double r = std::exp(rng.Uniform(std::log(0.02), std::log(0.35))) * texels_per_m;
    const double ax = r * rng.Uniform(0.5, 1.5), ay = r * rng.Uniform(0.5, 1.5);
    const double cx = rng.Uniform(0, w), cy = rng.Uniform(0, h);
    const double softness = rng.Uniform() < 0.5 ? 0.0 : rng.Uniform(0.1, 0.5);
    const float value = static_cast<float>(rng.Normal(0.0, 60.0));
    const int x0 = std::max(0, static_cast<int>(cx - ax - 2));
    const int x1 = std::min(w - 1, static_cast<int>(cx + ax + 2));
    const int y0 = std::max(0, static_cast<int>(cy - ay - 2));
    const int y1 = std::min(h - 1, static_cast<int>(cy + ay + 2));
    for (int y = y0; y <= y1; ++y) {
      for (int x = x0; x <= x1; ++x) {
        const double q = std::hypot((x - cx) / ax, (y - cy) / ay);
        float a;
        if (softness > 0.0) {
          a = static_cast<float>(std::clamp((1.0 - q) / softness, 0.0, 1.0));
        } else {
          a = Coverage((q - 1.0) * std::min(ax, ay));
        }
        if (a > 0.0f) Blend(&image, x, y, value, a);
      }
    }
  }
  // Lines and streaks (cables, seams, scratches): 1-6 texels wide.
  const int num_lines = static_cast<int>(area_m2 / 2.0) + 1;
  for (int i = 0; i < num_lines; ++i) {
    const double x0 = rng.Uniform(0, w), y0 = rng.Uniform(0, h);
    const double angle = rng.Uniform(0, M_PI);
    const double length = rng.Uniform(0.2, 2.0) * texels_per_m;
    const double half_width = rng.Uniform(0.5, 3.0);
    const float value = static_cast<float>(rng.Normal(0.0, 60.0));
    const double dx = std::cos(angle), dy = std::sin(angle);
    const int bx0 = std::max(0, static_cast<int>(std::min(x0, x0 + dx * length) - half_width - 2));
    const int bx1 = std::min(w - 1, static_cast<int>(std::max(x0, x0 + dx * length) + half_width + 2));
    const int by0 = std::max(0, static_cast<int>(std::min(y0, y0 + dy * length) - half_width - 2));
    const int by1 = std::min(h - 1, static_cast<int>(std::max(y0, y0 + dy * length) + half_width + 2));
    for (int y = by0; y <= by1; ++y) {
      for (int x = bx0; x <= bx1; ++x) {
        const double along = (x - x0) * dx + (y - y0) * dy;
        if (along < 0.0 || along > length) continue;
        const double across = std::abs(-(x - x0) * dy + (y - y0) * dx);
        const float a = Coverage(across - half_width);
        if (a > 0.0f) Blend(&image, x, y, value, a);
      }
    }
  }
  image = image * spec.contrast + spec.mean;
  cv::min(image, 250.0, image);
  cv::max(image, 5.0, image);
  return image;
}

MipTexture::MipTexture(const cv::Mat& level0) {
  CV_Assert(level0.type() == CV_32FC1 && !level0.empty());
  cv::Mat current = level0;
  while (true) {
    cv::Mat level8;
    current.convertTo(level8, CV_8UC1);  // rounds and saturates
    levels_.push_back(level8);
    if (current.cols == 1 && current.rows == 1) break;
    // Texel i of level l+1 must cover texels 2i and 2i+1 of level l exactly, as Sample's
    // coordinate mapping (i + 0.5) 2^l - 0.5 assumes. An odd side is first padded by one
    // replicated texel (clamp-to-edge, as Bilinear addresses) so that the 2:1 box is exact;
    // resizing 225 texels to 112 would instead stretch the box to 2.009 texels, and a surface
    // seen at a level of detail between the two levels would slide by up to one texel as the
    // camera approaches (texture "swimming": an image motion the geometry does not have).
    cv::Mat even = current;
    if (current.cols % 2 != 0 || current.rows % 2 != 0) {
      cv::copyMakeBorder(current, even, 0, current.rows % 2, 0, current.cols % 2,
                         cv::BORDER_REPLICATE);
    }
    const int w = std::max(1, even.cols / 2), h = std::max(1, even.rows / 2);
    cv::Mat next;
    // INTER_AREA is the box filter for integer factors; filtered in float, stored in 8 bits.
    cv::resize(even, next, cv::Size(w, h), 0, 0, cv::INTER_AREA);
    current = next;
  }
  UpdateTable();
}

void MipTexture::UpdateTable() {
  table_.clear();
  for (size_t i = 0; i < levels_.size(); ++i) {
    CV_Assert(levels_[i].isContinuous());
    Level l;
    l.data = levels_[i].ptr<uint8_t>(0);
    l.width = levels_[i].cols;
    l.height = levels_[i].rows;
    l.max_u = static_cast<float>(l.width - 1);
    l.max_v = static_cast<float>(l.height - 1);
    l.scale = 1.0f / static_cast<float>(1 << i);
    table_.push_back(l);
  }
}

}  // namespace sim
}  // namespace vilma
