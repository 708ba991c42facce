#include "vilma/localizer/pose_ransac.h"

#include <Eigen/Cholesky>
#include <cmath>
#include <memory>
#include <opengv/absolute_pose/CentralAbsoluteAdapter.hpp>
#include <opengv/sac/Ransac.hpp>
#include <opengv/sac_problems/absolute_pose/AbsolutePoseSacProblem.hpp>

namespace vilma::localizer {

std::string PoseRansacOptions::Validate() const {
  if (!(threshold_px > 0.0 && threshold_px <= 100.0)) return "threshold_px: expected in (0, 100]";
  if (max_iterations < 1) return "max_iterations: expected >= 1";
  if (!(probability > 0.0 && probability < 1.0)) return "probability: expected in (0, 1)";
  if (min_inliers < 4) return "min_inliers: expected >= 4 (3 for P3P + 1 to disambiguate)";
  if (refine_iterations < 0) return "refine_iterations: expected >= 0";
  if (!(keypoint_sigma_px > 0.0)) return "keypoint_sigma_px: expected > 0";
  return "";
}

const char* PoseStatusName(PoseStatus status) {
  switch (status) {
    case PoseStatus::kOk: return "ok";
    case PoseStatus::kTooFewMatches: return "too_few_matches";
    case PoseStatus::kRansacFailed: return "ransac_failed";
    case PoseStatus::kTooFewInliers: return "too_few_inliers";
  }
  return "unknown";
}

Matrix6d RefineCameraPose(const Camera& camera, const std::vector<Eigen::Vector2d>& keypoints,
                          const std::vector<Eigen::Vector3d>& p_G, const std::vector<int>& indices,
                          int iterations, double sigma_px, Transformation* T_G_C) {
  // Right perturbation T_G_C Exp(xi): p_C = Exp(-xi) T_C_G p_G ~= p_C - rho - phi x p_C, so
  // d p_C / d rho = -I and d p_C / d phi = [p_C]x.
  Eigen::Matrix<double, 6, 6> H = Eigen::Matrix<double, 6, 6>::Zero();
  for (int it = 0; it <= iterations; ++it) {
    H.setZero();
    Vector6d b = Vector6d::Zero();
    const Transformation T_C_G = T_G_C->inverse();
    for (int i : indices) {
      const Eigen::Vector3d p_C = T_C_G * p_G[i];
      if (p_C.z() <= 1e-6) continue;
      Eigen::Vector2d uv;
      Eigen::Matrix<double, 2, 3> J_uv_p;
      const Camera::ProjectionResult r = camera.Project(p_C, &uv, &J_uv_p);
      if (r == Camera::ProjectionResult::kBehindCamera || r == Camera::ProjectionResult::kNotFinite) {
        continue;
      }
      Eigen::Matrix<double, 3, 6> J_p_xi;
      J_p_xi.leftCols<3>() = -Eigen::Matrix3d::Identity();
      J_p_xi.rightCols<3>() = Skew(p_C);
      const Eigen::Matrix<double, 2, 6> J = J_uv_p * J_p_xi;
      const Eigen::Vector2d e = uv - keypoints[i];
      H += J.transpose() * J;
      b += J.transpose() * e;
    }
    if (it == iterations) break;  // the last pass only evaluates H at the final estimate
    const Eigen::LDLT<Eigen::Matrix<double, 6, 6>> ldlt(H);
    if (ldlt.info() != Eigen::Success) break;
    const Vector6d dx = -ldlt.solve(b);
    if (!dx.allFinite()) break;
    *T_G_C = *T_G_C * Transformation::Exp(dx);
    if (dx.norm() < 1e-10) {
      it = iterations - 1;  // converged: one more pass for H
    }
  }
  const Eigen::FullPivLU<Matrix6d> lu(H);
  if (!lu.isInvertible()) return Matrix6d::Zero();
  return sigma_px * sigma_px * lu.inverse();
}

namespace {

std::vector<int> PixelInliers(const Camera& camera, const std::vector<Eigen::Vector2d>& keypoints,
                              const std::vector<Eigen::Vector3d>& p_G, const Transformation& T_G_C,
                              double threshold_px, double* rms) {
  std::vector<int> inliers;
  const Transformation T_C_G = T_G_C.inverse();
  double sum2 = 0.0;
  for (std::size_t i = 0; i < p_G.size(); ++i) {
    const Eigen::Vector3d p_C = T_C_G * p_G[i];
    Eigen::Vector2d uv;
    if (p_C.z() <= 1e-6 ||
        camera.Project(p_C, &uv) != Camera::ProjectionResult::kValid) {
      continue;
    }
    const double e2 = (uv - keypoints[i]).squaredNorm();
    if (e2 <= threshold_px * threshold_px) {
      inliers.push_back(static_cast<int>(i));
      sum2 += e2;
    }
  }
  *rms = inliers.empty() ? 0.0 : std::sqrt(sum2 / inliers.size());
  return inliers;
}

}  // namespace

PoseResult EstimateCameraPose(const Camera& camera, const std::vector<Eigen::Vector2d>& keypoints,
                              const std::vector<Eigen::Vector3d>& p_G,
                              const PoseRansacOptions& options) {
  PoseResult result;
  // Bearings of the matches that unproject; `used[k]` is the match index of bearing k.
  opengv::bearingVectors_t bearings;
  opengv::points_t points;
  std::vector<int> used;
  for (std::size_t i = 0; i < keypoints.size() && i < p_G.size(); ++i) {
    Eigen::Vector3d f;
    if (!camera.Unproject(keypoints[i], &f)) continue;
    bearings.push_back(f.normalized());
    points.push_back(p_G[i]);
    used.push_back(static_cast<int>(i));
  }
  if (static_cast<int>(used.size()) < std::max(4, options.min_inliers)) {
    result.status = PoseStatus::kTooFewMatches;
    return result;
  }
  opengv::absolute_pose::CentralAbsoluteAdapter adapter(bearings, points);
  using Problem = opengv::sac_problems::absolute_pose::AbsolutePoseSacProblem;
  auto problem = std::make_shared<Problem>(adapter, Problem::KNEIP, /*randomSeed=*/false);
  problem->rng_alg_.seed(static_cast<unsigned>(options.seed));
  opengv::sac::Ransac<Problem> ransac;
  ransac.sac_model_ = problem;
  // OpenGV's error is 1 - cos(angle between bearing and reprojected bearing): a pixel
  // threshold at the focal length f is the angle atan(threshold / f).
  const double f = 0.5 * (camera.fx() + camera.fy());
  ransac.threshold_ = 1.0 - std::cos(std::atan(options.threshold_px / f));
  ransac.max_iterations_ = options.max_iterations;
  ransac.probability_ = options.probability;
  if (!ransac.computeModel(0) || ransac.inliers_.size() < 3 ||
      !ransac.model_coefficients_.allFinite()) {
    result.ransac_iterations = ransac.iterations_;
    result.status = PoseStatus::kRansacFailed;
    return result;
  }
  result.ransac_iterations = ransac.iterations_;
  // model = [R_G_C | p_G_C].
  const Eigen::Matrix3d R = ransac.model_coefficients_.leftCols<3>();
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(R, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d R_ortho = svd.matrixU() * svd.matrixV().transpose();
  if (R_ortho.determinant() < 0) {
    result.status = PoseStatus::kRansacFailed;
    return result;
  }
  result.T_G_C = Transformation(R_ortho, Eigen::Vector3d(ransac.model_coefficients_.col(3)));
  // Refine on the RANSAC inliers, re-select inliers in pixels, refine once more.
  std::vector<int> inliers;
  for (int k : ransac.inliers_) inliers.push_back(used[k]);
  double rms = 0.0;
  for (int round = 0; round < 2 && options.refine_iterations > 0; ++round) {
    if (inliers.size() < 3) break;
    result.covariance_C = RefineCameraPose(camera, keypoints, p_G, inliers,
                                           options.refine_iterations, options.keypoint_sigma_px,
                                           &result.T_G_C);
    inliers = PixelInliers(camera, keypoints, p_G, result.T_G_C, options.threshold_px, &rms);
  }
  if (options.refine_iterations == 0) {
    inliers = PixelInliers(camera, keypoints, p_G, result.T_G_C, options.threshold_px, &rms);
  }
  result.inliers = inliers;
  result.rms_reprojection_px = rms;
  result.status = static_cast<int>(inliers.size()) >= options.min_inliers
                      ? PoseStatus::kOk
                      : PoseStatus::kTooFewInliers;
  return result;
}

}  // namespace vilma::localizer
