// Depth maps as VI-map resources (ResourceType::kDepthMap, extension "vdepth"; docs/dense.md).
//
// A depth map belongs to one camera C of one vertex (VisualFrame::depth_resource_id). It is the
// metric depth (z along the optical axis) of a distortion-free pinhole view D that shares C's
// optical centre but may be rotated against it: stereo depth lives in the rectified left view
// (R_C_D = the rectifying rotation), imported RGB-D depth in C itself (R_C_D = identity). A
// pixel (u, v) with depth z > 0 is the point
//   p_C = R_C_D * z * K_D^-1 * [u, v, 1]^T.
//
// Encoding: a text header, one "key value..." line each, ended by an empty line, followed by a
// 16-bit PNG of round(z / depth_unit_m) (0 = no depth):
//   vilma-depth 1
//   size WIDTH HEIGHT
//   pinhole FX FY CX CY
//   q_C_D W X Y Z
//   depth_unit_m UNIT
#pragma once

#include <Eigen/Geometry>
#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "vilma/mapstore/id.h"
#include "vilma/mapstore/vi_map.h"

namespace vilma::mapping {

struct DepthMap {
  double fx = 0.0, fy = 0.0, cx = 0.0, cy = 0.0;  // pinhole intrinsics of D [px]
  Eigen::Quaterniond q_C_D = Eigen::Quaterniond::Identity();
  cv::Mat depth_m;  // CV_32FC1, metres along D's z axis; 0 (or not finite): no depth

  int width() const { return depth_m.cols; }
  int height() const { return depth_m.rows; }
  int ValidPixels() const;
  // The point of pixel (u, v) at depth z in C (see the header comment).
  Eigen::Vector3d PointInCamera(double u, double v, double z) const;
};

inline constexpr const char* kDepthMapExtension = "vdepth";
inline constexpr int kDepthMapFormatVersion = 1;

// Encodes with depth quantized to `depth_unit_m` (16 bits: at most 65535 units; deeper pixels
// are dropped, as are non-finite and non-positive ones). Throws std::invalid_argument for an
// empty map or a unit <= 0.
std::string EncodeDepthMap(const DepthMap& depth, double depth_unit_m = 0.001);
// Decodes; throws InputError "WHERE: FIELD: expected ..." for malformed bytes.
DepthMap DecodeDepthMap(const std::string& bytes, const std::string& where);

// A deterministic id for a resource of `vertex` camera `camera` with these bytes: the same
// content gets the same id in every run; other content gets another id unless its CRC-32 and
// size both collide (resources are immutable per id on disk, docs/vi-map.md).
mapstore::ResourceId DerivedResourceId(const mapstore::VertexId& vertex, int camera,
                                       const std::string& kind, const std::string& bytes);

// Loads and decodes a frame's depth map; throws InputError naming the vertex and camera when
// the frame has none or it does not decode.
DepthMap LoadDepthMap(const mapstore::VIMap& map, const mapstore::VertexId& vertex, int camera);

// The pose of a frame's depth view in G: T_G_D = T_G_I T_I_C [R_C_D, 0].
Eigen::Matrix4d DepthViewPose(const mapstore::VIMap& map, const mapstore::VertexId& vertex,
                              int camera, const DepthMap& depth);

// Multi-view depth check (as MVS fusion does): a depth pixel is kept when its point, seen from
// at least `min_consistent_views` other depth views, lands on a depth that agrees within
// `relative_tolerance` (|z_predicted - z_measured| <= tolerance * z_predicted). Views that do
// not see the point neither confirm nor refute it.
struct DepthFilterOptions {
  int neighbours = 2;            // views before and after in the mission compared; 0: no filter
  int min_consistent_views = 1;
  double relative_tolerance = 0.04;
  std::string Validate() const;
};

struct PosedDepth {
  const DepthMap* depth = nullptr;
  Eigen::Matrix4d T_G_D = Eigen::Matrix4d::Identity();
};

// Zeroes the pixels of `view` that fewer than min_consistent_views of `others` confirm;
// returns how many were removed.
int FilterDepthByNeighbours(DepthMap* view, const Eigen::Matrix4d& T_G_D,
                            const std::vector<PosedDepth>& others, const DepthFilterOptions& options);

}  // namespace vilma::mapping
