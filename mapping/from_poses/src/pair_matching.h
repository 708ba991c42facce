// Matching of keyframe features between two images (private to map_from_poses): descriptor
// matching (mutual nearest neighbours by Hamming distance, Lowe's ratio), verified either by the
// epipolar geometry of a known relative pose (stereo pairs of the rig) or by an
// essential-matrix RANSAC on bearings (vertex pairs whose poses are not trusted).
#pragma once

#include <opencv2/core.hpp>

#include <cstdint>
#include <utility>
#include <vector>

#include "vilma/core/geometry.h"

namespace vilma::mapping::internal {

struct DescriptorMatch {
  int a = 0;  // keypoint index in image a
  int b = 0;  // keypoint index in image b
};

// Mutual nearest neighbours with distance <= max_distance and best < ratio * second best in
// both directions. Deterministic (ties: the lower index).
std::vector<DescriptorMatch> MatchDescriptors(const cv::Mat& descriptors_a,
                                              const cv::Mat& descriptors_b, int max_distance,
                                              double ratio);

// Keeps the matches whose bearings satisfy the epipolar constraint of T_A_B (camera B's pose in
// camera A) within `threshold_rad` (angle between bearing a and the epipolar plane), and whose
// rays meet in front of both cameras.
std::vector<DescriptorMatch> FilterEpipolar(const std::vector<DescriptorMatch>& matches,
                                            const std::vector<Eigen::Vector3d>& bearings_a,
                                            const std::vector<Eigen::Vector3d>& bearings_b,
                                            const Transformation& T_A_B, double threshold_rad);

// Essential-matrix RANSAC (OpenCV's five-point solver on normalized coordinates, seeded) over
// the matches' bearings; returns the inliers (empty when fewer than 5 matches or no model).
std::vector<DescriptorMatch> FilterEssential(const std::vector<DescriptorMatch>& matches,
                                             const std::vector<Eigen::Vector3d>& bearings_a,
                                             const std::vector<Eigen::Vector3d>& bearings_b,
                                             double threshold_normalized, uint64_t seed);

// Union-find over integer nodes.
class DisjointSets {
 public:
  explicit DisjointSets(std::size_t n);
  int Find(int x);
  void Union(int a, int b);

 private:
  std::vector<int> parent_;
  std::vector<int> rank_;
};

}  // namespace vilma::mapping::internal
