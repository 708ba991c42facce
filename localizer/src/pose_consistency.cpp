#include "vilma/localizer/pose_consistency.h"

#include <Eigen/Eigenvalues>
#include <Eigen/LU>
#include <algorithm>
#include <cmath>
#include <numeric>

#include "vilma/localizer/pose_acceptance.h"
#include "vilma/localizer/pose_ransac.h"

namespace vilma::localizer {

SplitConsistency SplitHalfConsistency(const Camera& camera,
                                      const std::vector<Eigen::Vector2d>& keypoints,
                                      const std::vector<Eigen::Vector3d>& p_G,
                                      const std::vector<int>& inliers, const Transformation& T_G_C,
                                      int iterations, double sigma_px,
                                      const std::vector<Eigen::Matrix3d>& p_G_covariance,
                                      SplitAxis axis) {
  SplitConsistency out;
  if (inliers.size() < 8) return out;
  // The key each inlier is sorted by.
  std::vector<double> key(inliers.size());
  if (axis == SplitAxis::kImageAxis) {
    Eigen::Vector2d mean = Eigen::Vector2d::Zero();
    for (int i : inliers) mean += keypoints[static_cast<std::size_t>(i)];
    mean /= static_cast<double>(inliers.size());
    Eigen::Matrix2d scatter = Eigen::Matrix2d::Zero();
    for (int i : inliers) {
      const Eigen::Vector2d d = keypoints[static_cast<std::size_t>(i)] - mean;
      scatter += d * d.transpose();
    }
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix2d> es(scatter);
    const Eigen::Vector2d axis_uv = es.eigenvectors().col(1);  // largest eigenvalue
    for (std::size_t k = 0; k < inliers.size(); ++k) {
      key[k] = axis_uv.dot(keypoints[static_cast<std::size_t>(inliers[k])] - mean);
    }
  } else {
    const Transformation T_C_G = T_G_C.inverse();
    for (std::size_t k = 0; k < inliers.size(); ++k) {
      key[k] = (T_C_G * p_G[static_cast<std::size_t>(inliers[k])]).z();
    }
  }
  std::vector<std::size_t> order(inliers.size());
  std::iota(order.begin(), order.end(), 0);
  // Ties by inlier order: deterministic.
  std::stable_sort(order.begin(), order.end(),
                   [&key](std::size_t a, std::size_t b) { return key[a] < key[b]; });
  std::vector<int> half[2];
  for (std::size_t r = 0; r < order.size(); ++r) {
    half[r < order.size() / 2 ? 0 : 1].push_back(inliers[order[r]]);
  }
  Transformation T[2] = {T_G_C, T_G_C};
  Matrix6d C[2];
  for (int h = 0; h < 2; ++h) {
    std::sort(half[h].begin(), half[h].end());
    RefineCameraPose(camera, keypoints, p_G, half[h], iterations, sigma_px, &T[h]);
    if (!PoseCovariance(camera, keypoints, p_G, half[h], T[h], sigma_px, &C[h], nullptr,
                        p_G_covariance, CovarianceOf::kUnweighted)) {
      return out;
    }
  }
  // d in the tangent space at T_1 (right perturbation: T_2 = T_1 Exp(d)); C_2 is at T_2, which
  // is within the noise of T_1, so its frame is taken as T_1's.
  const Vector6d d = (T[0].inverse() * T[1]).Log();
  const Eigen::FullPivLU<Matrix6d> lu(C[0] + C[1]);
  if (!lu.isInvertible()) return out;
  out.mahalanobis2 = d.dot(lu.solve(d));
  out.position_m = (T[0].translation() - T[1].translation()).norm();
  out.rotation_deg = AngleBetween(T[0].rotation(), T[1].rotation()) * 180.0 / M_PI;
  out.valid = std::isfinite(out.mahalanobis2);
  return out;
}

}  // namespace vilma::localizer
