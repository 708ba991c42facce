#include "vilma/sim/renderer.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <stdexcept>

#include "vilma/sim/random.h"

namespace vilma {
namespace sim {

using Eigen::Matrix3d;
using Eigen::Vector2d;
using Eigen::Vector3d;

std::string RenderOptions::Validate() const {
  if (!(render_focal_scale >= 0.25 && render_focal_scale <= 4.0))
    return "render_focal_scale: expected 0.25 .. 4";
  if (!(near_m > 0.0)) return "near_m: expected > 0";
  if (!(gain > 0.0) || !std::isfinite(gain)) return "gain: expected > 0";
  if (!std::isfinite(offset)) return "offset: expected a finite number";
  if (!(vignetting >= 0.0 && vignetting < 1.0)) return "vignetting: expected 0 .. <1";
  if (!(noise_sigma >= 0.0) || !std::isfinite(noise_sigma)) return "noise_sigma: expected >= 0";
  return "";
}

namespace {

// log2(x) for x > 0 to within ~0.01: exponent plus a quadratic fit of log2 on the mantissa.
inline float FastLog2(float x) {
  uint32_t bits;
  std::memcpy(&bits, &x, 4);
  const float e = static_cast<float>(static_cast<int>(bits >> 23) - 127);
  bits = (bits & 0x7FFFFFu) | 0x3F800000u;
  float m;
  std::memcpy(&m, &bits, 4);
  const float f = m - 1.0f;
  return e + f * (1.3465553f - 0.3465553f * f);
}

inline uint64_t XorShift(uint64_t* s) {
  uint64_t x = *s;
  x ^= x << 13;
  x ^= x >> 7;
  x ^= x << 17;
  *s = x;
  return x;
}

}  // namespace

Renderer::Renderer(const World& world, const Camera& camera, const RenderOptions& options)
    : world_(world), camera_(camera), options_(options) {
  const std::string error = options.Validate();
  if (!error.empty()) throw std::invalid_argument("RenderOptions: " + error);
  if (!world.textures_ready()) throw std::invalid_argument("Renderer: world textures not generated");
  const int w = camera.width(), h = camera.height();

  // Undistorted field of view: the normalized coordinates of the image border (and, for
  // strong barrel distortion, anything inside it) bound the pinhole render.
  double xmin = 1e9, xmax = -1e9, ymin = 1e9, ymax = -1e9;
  cv::Mat nx(h, w, CV_32FC1), ny(h, w, CV_32FC1);
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      Vector3d b;
      float x = std::numeric_limits<float>::quiet_NaN(), y = x;
      if (camera.Unproject(Vector2d(u, v), &b) && b.z() > 1e-6) {
        x = static_cast<float>(b.x() / b.z());
        y = static_cast<float>(b.y() / b.z());
        xmin = std::min<double>(xmin, x);
        xmax = std::max<double>(xmax, x);
        ymin = std::min<double>(ymin, y);
        ymax = std::max<double>(ymax, y);
      }
      nx.at<float>(v, u) = x;
      ny.at<float>(v, u) = y;
    }
  }
  if (!(xmax > xmin && ymax > ymin)) throw std::invalid_argument("Renderer: camera does not unproject");
  const double fx = camera.fx() * options.render_focal_scale;
  const double fy = camera.fy() * options.render_focal_scale;
  const double margin_px = 2.0;  // bilinear support at the border
  const double cx = -xmin * fx + margin_px, cy = -ymin * fy + margin_px;
  const int pw = static_cast<int>(std::ceil((xmax - xmin) * fx + 2 * margin_px)) + 1;
  const int ph = static_cast<int>(std::ceil((ymax - ymin) * fy + 2 * margin_px)) + 1;
  pinhole_ = Camera(pw, ph, Eigen::Vector4d(fx, fy, cx, cy), DistortionModel::kNone,
                    Eigen::VectorXd());
  cv::Mat map_x(h, w, CV_32FC1), map_y(h, w, CV_32FC1);
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      const float x = nx.at<float>(v, u), y = ny.at<float>(v, u);
      map_x.at<float>(v, u) = std::isfinite(x) ? static_cast<float>(fx * x + cx) : -10.0f;
      map_y.at<float>(v, u) = std::isfinite(y) ? static_cast<float>(fy * y + cy) : -10.0f;
    }
  }
  // Only the pinhole pixels that the remap reads are rendered: per row, the span of the
  // bilinear footprints (barrel distortion leaves the bounding box's edge midpoints unused).
  row_begin_.assign(ph, pw);
  row_end_.assign(ph, -1);
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      const float mx = map_x.at<float>(v, u), my = map_y.at<float>(v, u);
      if (!(mx >= 0.0f && my >= 0.0f)) continue;
      const int x0 = static_cast<int>(mx), y0 = static_cast<int>(my);
      for (int yy = std::max(0, y0 - 1); yy <= std::min(ph - 1, y0 + 2); ++yy) {
        row_begin_[yy] = std::min(row_begin_[yy], std::max(0, x0 - 1));
        row_end_[yy] = std::max(row_end_[yy], std::min(pw - 1, x0 + 2));
      }
    }
  }
  // Fixed-point tables (1/32 px) make cv::remap several times faster than float maps.
  cv::convertMaps(map_x, map_y, map1_, map2_, CV_16SC2);

  // Gain and vignetting: radial cos^4-like falloff, `vignetting` darker at the corners.
  gain_map_.create(h, w, CV_32FC1);
  const double r_corner2 = std::pow(std::max(camera.cx(), w - 1 - camera.cx()), 2) +
                           std::pow(std::max(camera.cy(), h - 1 - camera.cy()), 2);
  for (int v = 0; v < h; ++v) {
    for (int u = 0; u < w; ++u) {
      const double r2 = (std::pow(u - camera.cx(), 2) + std::pow(v - camera.cy(), 2)) / r_corner2;
      gain_map_.at<float>(v, u) = static_cast<float>(options.gain * (1.0 - options.vignetting * r2));
    }
  }
  // Unit-variance Gaussian table for the pixel noise (exactly normalized).
  Rng rng(0x5EEDu);
  noise_table_.resize(1 << 16);
  double sum = 0.0, sum2 = 0.0;
  for (float& n : noise_table_) {
    n = static_cast<float>(rng.Normal());
    sum += n;
    sum2 += n * n;
  }
  const double mean = sum / noise_table_.size();
  const double sd = std::sqrt(sum2 / noise_table_.size() - mean * mean);
  for (float& n : noise_table_) n = static_cast<float>((n - mean) / sd);

  color_.create(ph, pw, CV_32FC1);
  zbuffer_.create(ph, pw, CV_32FC1);
  accumulator_.create(ph, pw, CV_32FC1);
  distorted_.create(h, w, CV_32FC1);
}

