#include "vilma/eval/localization/stereo_geometry.h"

#include <algorithm>
#include <cmath>

#include "vilma/mapping/triangulation.h"

namespace vilma::eval {

namespace {

// Bilinear grey value of an 8-bit image at (x, y); the caller keeps (x, y) at least one pixel
// inside the image.
double Bilinear(const cv::Mat& image, double x, double y) {
  const int x0 = static_cast<int>(std::floor(x));
  const int y0 = static_cast<int>(std::floor(y));
  const double ax = x - x0, ay = y - y0;
  const uint8_t* r0 = image.ptr<uint8_t>(y0);
  const uint8_t* r1 = image.ptr<uint8_t>(y0 + 1);
  return (1.0 - ay) * ((1.0 - ax) * r0[x0] + ax * r0[x0 + 1]) +
         ay * ((1.0 - ax) * r1[x0] + ax * r1[x0 + 1]);
}

// True when the (2 w + 1)^2 patch around (x, y), widened by `margin` pixels along x for the
// gradient, lies inside the image with room for bilinear interpolation.
bool PatchInside(const cv::Mat& image, double x, double y, int w, double margin) {
  return x - w - margin >= 0.0 && x + w + margin + 1.0 < image.cols && y - w >= 0.0 &&
         y + w + 1.0 < image.rows;
}

// Zero-mean patch of (2 w + 1)^2 samples at (x + i, y + j), row-major; returns its std.
double ZeroMeanPatch(const cv::Mat& image, double x, double y, int w, std::vector<double>* patch) {
  patch->clear();
  double sum = 0.0;
  for (int j = -w; j <= w; ++j) {
    for (int i = -w; i <= w; ++i) {
      const double g = Bilinear(image, x + i, y + j);
      patch->push_back(g);
      sum += g;
    }
  }
  const double mean = sum / static_cast<double>(patch->size());
  double ss = 0.0;
  for (double& g : *patch) {
    g -= mean;
    ss += g * g;
  }
  return std::sqrt(ss / static_cast<double>(patch->size()));
}

// ZNCC of two zero-mean patches (0 when either is flat).
double Zncc(const std::vector<double>& a, const std::vector<double>& b) {
  double ab = 0.0, aa = 0.0, bb = 0.0;
  for (std::size_t k = 0; k < a.size(); ++k) {
    ab += a[k] * b[k];
    aa += a[k] * a[k];
    bb += b[k] * b[k];
  }
  return aa > 0.0 && bb > 0.0 ? ab / std::sqrt(aa * bb) : 0.0;
}

}  // namespace

std::string DisparityRefinementOptions::Validate() const {
  if (half_window_px < 1 || half_window_px > 15) return "half_window_px: expected 1..15";
  if (search_radius_px < 1 || search_radius_px > 10) return "search_radius_px: expected 1..10";
  if (!(std::isfinite(max_change_px) && max_change_px > 0.0)) return "max_change_px: expected > 0";
  if (!(std::isfinite(min_zncc) && min_zncc >= -1.0 && min_zncc <= 1.0)) {
    return "min_zncc: expected in [-1, 1]";
  }
  if (!(std::isfinite(min_patch_std) && min_patch_std >= 0.0)) {
    return "min_patch_std: expected >= 0";
  }
  if (max_iterations < 1 || max_iterations > 100) return "max_iterations: expected 1..100";
  return "";
}

const char* DisparityRefinementStatusName(DisparityRefinementStatus status) {
  switch (status) {
    case DisparityRefinementStatus::kOk: return "ok";
    case DisparityRefinementStatus::kOutside: return "outside";
    case DisparityRefinementStatus::kTextureless: return "textureless";
    case DisparityRefinementStatus::kNoPeak: return "no_peak";
    case DisparityRefinementStatus::kMovedTooFar: return "moved_too_far";
    case DisparityRefinementStatus::kLowZncc: return "low_zncc";
  }
  return "?";
}

DisparityRefinement RefineDisparity(const cv::Mat& left, const cv::Mat& right,
                                    const Eigen::Vector2d& uv_left, double d0,
                                    const DisparityRefinementOptions& options) {
  DisparityRefinement out;
  out.disparity_px = d0;
  if (left.type() != CV_8UC1 || right.type() != CV_8UC1) return out;
  const int w = options.half_window_px;
  const double u = uv_left.x(), v = uv_left.y();
  const double reach = options.search_radius_px + options.max_change_px + 1.0;
  if (!PatchInside(left, u, v, w, 0.0) || !PatchInside(right, u - d0, v, w, reach)) return out;
  std::vector<double> P_L, P_R;
  if (ZeroMeanPatch(left, u, v, w, &P_L) < options.min_patch_std) {
    out.status = DisparityRefinementStatus::kTextureless;
    return out;
  }

  // 1. ZNCC scan at whole-pixel offsets from d0, parabola through the best and its neighbours.
  const int r = options.search_radius_px;
  std::vector<double> zncc(static_cast<std::size_t>(2 * r + 1));
  int best = 0;
  for (int k = -r; k <= r; ++k) {
    ZeroMeanPatch(right, u - (d0 + k), v, w, &P_R);
    zncc[static_cast<std::size_t>(k + r)] = Zncc(P_L, P_R);
    if (zncc[static_cast<std::size_t>(k + r)] > zncc[static_cast<std::size_t>(best + r)]) best = k;
  }
  if (best == -r || best == r) {
    out.status = DisparityRefinementStatus::kNoPeak;
    out.zncc = zncc[static_cast<std::size_t>(best + r)];
    return out;
  }
  const double cm = zncc[static_cast<std::size_t>(best + r - 1)];
  const double c0 = zncc[static_cast<std::size_t>(best + r)];
  const double cp = zncc[static_cast<std::size_t>(best + r + 1)];
  const double curvature = cm - 2.0 * c0 + cp;  // < 0 at a maximum
  double d = d0 + best + (curvature < 0.0 ? 0.5 * (cm - cp) / curvature : 0.0);

  // 2. 1-D Lucas-Kanade on the zero-mean SSD (the comment in the header).
  const std::size_t n = P_L.size();
  std::vector<double> J(n);
  double sum_rr = 0.0, sum_JJ = 0.0;
  for (int it = 0; it < options.max_iterations; ++it) {
    if (std::abs(d - d0) > options.max_change_px + 1.0) break;  // diverging: judged below
    ZeroMeanPatch(right, u - d, v, w, &P_R);
    double mean_J = 0.0;
    std::size_t k = 0;
    for (int j = -w; j <= w; ++j) {
      for (int i = -w; i <= w; ++i, ++k) {
        const double x = u - d + i, y = v + j;
        // dP_R/dd = -dI_R/dx, the gradient by central difference of bilinear samples.
        J[k] = -0.5 * (Bilinear(right, x + 1.0, y) - Bilinear(right, x - 1.0, y));
        mean_J += J[k];
      }
    }
    mean_J /= static_cast<double>(n);
    double Jr = 0.0;
    sum_JJ = 0.0;
    sum_rr = 0.0;
    for (std::size_t q = 0; q < n; ++q) {
      J[q] -= mean_J;
      const double res = P_R[q] - P_L[q];
      Jr += J[q] * res;
      sum_JJ += J[q] * J[q];
      sum_rr += res * res;
    }
    if (!(sum_JJ > 1e-9)) {
      out.status = DisparityRefinementStatus::kTextureless;
      return out;
    }
    const double step = -Jr / sum_JJ;
    d += step;
    out.iterations = it + 1;
    if (std::abs(step) < 1e-4) break;
  }
  out.disparity_px = d;
  if (std::abs(d - d0) > options.max_change_px) {
    out.status = DisparityRefinementStatus::kMovedTooFar;
    return out;
  }
  ZeroMeanPatch(right, u - d, v, w, &P_R);
  out.zncc = Zncc(P_L, P_R);
  out.sigma_px = std::sqrt(sum_rr / static_cast<double>(n - 2) / sum_JJ);
  out.status = out.zncc >= options.min_zncc ? DisparityRefinementStatus::kOk
                                            : DisparityRefinementStatus::kLowZncc;
  return out;
}

Eigen::Vector3d StereoPoint_C(const Camera& camera, double baseline_m,
                              const Eigen::Vector2d& uv_left, double disparity_px) {
  const double Z = camera.fx() * baseline_m / disparity_px;
  return Eigen::Vector3d((uv_left.x() - camera.cx()) * Z / camera.fx(),
                         (uv_left.y() - camera.cy()) * Z / camera.fy(), Z);
}

std::string StereoTrackOptions::Validate() const {
  if (!(std::isfinite(sigma_px) && sigma_px > 0.0)) return "sigma_px: expected > 0";
  if (!(std::isfinite(max_residual_px) && max_residual_px > 0.0)) {
    return "max_residual_px: expected > 0";
  }
  return "";
}

StereoTrackPoint TriangulateStereoTrack(const std::vector<StereoObservation>& observations,
                                        const Camera& camera, double baseline_m,
                                        const StereoTrackOptions& options) {
  StereoTrackPoint out;
  out.used.assign(observations.size(), true);
  const Transformation T_CL_CR(Eigen::Matrix3d::Identity(), Eigen::Vector3d(baseline_m, 0, 0));
  mapping::TriangulationOptions tri;
  tri.max_iterations = 20;
  tri.convergence_step_m = 1e-9;
  tri.keypoint_sigma_px = options.sigma_px;
  while (true) {
    std::vector<mapping::TriangulationObservation> views;
    std::vector<std::size_t> index;  // observation of each view pair
    for (std::size_t k = 0; k < observations.size(); ++k) {
      if (!out.used[k]) continue;
      const StereoObservation& o = observations[k];
      views.push_back({o.T_W_C, &camera, o.uv_left});
      views.push_back({o.T_W_C * T_CL_CR, &camera,
                       Eigen::Vector2d(o.uv_left.x() - o.disparity_px, o.uv_left.y())});
      index.push_back(k);
    }
    if (views.empty()) return out;
    const mapping::TriangulationResult r = mapping::Triangulate(views, tri);
    if (!r.ok()) {
      if (index.size() == 1) return out;
      // Degenerate or behind a camera: keep the nearest view (largest disparity) alone.
      std::size_t nearest = index.front();
      for (std::size_t k : index) {
        if (observations[k].disparity_px > observations[nearest].disparity_px) nearest = k;
      }
      std::fill(out.used.begin(), out.used.end(), false);
      out.used[nearest] = true;
      continue;
    }
    // The worst view pair by its larger pixel residual.
    double worst = -1.0;
    std::size_t worst_k = index.front();
    double ss = 0.0;
    for (std::size_t v = 0; v < views.size(); ++v) {
      const Eigen::Vector3d p_C = views[v].T_M_C.inverse() * r.p_M;
      Eigen::Vector2d uv;
      camera.Project(p_C, &uv);
      const double e = (uv - views[v].uv).norm();
      ss += e * e;
      if (e > worst) {
        worst = e;
        worst_k = index[v / 2];
      }
    }
    if (worst > options.max_residual_px && index.size() > 1) {
      out.used[worst_k] = false;
      continue;
    }
    out.ok = true;
    out.p_W = r.p_M;
    out.covariance_W = r.covariance_M;
    out.views_used = static_cast<int>(index.size());
    out.rms_residual_px = std::sqrt(ss / static_cast<double>(views.size()));
    return out;
  }
}

}  // namespace vilma::eval
