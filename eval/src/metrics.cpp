#include "vilma/eval/metrics.h"

#include <algorithm>
#include <cmath>

namespace vilma {
namespace {

constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;

}  // namespace

// ---- statistics ----

ErrorStats ComputeErrorStats(const std::vector<double>& values) {
  ErrorStats s;
  s.count = values.size();
  if (values.empty()) return s;
  double sum = 0.0;
  double sum_sq = 0.0;
  s.min = values.front();
  s.max = values.front();
  for (double v : values) {
    sum += v;
    sum_sq += v * v;
    s.min = std::min(s.min, v);
    s.max = std::max(s.max, v);
  }
  const double n = static_cast<double>(values.size());
  s.mean = sum / n;
  s.rmse = std::sqrt(sum_sq / n);
  double var = 0.0;
  for (double v : values) var += (v - s.mean) * (v - s.mean);
  s.std_dev = std::sqrt(var / n);
  std::vector<double> sorted = values;
  std::sort(sorted.begin(), sorted.end());
  const std::size_t mid = sorted.size() / 2;
  s.median = sorted.size() % 2 == 1 ? sorted[mid] : 0.5 * (sorted[mid - 1] + sorted[mid]);
  return s;
}

std::vector<WithinCount> CountWithin(const std::vector<double>& translation_errors_m,
                                     const std::vector<double>& distances_m) {
  std::vector<WithinCount> counts;
  counts.reserve(distances_m.size());
  for (double d : distances_m) {
    WithinCount c;
    c.distance_m = d;
    c.matched_poses = translation_errors_m.size();
    for (double e : translation_errors_m) {
      if (e <= d) ++c.poses;  // the boundary is within
    }
    c.fraction = c.matched_poses == 0
                     ? 0.0
                     : static_cast<double>(c.poses) / static_cast<double>(c.matched_poses);
    counts.push_back(c);
  }
  return counts;
}

RelativeError ComputeRelativeError(const std::vector<Transformation>& T_G_B_gt,
                                   const std::vector<Transformation>& T_G_B_est,
                                   double length_m) {
  if (T_G_B_gt.size() != T_G_B_est.size()) {
    throw std::invalid_argument("ComputeRelativeError: expected equally long pose lists");
  }
  RelativeError r;
  r.length_m = length_m;
  const std::size_t n = T_G_B_gt.size();
  // Travelled distance along the ground truth, path[i] = sum_{k<i} |p_k+1 - p_k|.
  std::vector<double> path(n, 0.0);
  for (std::size_t i = 1; i < n; ++i) {
    path[i] = path[i - 1] + (T_G_B_gt[i].translation() - T_G_B_gt[i - 1].translation()).norm();
  }
  std::vector<double> trans, percent, rot;
  for (std::size_t i = 0; i < n; ++i) {
    // First j with path[j] >= path[i] + d (path is non-decreasing).
    const auto it = std::lower_bound(path.begin() + static_cast<long>(i), path.end(),
                                     path[i] + length_m);
    if (it == path.end()) break;  // no later start can reach d either
    const std::size_t j = static_cast<std::size_t>(it - path.begin());
    const Transformation T_gt_ij = T_G_B_gt[i].inverse() * T_G_B_gt[j];
    const Transformation T_est_ij = T_G_B_est[i].inverse() * T_G_B_est[j];
    const Transformation E = T_gt_ij.inverse() * T_est_ij;
    const double t_err = E.translation().norm();
    trans.push_back(t_err);
    percent.push_back(100.0 * t_err / length_m);
    rot.push_back(AngleBetween(Eigen::Quaterniond::Identity(), E.rotation()) * kRadToDeg);
  }
  r.pairs = trans.size();
  r.translation_m = ComputeErrorStats(trans);
  r.translation_percent = ComputeErrorStats(percent);
  r.rotation_deg = ComputeErrorStats(rot);
  return r;
}

}  // namespace vilma