void Renderer::RenderPinhole(const Transformation& T_W_C, cv::Mat* out, bool accumulate,
                             float weight) {
  if (accumulate) {
    Rasterize(T_W_C, &color_);
    cv::scaleAdd(color_, weight, *out, *out);
  } else {
    out->create(pinhole_.height(), pinhole_.width(), CV_32FC1);
    Rasterize(T_W_C, out);
  }
}

void Renderer::Rasterize(const Transformation& T_W_C, cv::Mat* color) {
  const int pw = pinhole_.width(), ph = pinhole_.height();
  color->setTo(static_cast<float>(world_.background_intensity));
  zbuffer_.setTo(0.0f);  // W = 1/z; 0 is infinitely far
  const Matrix3d R_C_W = T_W_C.rotationMatrix().transpose();
  const Vector3d c_W = T_W_C.translation();
  const double fx = pinhole_.fx(), fy = pinhole_.fy(), cx = pinhole_.cx(), cy = pinhole_.cy();
  Matrix3d K_inv;
  K_inv << 1.0 / fx, 0.0, -cx / fx, 0.0, 1.0 / fy, -cy / fy, 0.0, 0.0, 1.0;

  // Front-to-back order (distance to the quad centre) so that the z-test rejects hidden
  // pixels before any texture fetch.
  order_.clear();
  for (size_t i = 0; i < world_.quads.size(); ++i) {
    const Quad& q = world_.quads[i];
    const Vector3d n = q.edge_u_W.cross(q.edge_v_W);
    const double side = n.dot(c_W - q.origin_W);
    if (!q.two_sided && side <= 0.0) continue;  // back face
    const Vector3d centre = q.origin_W + 0.5 * (q.edge_u_W + q.edge_v_W);
    order_.emplace_back((centre - c_W).squaredNorm(), static_cast<int>(i));
  }
  std::sort(order_.begin(), order_.end());

  const double near = options_.near_m;
  for (const auto& entry : order_) {
    const Quad& q = world_.quads[entry.second];
    const MipTexture& tex = world_.texture(q.texture_index);
    // Corners in the camera frame.
    Vector3d corners_W[4] = {q.origin_W, q.origin_W + q.edge_u_W,
                             q.origin_W + q.edge_u_W + q.edge_v_W, q.origin_W + q.edge_v_W};
    Vector3d poly[8];
    int n_in = 0;
    Vector3d cam[4];
    for (int k = 0; k < 4; ++k) cam[k] = R_C_W * (corners_W[k] - c_W);
    // Sutherland-Hodgman against z >= near.
    for (int k = 0; k < 4; ++k) {
      const Vector3d& a = cam[k];
      const Vector3d& b = cam[(k + 1) % 4];
      const bool a_in = a.z() >= near, b_in = b.z() >= near;
      if (a_in) poly[n_in++] = a;
      if (a_in != b_in) poly[n_in++] = a + (b - a) * ((near - a.z()) / (b.z() - a.z()));
    }
    if (n_in < 3) continue;
    double px[8], py[8];
    double ymin = 1e30, ymax = -1e30, xmin = 1e30, xmax = -1e30;
    for (int k = 0; k < n_in; ++k) {
      px[k] = fx * poly[k].x() / poly[k].z() + cx;
      py[k] = fy * poly[k].y() / poly[k].z() + cy;
      ymin = std::min(ymin, py[k]);
      ymax = std::max(ymax, py[k]);
      xmin = std::min(xmin, px[k]);
      xmax = std::max(xmax, px[k]);
    }
    if (xmax < 0 || ymax < 0 || xmin > pw - 1 || ymin > ph - 1) continue;
    // Plane homography: image ~ K [R u, R v, R (o - c)] (s, t, 1); invert, then scale s, t to
    // texel units (texel edges at 0 and width).
    Matrix3d M;
    M.col(0) = R_C_W * q.edge_u_W;
    M.col(1) = R_C_W * q.edge_v_W;
    M.col(2) = R_C_W * (q.origin_W - c_W);
    if (std::abs(M.determinant()) < 1e-12) continue;  // the plane passes through the camera
    Matrix3d H = M.inverse() * K_inv;
    H.row(0) *= tex.width();
    H.row(1) *= tex.height();
    const float h00 = static_cast<float>(H(0, 0)), h01 = static_cast<float>(H(0, 1)),
                h02 = static_cast<float>(H(0, 2)), h10 = static_cast<float>(H(1, 0)),
                h11 = static_cast<float>(H(1, 1)), h12 = static_cast<float>(H(1, 2)),
                h20 = static_cast<float>(H(2, 0)), h21 = static_cast<float>(H(2, 1)),
                h22 = static_cast<float>(H(2, 2));
    const float u_max = static_cast<float>(tex.width()) - 0.5f;
    const float v_max = static_cast<float>(tex.height()) - 0.5f;
    const int y0 = std::max(0, static_cast<int>(std::ceil(ymin - 1e-6)));
    const int y1 = std::min(ph - 1, static_cast<int>(std::floor(ymax + 1e-6)));
    for (int y = y0; y <= y1; ++y) {
      // Span of the convex polygon on this row (pixel centres at integers).
      double xl = 1e30, xr = -1e30;
      for (int k = 0; k < n_in; ++k) {
        const int k2 = (k + 1) % n_in;
        const double ya = py[k], yb = py[k2];
        if ((y < std::min(ya, yb) - 1e-9) || (y > std::max(ya, yb) + 1e-9)) continue;
        double x;
        if (std::abs(yb - ya) < 1e-12) {
          xl = std::min({xl, px[k], px[k2]});
          xr = std::max({xr, px[k], px[k2]});
          continue;
        }
        x = px[k] + (y - ya) * (px[k2] - px[k]) / (yb - ya);
        xl = std::min(xl, x);
        xr = std::max(xr, x);
      }
      const int x0 = std::max(row_begin_[y], static_cast<int>(std::ceil(xl - 1e-4)));
      const int x1 = std::min(row_end_[y], static_cast<int>(std::floor(xr + 1e-4)));
      if (x1 < x0) continue;
      float* crow = color->ptr<float>(y);
      float* zrow = zbuffer_.ptr<float>(y);
      const float fy_ = static_cast<float>(y);
      const float U0 = h01 * fy_ + h02, V0 = h11 * fy_ + h12, W0 = h21 * fy_ + h22;
      // Level of detail log2(texels per pixel) from the homography's Jacobian:
      // d(U/W)/dx = (h00 - u h20) / W etc. It varies slowly along a span, so it is computed
      // exactly every kLodStep pixels and interpolated linearly in between.
      auto lod_at = [&](float fx_) {
        const float W = W0 + h20 * fx_;
        if (W <= 0.0f) return 0.0f;
        const float inv_w = 1.0f / W;
        const float u = (U0 + h00 * fx_) * inv_w, v = (V0 + h10 * fx_) * inv_w;
        const float dux = (h00 - u * h20) * inv_w, dvx = (h10 - v * h20) * inv_w;
        const float duy = (h01 - u * h21) * inv_w, dvy = (h11 - v * h21) * inv_w;
        const float rho2 = std::max(dux * dux + dvx * dvx, duy * duy + dvy * dvy);
        return 0.5f * FastLog2(rho2 + 1e-20f);
      };
      constexpr int kLodStep = 8;
      constexpr int kChunk = 64;
      float chunk_w[kChunk], chunk_u[kChunk], chunk_v[kChunk];
      for (int xc = x0; xc <= x1; xc += kChunk) {
        const int n = std::min(kChunk, x1 - xc + 1);
        // Perspective-correct texel coordinates (a vectorizable loop).
        for (int i = 0; i < n; ++i) {
          const float fx_ = static_cast<float>(xc + i);
          const float W = W0 + h20 * fx_;
          const float inv_w = 1.0f / W;
          chunk_w[i] = W;
          chunk_u[i] = std::min(std::max((U0 + h00 * fx_) * inv_w, 0.5f), u_max) - 0.5f;
          chunk_v[i] = std::min(std::max((V0 + h10 * fx_) * inv_w, 0.5f), v_max) - 0.5f;
        }
        float lod_a = lod_at(static_cast<float>(xc));
        for (int i0 = 0; i0 < n; i0 += kLodStep) {
          const int i1 = std::min(n, i0 + kLodStep);
          // Sample inside the span only (beyond it the plane may be behind the camera).
          const int step = std::max(1, std::min(kLodStep, x1 - (xc + i0)));
          const float lod_b = lod_at(static_cast<float>(xc + i0 + step));
          const float dlod = (lod_b - lod_a) / static_cast<float>(step);
          float lod = lod_a;
          for (int i = i0; i < i1; ++i, lod += dlod) {
            const int x = xc + i;
            if (chunk_w[i] <= zrow[x]) continue;  // hidden (or behind: W <= 0)
            crow[x] = tex.Sample(chunk_u[i], chunk_v[i], lod);
            zrow[x] = chunk_w[i];
          }
          lod_a = lod_b;
        }
      }
    }
  }
}

