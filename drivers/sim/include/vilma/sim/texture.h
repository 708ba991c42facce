// Procedural textures with natural-image statistics and their mip pyramids.
//
// A natural texture is a sum of value-noise octaves whose amplitude falls as 1/f (power
// spectrum ~1/f^2, the statistics of natural images: Field 1987), overlaid with sharp-edged
// content that feature detectors need: rectangles (posters, tiles, panels), blobs, lines and
// streaks. Nothing is periodic, so nothing aliases into false matches. Everything is
// deterministic from the seed.
#pragma once

#include <cstddef>
#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

namespace vilma {
namespace sim {

enum class TextureKind {
  kNatural,  // the procedural natural texture above
  kChecker,  // 2x2 checkerboard whose inner corner is at the texture centre (test marker)
  kUniform,  // constant `mean` (e.g. a plain ceiling)
};

struct TextureSpec {
  TextureKind kind = TextureKind::kNatural;
  int width = 256;              // [texels]
  int height = 256;             // [texels]
  double texel_size_m = 0.015;  // size of a texel on the quad [m]; sets feature scales
  double mean = 128.0;          // mean grey level [0..255]
  double contrast = 1.0;        // scales the standard deviation (about 45 grey levels at 1)
  uint64_t seed = 1;

  // Empty if valid, otherwise what is wrong.
  std::string Validate() const;
};

// Generates the level-0 image (CV_32FC1, grey levels 0..255).
cv::Mat GenerateTexture(const TextureSpec& spec);

// A texture with its mip pyramid (box-filtered halvings down to 1x1), sampled with trilinear
// filtering. Levels are stored as 8-bit (CV_8UC1, continuous): four times less memory traffic
// than float in the renderer's inner loop, which is bound by texture cache misses.
class MipTexture {
 public:
  MipTexture() = default;
  // `level0`: CV_32FC1 grey levels 0..255.
  explicit MipTexture(const cv::Mat& level0);
  MipTexture(const MipTexture& other) : levels_(other.levels_) { UpdateTable(); }
  MipTexture& operator=(const MipTexture& other) {
    levels_ = other.levels_;
    UpdateTable();
    return *this;
  }

  int width() const { return levels_.empty() ? 0 : levels_[0].cols; }
  int height() const { return levels_.empty() ? 0 : levels_[0].rows; }
  int num_levels() const { return static_cast<int>(levels_.size()); }
  const cv::Mat& level(int i) const { return levels_[i]; }

  // Trilinear sample at level-0 texel coordinates (u, v) (texel centres at integers) with
  // level of detail `lod` = log2(texels per pixel); clamp-to-edge addressing.
  float Sample(float u, float v, float lod) const {
    if (lod <= 0.0f) return Bilinear(table_[0], u, v);
    const int max_level = static_cast<int>(levels_.size()) - 1;
    const int l0 = static_cast<int>(lod);
    if (l0 >= max_level) {
      const Level& l = table_[max_level];
      return Bilinear(l, (u + 0.5f) * l.scale - 0.5f, (v + 0.5f) * l.scale - 0.5f);
    }
    const float f = lod - static_cast<float>(l0);
    const Level& la = table_[l0];
    const Level& lb = table_[l0 + 1];
    // Texel centre i of level l sits at level-0 coordinate (i + 0.5) 2^l - 0.5.
    const float a = Bilinear(la, (u + 0.5f) * la.scale - 0.5f, (v + 0.5f) * la.scale - 0.5f);
    const float b = Bilinear(lb, (u + 0.5f) * lb.scale - 0.5f, (v + 0.5f) * lb.scale - 0.5f);
    return a + f * (b - a);
  }

 private:
  struct Level {
    const uint8_t* data = nullptr;
    int width = 0, height = 0;
    float max_u = 0.0f, max_v = 0.0f;
    float scale = 1.0f;  // 2^-level
  };
  static float Bilinear(const Level& l, float u, float v) {
    u = u < 0.0f ? 0.0f : (u > l.max_u ? l.max_u : u);
    v = v < 0.0f ? 0.0f : (v > l.max_v ? l.max_v : v);
    const int x0 = static_cast<int>(u), y0 = static_cast<int>(v);
    const int dx = x0 + 1 < l.width ? 1 : 0;
    const int dy = y0 + 1 < l.height ? l.width : 0;
    const float fx = u - static_cast<float>(x0), fy = v - static_cast<float>(y0);
    const uint8_t* p = l.data + static_cast<ptrdiff_t>(y0) * l.width + x0;
    const float p00 = p[0], p01 = p[dx], p10 = p[dy], p11 = p[dy + dx];
    const float top = p00 + fx * (p01 - p00);
    const float bottom = p10 + fx * (p11 - p10);
    return top + fy * (bottom - top);
  }
  void UpdateTable();

  std::vector<cv::Mat> levels_;
  std::vector<Level> table_;
};

}  // namespace sim
}  // namespace vilma
