#include "vilma/localizer/translation_ransac.h"

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>

namespace vilma::localizer {
namespace {

// Residual and cheirality of one correspondence for the unit translation t; n = a x f_c is
// precomputed (|n| = sine of the parallax angle).
inline bool IsInlier(const Eigen::Vector3d& t, const Eigen::Vector3d& a, const Eigen::Vector3d& f,
                     const Eigen::Vector3d& n, double threshold) {
  const double parallax = n.norm();
  const Eigen::Vector3d m = t.cross(a);  // normal of the epipolar plane span(t, a)
  const double m_norm = m.norm();
  if (m_norm < 1e-9) {
    // a along t: the point lies on the baseline; f_c must stay on it.
    return parallax < threshold;
  }
  if (std::abs(f.dot(m)) > threshold * m_norm) return false;
  if (parallax <= threshold) return true;  // depth sign undefined without parallax
  // d_c f = d_p a + t: crossing with f gives d_p (a x f) = f x t, crossing with a gives
  // d_c (f x a) = t x a; both depths must be positive.
  const double d_p = f.cross(t).dot(n);
  const double d_c = -m.dot(n);  // (t x a).(f x a) = -(t x a).(a x f)
  return d_p > 0.0 && d_c > 0.0;
}

int CountInliers(const Eigen::Vector3d& t, const std::vector<Eigen::Vector3d>& a,
                 const std::vector<Eigen::Vector3d>& f, const std::vector<Eigen::Vector3d>& n,
                 double threshold, std::vector<char>* flags) {
  int count = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const bool inlier = IsInlier(t, a[i], f[i], n[i], threshold);
    if (flags != nullptr) (*flags)[i] = inlier ? 1 : 0;
    count += inlier ? 1 : 0;
  }
  return count;
}

}  // namespace

TranslationRansacResult RansacTranslationKnownRotation(const std::vector<Eigen::Vector3d>& a,
                                                       const std::vector<Eigen::Vector3d>& f_c,
                                                       double threshold,
                                                       const RansacOptions& options) {
  if (a.size() != f_c.size()) {
    throw std::invalid_argument("RansacTranslationKnownRotation: bearing counts differ");
  }
  const int n_total = static_cast<int>(a.size());
  TranslationRansacResult result;
  result.inliers.assign(a.size(), 1);
  result.num_inliers = n_total;
  if (options.method == "none" || n_total < options.min_matches) return result;
  result.verified = true;

  std::vector<Eigen::Vector3d> n(a.size());
  for (std::size_t i = 0; i < a.size(); ++i) n[i] = a[i].cross(f_c[i]);

  // Rotation-only model: every correspondence without parallax.
  std::vector<char> flags_zero(a.size(), 0);
  int inliers_zero = 0;
  for (std::size_t i = 0; i < a.size(); ++i) {
    flags_zero[i] = n[i].norm() < threshold ? 1 : 0;
    inliers_zero += flags_zero[i];
  }

  // Only correspondences with parallax constrain t; samples are drawn among them.
  std::vector<int> moving;
  for (int i = 0; i < n_total; ++i) {
    if (!flags_zero[static_cast<std::size_t>(i)]) moving.push_back(i);
  }
  std::mt19937 rng(static_cast<std::mt19937::result_type>(options.seed));
  Eigen::Vector3d best_t = Eigen::Vector3d::Zero();
  int best_count = -1;
  std::vector<char> flags(a.size(), 0);
  if (moving.size() >= 2) {
    std::uniform_int_distribution<int> pick(0, static_cast<int>(moving.size()) - 1);
    int needed = options.max_iterations;
    for (int it = 0; it < std::min(needed, options.max_iterations); ++it) {
      ++result.iterations;
      const int i = moving[static_cast<std::size_t>(pick(rng))];
      int j = moving[static_cast<std::size_t>(pick(rng))];
      if (i == j) continue;
      Eigen::Vector3d t = n[static_cast<std::size_t>(i)].cross(n[static_cast<std::size_t>(j)]);
      const double norm = t.norm();
      if (norm < 1e-12) continue;
      t /= norm;
      // The sign of t is fixed by cheirality: try both.
      for (const double sign : {1.0, -1.0}) {
        const Eigen::Vector3d ts = sign * t;
        const int count = CountInliers(ts, a, f_c, n, threshold, nullptr);
        if (count > best_count) {
          best_count = count;
          best_t = ts;
        }
      }
      // Adaptive stop: samples are drawn among the moving correspondences, so the inlier
      // ratio that matters is that of the moving inliers.
      const double w = std::max(0, best_count - inliers_zero) /
                       static_cast<double>(moving.size());
      if (w >= 1.0) break;
      if (w > 0.0) {
        const double k = std::log(1.0 - options.confidence) / std::log(1.0 - w * w);
        needed = static_cast<int>(std::min<double>(std::ceil(k), options.max_iterations));
      }
    }
  }

  if (best_count > 0) {
    // Least-squares refinement on the inliers with parallax: t minimizes sum (t . n_i/|n_i|)^2,
    // the eigenvector of the smallest eigenvalue of sum n_i n_i^T / |n_i|^2.
    CountInliers(best_t, a, f_c, n, threshold, &flags);
    Eigen::Matrix3d A = Eigen::Matrix3d::Zero();
    int used = 0;
    for (std::size_t i = 0; i < a.size(); ++i) {
      if (!flags[i] || flags_zero[i]) continue;
      const Eigen::Vector3d u = n[i].normalized();
      A += u * u.transpose();
      ++used;
    }
    if (used >= 3) {
      Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(A);
      Eigen::Vector3d t = eig.eigenvectors().col(0);
      if (t.dot(best_t) < 0.0) t = -t;
      const int count = CountInliers(t, a, f_c, n, threshold, nullptr);
      if (count >= best_count) {
        best_count = count;
        best_t = t;
      }
    }
  }

  // Model selection: the translation must explain clearly more than the rotation alone, and
  // a good part of the correspondences with parallax.
  const int margin = std::max(
      static_cast<int>(std::ceil(options.rotation_only_margin * n_total)),
      static_cast<int>(std::ceil(options.min_translation_support *
                                 static_cast<double>(moving.size()))));
  if (best_count < 0 || moving.size() < 2 || best_count - inliers_zero < std::max(margin, 1)) {
    result.rotation_only = true;
    result.t_dir.setZero();
    result.inliers = flags_zero;
    result.num_inliers = inliers_zero;
  } else {
    result.t_dir = best_t;
    result.num_inliers = CountInliers(best_t, a, f_c, n, threshold, &result.inliers);
  }
  return result;
}

}  // namespace vilma::localizer
