#include "vilma/eval/localization/residual_calibration.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>

#include "vilma/localizer/pose_acceptance.h"

namespace vilma::eval {

std::vector<ResidualSample> InlierResidualSamples(const Camera& camera,
                                                  const localizer::LocalizationMap& map,
                                                  const std::vector<Eigen::Vector2d>& keypoints,
                                                  const localizer::LocalizationResult& result,
                                                  double sigma_px) {
  std::vector<ResidualSample> samples;
  const bool with_landmarks = !map.p_G_covariance.empty();
  for (int i : result.inliers) {
    const localizer::Match2D3D& m = result.matches[static_cast<std::size_t>(i)];
    Eigen::Vector2d e;
    Eigen::Matrix<double, 2, 6> J;
    Eigen::Matrix<double, 2, 3> J_l;
    if (!localizer::ReprojectionResidual(camera, result.T_G_C, map.p_G[m.landmark],
                                         keypoints[static_cast<std::size_t>(m.keypoint)], &e, &J,
                                         &J_l)) {
      continue;
    }
    const Eigen::Matrix3d Sigma_l = with_landmarks
                                        ? map.p_G_covariance[m.landmark].cast<double>().eval()
                                        : Eigen::Matrix3d::Zero().eval();
    const Eigen::Matrix2d landmark_px2 = J_l * Sigma_l * J_l.transpose();
    const Eigen::Matrix2d Sigma_r =
        sigma_px * sigma_px * Eigen::Matrix2d::Identity() + landmark_px2;
    ResidualSample s;
    s.squared_px2 = e.squaredNorm();
    s.landmark_trace_px2 = landmark_px2.trace();
    s.chi2 = e.dot(Sigma_r.inverse() * e);
    samples.push_back(s);
  }
  if (samples.size() < 4) return {};
  const double n = static_cast<double>(samples.size());
  const double scale = 2.0 * n / (2.0 * n - 6.0);
  for (ResidualSample& s : samples) s.squared_px2 *= scale;
  return samples;
}

NoiseCalibration FitNoiseComponents(const std::vector<ResidualSample>& samples, double dof,
                                    int poses) {
  NoiseCalibration c;
  c.poses = poses;
  c.residuals = static_cast<int>(samples.size());
  if (samples.empty() || !(dof > 0.0)) return c;
  double chi2 = 0.0;
  bool any_landmark = false;
  for (const ResidualSample& s : samples) {
    chi2 += s.chi2;
    any_landmark |= s.landmark_trace_px2 > 0.0;
  }
  c.chi2_per_dof = chi2 / dof;
  // Weighted least squares of |e|^2 on [2, tr(J Sigma_l J^T)] (one column without
  // covariances); start unweighted, then reweight by the predicted variance three times.
  double s_kp = 0.0, alpha = 0.0;
  for (int round = 0; round < 4; ++round) {
    Eigen::Matrix2d A = Eigen::Matrix2d::Zero();
    Eigen::Vector2d b = Eigen::Vector2d::Zero();
    for (const ResidualSample& s : samples) {
      const Eigen::Vector2d x(2.0, s.landmark_trace_px2);
      double w = 1.0;
      if (round > 0) {
        const double predicted = std::max(2.0 * s_kp + alpha * s.landmark_trace_px2, 1e-6);
        w = 1.0 / (predicted * predicted);
      }
      A += w * x * x.transpose();
      b += w * x * s.squared_px2;
    }
    if (!any_landmark) {
      s_kp = b(0) / A(0, 0);
      alpha = 0.0;
    } else {
      const Eigen::FullPivLU<Eigen::Matrix2d> lu(A);
      if (!lu.isInvertible()) return c;
      const Eigen::Vector2d theta = lu.solve(b);
      s_kp = std::max(theta(0), 0.0);
      alpha = std::max(theta(1), 0.0);
    }
  }
  c.keypoint_sigma_px = std::sqrt(s_kp);
  c.landmark_scale = any_landmark ? alpha : -1.0;
  return c;
}

LandmarkSurfaceCheck CheckLandmarksAgainstWorld(const localizer::LocalizationMap& map,
                                                const sim::World& world) {
  LandmarkSurfaceCheck c;
  if (map.p_G_covariance.empty() || world.quads.empty()) return c;
  std::vector<double> chi2;
  double sum_d2 = 0.0, sum_s2 = 0.0;
  for (std::size_t l = 0; l < map.p_G.size(); ++l) {
    const Eigen::Vector3d& p = map.p_G[l];
    const Eigen::Matrix3d Sigma_l = map.p_G_covariance[l].cast<double>();
    if (Sigma_l.isZero(0.0)) continue;
    std::size_t best = 0;
    double best_distance = std::numeric_limits<double>::infinity();
    for (std::size_t q = 0; q < world.quads.size(); ++q) {
      const double d = sim::DistanceToQuad(world.quads[q], p);
      if (d < best_distance) {
        best_distance = d;
        best = q;
      }
    }
    const sim::Quad& quad = world.quads[best];
    const Eigen::Vector3d n = quad.Normal();
    const double d = n.dot(p - quad.origin_W);
    // The foot point lies inside the parallelogram exactly when the distance to it is the
    // plane distance.
    if (std::abs(std::abs(d) - best_distance) > 1e-9) continue;
    const double s2 = n.dot(Sigma_l * n);
    if (!(s2 > 0.0)) continue;
    chi2.push_back(d * d / s2);
    sum_d2 += d * d;
    sum_s2 += s2;
  }
  c.landmarks = static_cast<int>(chi2.size());
  if (chi2.empty()) return c;
  const double n = static_cast<double>(chi2.size());
  double sum = 0.0;
  for (double x : chi2) sum += x;
  c.chi2_per_dof = sum / n;
  std::nth_element(chi2.begin(), chi2.begin() + static_cast<std::ptrdiff_t>(chi2.size() / 2),
                   chi2.end());
  c.median_chi2 = chi2[chi2.size() / 2];
  c.rms_distance_m = std::sqrt(sum_d2 / n);
  c.rms_sigma_m = std::sqrt(sum_s2 / n);
  return c;
}

}  // namespace vilma::eval
