#include "vilma/localizer/pose_ambiguity.h"

#include <Eigen/SVD>
#include <cmath>
#include <limits>
#include <opengv/absolute_pose/CentralAbsoluteAdapter.hpp>
#include <opengv/absolute_pose/methods.hpp>
#include <random>

#include "vilma/localizer/pose_ransac.h"

namespace vilma::localizer {
namespace {

// Matches within threshold_px of their keypoint under T_G_C (indices).
std::vector<int> InliersOf(const Camera& camera, const std::vector<Eigen::Vector2d>& keypoints,
                           const std::vector<Eigen::Vector3d>& p_G, const Transformation& T_G_C,
                           double threshold_px) {
  std::vector<int> inliers;
  const Transformation T_C_G = T_G_C.inverse();
  const double t2 = threshold_px * threshold_px;
  for (std::size_t i = 0; i < p_G.size(); ++i) {
    const Eigen::Vector3d p_C = T_C_G * p_G[i];
    Eigen::Vector2d uv;
    if (p_C.z() <= 1e-6 || camera.Project(p_C, &uv) != Camera::ProjectionResult::kValid) continue;
    if ((uv - keypoints[i]).squaredNorm() <= t2) inliers.push_back(static_cast<int>(i));
  }
  return inliers;
}

// The number of matches within threshold_px under T_G_C when it exceeds `to_beat`, else any
// number <= to_beat: the count stops once the matches left cannot lift it above to_beat (most
// sampled poses are far worse than the best so far; same selection, less projection).
int CountIfMore(const Camera& camera, const std::vector<Eigen::Vector2d>& keypoints,
                const std::vector<Eigen::Vector3d>& p_G, const Transformation& T_G_C,
                double threshold_px, int to_beat) {
  const Transformation T_C_G = T_G_C.inverse();
  const double t2 = threshold_px * threshold_px;
  const int total = static_cast<int>(p_G.size());
  int n = 0;
  for (int i = 0; i < total; ++i) {
    if (n + (total - i) <= to_beat) return n;
    const Eigen::Vector3d p_C = T_C_G * p_G[static_cast<std::size_t>(i)];
    Eigen::Vector2d uv;
    if (p_C.z() <= 1e-6 || camera.Project(p_C, &uv) != Camera::ProjectionResult::kValid) continue;
    if ((uv - keypoints[static_cast<std::size_t>(i)]).squaredNorm() <= t2) ++n;
  }
  return n;
}

}  // namespace

DisplacedRival FindDisplacedRival(const Camera& camera,
                                  const std::vector<Eigen::Vector2d>& keypoints,
                                  const std::vector<Eigen::Vector3d>& p_G,
                                  const std::vector<int>& winner_inliers,
                                  const std::vector<double>& winner_errors,
                                  const Transformation& T_G_C_winner,
                                  const DisplacedRivalOptions& options) {
  DisplacedRival best;
  // The pool: bearings of every match that unprojects; `index_of[i]` is match i's bearing.
  opengv::bearingVectors_t bearings;
  opengv::points_t points;
  std::vector<int> index_of(keypoints.size(), -1);
  for (std::size_t i = 0; i < keypoints.size() && i < p_G.size(); ++i) {
    Eigen::Vector3d f;
    if (!camera.Unproject(keypoints[i], &f)) continue;
    index_of[i] = static_cast<int>(bearings.size());
    bearings.push_back(f.normalized());
    points.push_back(p_G[i]);
  }
  std::vector<int> in, out;  // bearing indices of winner inliers / of rejected matches
  for (int i : winner_inliers) {
    if (index_of[static_cast<std::size_t>(i)] >= 0) in.push_back(index_of[static_cast<std::size_t>(i)]);
  }
  for (std::size_t i = 0; i < winner_errors.size() && i < index_of.size(); ++i) {
    if (index_of[i] >= 0 && !(winner_errors[i] <= options.threshold_px)) out.push_back(index_of[i]);
  }
  if (in.size() < 2 || out.empty()) return best;
  const opengv::absolute_pose::CentralAbsoluteAdapter adapter(bearings, points);
  auto displaced = [&](const Transformation& T, double* position_m, double* rotation_deg) {
    *position_m = (T.translation() - T_G_C_winner.translation()).norm();
    *rotation_deg = AngleBetween(T.rotation(), T_G_C_winner.rotation()) * 180.0 / M_PI;
    return *position_m > options.min_position_m || *rotation_deg > options.min_rotation_deg;
  };
  std::mt19937_64 rng(options.seed);
  std::uniform_int_distribution<std::size_t> pick_in(0, in.size() - 1);
  std::uniform_int_distribution<std::size_t> pick_out(0, out.size() - 1);
  for (int s = 0; s < options.samples; ++s) {
    const int a = in[pick_in(rng)];
    int b = in[pick_in(rng)];
    if (b == a) continue;  // a draw, not a retry: the sample count stays deterministic
    const int c = out[pick_out(rng)];
    // p3p_kneip: up to 4 solutions [R_G_C | p_G_C].
    const opengv::transformations_t solutions = opengv::absolute_pose::p3p_kneip(adapter, {a, b, c});
    for (const opengv::transformation_t& m : solutions) {
      if (!m.allFinite()) continue;
      const Eigen::Matrix3d R = m.leftCols<3>();
      const Eigen::JacobiSVD<Eigen::Matrix3d> svd(R, Eigen::ComputeFullU | Eigen::ComputeFullV);
      const Eigen::Matrix3d R_ortho = svd.matrixU() * svd.matrixV().transpose();
      if (R_ortho.determinant() < 0.0) continue;
      const Transformation T(R_ortho, Eigen::Vector3d(m.col(3)));
      double position_m = 0.0, rotation_deg = 0.0;
      if (!displaced(T, &position_m, &rotation_deg)) continue;
      const int n = CountIfMore(camera, keypoints, p_G, T, options.threshold_px, best.inliers);
      if (n > best.inliers) {
        best.found = n >= 3;
        best.inliers = n;
        best.position_m = position_m;
        best.rotation_deg = rotation_deg;
        best.T_G_C = T;
      }
    }
  }
  if (!best.found) return best;
  // Refine the best on its inliers (re-selected, 2 rounds as after RANSAC); keep the refined
  // pose only if it is still displaced and explains more: the figure is a lower bound of the
  // support of the best displaced pose either way.
  Transformation T = best.T_G_C;
  std::vector<int> inliers = InliersOf(camera, keypoints, p_G, T, options.threshold_px);
  for (int round = 0; round < 2 && options.refine_iterations > 0 && inliers.size() >= 3; ++round) {
    RefineCameraPose(camera, keypoints, p_G, inliers, options.refine_iterations, 1.0, &T);
    inliers = InliersOf(camera, keypoints, p_G, T, options.threshold_px);
  }
  double position_m = 0.0, rotation_deg = 0.0;
  if (displaced(T, &position_m, &rotation_deg) && static_cast<int>(inliers.size()) > best.inliers) {
    best.inliers = static_cast<int>(inliers.size());
    best.position_m = position_m;
    best.rotation_deg = rotation_deg;
    best.T_G_C = T;
  }
  return best;
}

}  // namespace vilma::localizer
