// Judging depth maps without ground truth (docs/dense.md): neighbouring keyframes that see the
// same surface must agree on its depth. The depth views of a map, for evaluations with ground
// truth (mapping/evaluation/mesh_evaluation.h).
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

#include "vilma/mapping/dense/depth_map.h"
#include "vilma/mapstore/vi_map.h"

namespace vilma::mapping {

// A depth view: pinhole D with its pose in G.
struct DepthView {
  mapstore::VertexId vertex;
  int camera = 0;
  Eigen::Matrix4d T_G_D = Eigen::Matrix4d::Identity();
  double fx = 0.0, fy = 0.0, cx = 0.0, cy = 0.0;
  int width = 0, height = 0;
};

// The views of every depth resource of the missions (empty: all), in mission and vertex order.
std::vector<DepthView> DepthViews(const mapstore::VIMap& map,
                                  const std::vector<mapstore::MissionId>& missions);

struct DepthConsistencyOptions {
  int pixel_stride = 4;  // every n-th pixel of a depth map in u and v is checked
  std::string Validate() const;
};

struct DepthConsistency {
  int pairs = 0;               // neighbouring keyframes (consecutive in their mission) compared
  long overlapping_points = 0; // points of one view that land on depth in the other
  double median_abs_m = 0.0;   // median |depth predicted from the first view - depth measured|
  double p90_abs_m = 0.0;
  double median_relative = 0.0;  // median of |difference| / depth
  std::string BriefReport() const;
  std::string FullReport() const;  // the brief report as a line (what the command prints)
};

// The same over given pairs of posed depth maps (the first's points checked in the second).
DepthConsistency MeasureDepthConsistency(const std::vector<std::pair<PosedDepth, PosedDepth>>& pairs,
                                         const DepthConsistencyOptions& options = {});

// Each depth map's points (every pixel_stride-th pixel) are moved into the depth view of the
// same camera of the next vertex and compared with the depth measured there (nearest pixel).
// Occlusions and mismatches count as they are: the median is the robust figure.
DepthConsistency MeasureDepthConsistency(const mapstore::VIMap& map,
                                         const std::vector<mapstore::MissionId>& missions,
                                         const DepthConsistencyOptions& options = {});

}  // namespace vilma::mapping