void Renderer::Render(const std::vector<Transformation>& T_W_C_samples, uint64_t noise_seed,
                      cv::Mat* image) {
  if (T_W_C_samples.empty()) throw std::invalid_argument("Renderer::Render: no pose");
  if (T_W_C_samples.size() == 1) {
    RenderPinhole(T_W_C_samples[0], &accumulator_);
  } else {
    accumulator_.setTo(0.0f);
    const float weight = 1.0f / static_cast<float>(T_W_C_samples.size());
    for (const Transformation& T : T_W_C_samples) RenderPinhole(T, &accumulator_, true, weight);
  }
  cv::remap(accumulator_, distorted_, map1_, map2_, cv::INTER_LINEAR, cv::BORDER_CONSTANT,
            cv::Scalar(world_.background_intensity));
  const int w = camera_.width(), h = camera_.height();
  image->create(h, w, CV_8UC1);
  uint64_t state = SplitMix64(noise_seed) | 1u;
  const float sigma = static_cast<float>(options_.noise_sigma);
  const float offset = static_cast<float>(options_.offset);
  const bool noisy = sigma > 0.0f;
  for (int v = 0; v < h; ++v) {
    const float* src = distorted_.ptr<float>(v);
    const float* gain = gain_map_.ptr<float>(v);
    uint8_t* dst = image->ptr<uint8_t>(v);
    for (int u = 0; u < w; ++u) {
      float value = gain[u] * src[u] + offset;
      if (noisy) value += sigma * noise_table_[XorShift(&state) >> 48];
      value = std::min(255.0f, std::max(0.0f, value + 0.5f));
      dst[u] = static_cast<uint8_t>(value);
    }
  }
}

}  // namespace sim
}  // namespace vilma
