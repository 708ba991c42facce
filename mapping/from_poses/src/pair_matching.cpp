#include "pair_matching.h"

#include <opencv2/calib3d.hpp>
#include <opencv2/core/hal/hal.hpp>

#include <algorithm>
#include <cmath>
#include <limits>
#include <numeric>

namespace vilma::mapping::internal {
namespace {

struct Best {
  int index = -1;
  int distance = std::numeric_limits<int>::max();
  int second = std::numeric_limits<int>::max();
};

// For every row of `from`, the nearest and second-nearest distance among the rows of `to`.
std::vector<Best> NearestNeighbours(const cv::Mat& from, const cv::Mat& to) {
  std::vector<Best> best(static_cast<std::size_t>(from.rows));
  for (int i = 0; i < from.rows; ++i) {
    Best& b = best[static_cast<std::size_t>(i)];
    const uint8_t* a = from.ptr<uint8_t>(i);
    for (int j = 0; j < to.rows; ++j) {
      const int d = cv::hal::normHamming(a, to.ptr<uint8_t>(j), from.cols);
      if (d < b.distance) {
        b.second = b.distance;
        b.distance = d;
        b.index = j;
      } else if (d < b.second) {
        b.second = d;
      }
    }
  }
  return best;
}

bool PassesRatio(const Best& b, int max_distance, double ratio) {
  return b.index >= 0 && b.distance <= max_distance &&
         (b.second == std::numeric_limits<int>::max() || b.distance < ratio * b.second);
}

}  // namespace

std::vector<DescriptorMatch> MatchDescriptors(const cv::Mat& descriptors_a,
                                              const cv::Mat& descriptors_b, int max_distance,
                                              double ratio) {
  std::vector<DescriptorMatch> matches;
  if (descriptors_a.empty() || descriptors_b.empty()) return matches;
  const std::vector<Best> ab = NearestNeighbours(descriptors_a, descriptors_b);
  const std::vector<Best> ba = NearestNeighbours(descriptors_b, descriptors_a);
  for (int i = 0; i < descriptors_a.rows; ++i) {
    const Best& forward = ab[static_cast<std::size_t>(i)];
    if (!PassesRatio(forward, max_distance, ratio)) continue;
    const Best& backward = ba[static_cast<std::size_t>(forward.index)];
    if (backward.index != i || !PassesRatio(backward, max_distance, ratio)) continue;
    matches.push_back({i, forward.index});
  }
  return matches;
}

std::vector<DescriptorMatch> FilterEpipolar(const std::vector<DescriptorMatch>& matches,
                                            const std::vector<Eigen::Vector3d>& bearings_a,
                                            const std::vector<Eigen::Vector3d>& bearings_b,
                                            const Transformation& T_A_B, double threshold_rad) {
  // Epipolar plane of a match: spanned by the baseline t = p_A_B and the ray R_A_B f_b; its
  // normal n = t x (R f_b). The angle of f_a to the plane is asin(|n . f_a| / |n|).
  const Eigen::Vector3d t = T_A_B.translation();
  const Eigen::Matrix3d R = T_A_B.rotation().toRotationMatrix();
  std::vector<DescriptorMatch> kept;
  for (const DescriptorMatch& m : matches) {
    const Eigen::Vector3d& f_a = bearings_a[static_cast<std::size_t>(m.a)];
    const Eigen::Vector3d f_b_in_a = R * bearings_b[static_cast<std::size_t>(m.b)];
    const Eigen::Vector3d n = t.cross(f_b_in_a);
    if (n.norm() < 1e-12) continue;
    const double angle = std::asin(std::min(1.0, std::abs(n.dot(f_a)) / n.norm()));
    if (angle > threshold_rad) continue;
    // Depths along both rays (least squares): d_a f_a - d_b f_b_in_a = t.
    Eigen::Matrix<double, 3, 2> A;
    A.col(0) = f_a;
    A.col(1) = -f_b_in_a;
    const Eigen::Vector2d depths = A.colPivHouseholderQr().solve(t);
    if (depths(0) <= 0.0 || depths(1) <= 0.0) continue;
    kept.push_back(m);
  }
  return kept;
}

std::vector<DescriptorMatch> FilterEssential(const std::vector<DescriptorMatch>& matches,
                                             const std::vector<Eigen::Vector3d>& bearings_a,
                                             const std::vector<Eigen::Vector3d>& bearings_b,
                                             double threshold_normalized, uint64_t seed) {
  std::vector<cv::Point2d> xa, xb;
  std::vector<DescriptorMatch> usable;
  for (const DescriptorMatch& m : matches) {
    const Eigen::Vector3d& fa = bearings_a[static_cast<std::size_t>(m.a)];
    const Eigen::Vector3d& fb = bearings_b[static_cast<std::size_t>(m.b)];
    if (fa.z() <= 1e-6 || fb.z() <= 1e-6) continue;  // the normalized plane needs z > 0
    xa.emplace_back(fa.x() / fa.z(), fa.y() / fa.z());
    xb.emplace_back(fb.x() / fb.z(), fb.y() / fb.z());
    usable.push_back(m);
  }
  std::vector<DescriptorMatch> kept;
  if (usable.size() < 5) return kept;
  // OpenCV's RANSAC draws from cv::theRNG(): seeding it makes the result deterministic.
  cv::theRNG().state = seed == 0 ? 1 : seed;
  cv::Mat mask;
  const cv::Mat E = cv::findEssentialMat(xa, xb, cv::Mat::eye(3, 3, CV_64F), cv::RANSAC, 0.999,
                                         threshold_normalized, mask);
  if (E.empty() || E.rows != 3) return kept;
  for (std::size_t i = 0; i < usable.size(); ++i) {
    if (mask.at<uint8_t>(static_cast<int>(i)) != 0) kept.push_back(usable[i]);
  }
  return kept;
}

DisjointSets::DisjointSets(std::size_t n) : parent_(n), rank_(n, 0) {
  std::iota(parent_.begin(), parent_.end(), 0);
}

int DisjointSets::Find(int x) {
  while (parent_[static_cast<std::size_t>(x)] != x) {
    int& p = parent_[static_cast<std::size_t>(x)];
    p = parent_[static_cast<std::size_t>(p)];  // path halving
    x = p;
  }
  return x;
}

void DisjointSets::Union(int a, int b) {
  a = Find(a);
  b = Find(b);
  if (a == b) return;
  // Union by rank; on ties the smaller root wins, so components do not depend on order.
  if (rank_[static_cast<std::size_t>(a)] < rank_[static_cast<std::size_t>(b)] ||
      (rank_[static_cast<std::size_t>(a)] == rank_[static_cast<std::size_t>(b)] && b < a)) {
    std::swap(a, b);
  }
  parent_[static_cast<std::size_t>(b)] = a;
  if (rank_[static_cast<std::size_t>(a)] == rank_[static_cast<std::size_t>(b)]) {
    ++rank_[static_cast<std::size_t>(a)];
  }
}

}  // namespace vilma::mapping::internal
