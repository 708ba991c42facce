// Fast software renderer of a World into a distorted 8-bit grey camera image.
//
// 1. Rasterize every textured quad into an undistorted pinhole image whose field of view
//    covers the distorted camera's (quads sorted front to back, back faces culled, near-plane
//    clipping, scanline fill of the projected convex polygon). Per pixel the texture
//    coordinates follow from the quad's plane homography (perspective-correct: (U, V, W) =
//    H^-1 (x, y, 1), texel = (U/W, V/W), and W = 1/z is the z-buffer key), the mip level from
//    the homography's analytic Jacobian d(u, v)/d(x, y), trilinear filtering.
// 2. Distort with precomputed remap tables: for each output pixel, unproject through the
//    distorted camera and project into the pinhole render (bilinear).
// 3. Photometric model: gain (session lighting) * vignetting * radiance + offset + Gaussian
//    pixel noise, rounded to 8 bits.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "vilma/core/camera.h"
#include "vilma/core/geometry.h"
#include "vilma/sim/world.h"

namespace vilma {
namespace sim {

struct RenderOptions {
  // Pinhole render focal length / camera fx. 1 samples the image centre 1:1 (the periphery,
  // compressed by the barrel distortion, is oversampled); 0.85 renders 28 % fewer pixels at
  // the cost of a slightly softer centre (like a lens a little out of focus).
  double render_focal_scale = 0.85;
  double near_m = 0.05;             // near clipping plane [m]
  double gain = 1.0;                // radiance multiplier (lighting of the session)
  double offset = 0.0;              // added grey level (lighting of the session)
  double vignetting = 0.3;          // relative darkening at the image corners (0: none)
  double noise_sigma = 2.0;         // Gaussian pixel noise [grey levels] (0: none)

  std::string Validate() const;
};

class Renderer {
 public:
  // `world` must outlive the renderer and have its textures generated.
  Renderer(const World& world, const Camera& camera, const RenderOptions& options);

  // Renders the undistorted pinhole image (CV_32FC1, pinhole_camera() geometry) seen by a
  // camera at T_W_C; adds it into `accumulator` with weight `weight` when `accumulate`.
  void RenderPinhole(const Transformation& T_W_C, cv::Mat* pinhole, bool accumulate = false,
                     float weight = 1.0f);

  // Full image (CV_8UC1, camera size): the average of the pinhole renders at the poses
  // T_W_C_samples (one pose: no motion blur), distorted, lit, with noise drawn from noise_seed.
  void Render(const std::vector<Transformation>& T_W_C_samples, uint64_t noise_seed,
              cv::Mat* image);

  const Camera& camera() const { return camera_; }
  const Camera& pinhole_camera() const { return pinhole_; }
  const RenderOptions& options() const { return options_; }

 private:
  // Rasterizes the world into `color` (pinhole size, CV_32FC1) using zbuffer_.
  void Rasterize(const Transformation& T_W_C, cv::Mat* color);

  const World& world_;
  Camera camera_;
  Camera pinhole_;
  RenderOptions options_;
  cv::Mat map1_, map2_;       // fixed-point remap tables (distorted <- pinhole)
  std::vector<int> row_begin_, row_end_;  // pinhole pixels [begin, end] per row that are used
  cv::Mat gain_map_;          // CV_32FC1: gain * vignetting per output pixel
  std::vector<float> noise_table_;  // unit Gaussian samples
  cv::Mat color_, zbuffer_, accumulator_, distorted_;
  std::vector<std::pair<double, int>> order_;
};

}  // namespace sim
}  // namespace vilma
