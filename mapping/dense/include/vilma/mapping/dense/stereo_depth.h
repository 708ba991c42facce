// Stereo depth for dense reconstruction (maplab's stereo_dense_reconstruction; docs/dense.md):
// camera pairs of a rig that can be rectified onto one image plane, rectification for any of
// vilma's camera models, OpenCV's semi-global block matching (StereoSGBM), and depth maps as
// resources of the map's vertices.
//
// Rectification (Bouguet's construction, without OpenCV's pinhole-only stereoRectify so that
// equidistant cameras work too): with the right camera's centre b = t_L_R in the left frame,
// the rectified view D has
//   x_D = b / |b|,   z_D = the mean optical axis made orthogonal to x_D,   y_D = z_D x x_D,
// R_L_D = [x_D y_D z_D] and R_R_D = R_R_L R_L_D. Both views share the pinhole K_D, so a point at
// depth z appears in the rows v_L = v_R with disparity d = u_L - u_R = f B / z (B = |b|).
#pragma once

#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "vilma/core/camera.h"
#include "vilma/core/geometry.h"
#include "vilma/core/progress.h"
#include "vilma/core/rig.h"
#include "vilma/mapping/dense/depth_map.h"
#include "vilma/mapstore/vi_map.h"

namespace vilma::mapping {

struct StereoPairOptions {
  double min_baseline_m = 0.02;         // shorter baselines give no usable depth
  double max_axis_angle_deg = 20.0;     // optical axes at most this far apart
  // The baseline must lie in the image plane (left camera's x axis within this angle), which
  // is what planar rectification with horizontal epipolar lines needs.
  double max_baseline_angle_deg = 30.0;
  std::string Validate() const;
};

// Two cameras of a rig that can be rectified; `left` sees `right` on its +x side.
struct StereoPair {
  int left = -1;
  int right = -1;
  Transformation T_L_R;  // right camera in the left one
  double baseline_m = 0.0;
};

// The suitable pairs, each camera in at most one (greedily by baseline, longest first).
std::vector<StereoPair> FindStereoPairs(const SensorRig& rig, const StereoPairOptions& options);
// Why no pair of `rig` qualifies (one line per camera pair), for error messages.
std::string ExplainNoStereoPair(const SensorRig& rig, const StereoPairOptions& options);

// Remap tables of a rectified pair: rectified_left = remap(left, map_left_x, map_left_y), etc.
struct StereoRectification {
  Eigen::Matrix3d R_L_D = Eigen::Matrix3d::Identity();
  Eigen::Matrix3d R_R_D = Eigen::Matrix3d::Identity();
  double f = 0.0, cx = 0.0, cy = 0.0;  // pinhole of D (fx = fy = f) [px]
  int width = 0, height = 0;
  double baseline_m = 0.0;
  cv::Mat map_left_x, map_left_y, map_right_x, map_right_y;  // CV_32FC1
};

// `focal_scale` scales the rectified focal length against the left camera's mean focal
// length (< 1 keeps more of a distorted image).
StereoRectification ComputeStereoRectification(const Camera& left, const Camera& right,
                                               const Transformation& T_L_R,
                                               double focal_scale = 1.0);

struct SgbmOptions {
  int min_disparity = 0;
  int num_disparities = 64;  // multiple of 16: depths down to f B / (min + num) are found
  int block_size = 5;        // odd, 3..11
  int p1_per_pixel = 8;      // P1 = p1_per_pixel * block_size^2 (smoothness, +-1 disparity)
  int p2_per_pixel = 32;     // P2 = p2_per_pixel * block_size^2 (larger jumps), > P1
  int disp12_max_diff = 1;   // left-right check [px]; < 0: off
  int uniqueness_ratio = 15;       // [%]
  int speckle_window_size = 100;   // 0: no speckle filter
  int speckle_range = 2;           // [disparity px]
  int pre_filter_cap = 63;
  std::string mode = "sgbm";       // sgbm (5 paths), hh (8 paths), 3way
  std::string Validate() const;
};

struct StereoDepthOptions {
  StereoPairOptions pairs;
  SgbmOptions sgbm;
  double focal_scale = 1.0;  // see ComputeStereoRectification
  double min_depth_m = 0.2;  // depths outside [min, max] are dropped
  double max_depth_m = 10.0;
  double depth_unit_m = 0.001;  // quantization of the stored depth (16 bits: 65.5 m at 1 mm)
  bool overwrite = true;        // replace depth maps the frames already have
  std::string Validate() const;
};

// Depth of the rectified left view from a pair of 8-bit gray images (CV_8UC1 of the cameras'
// sizes).
DepthMap ComputeStereoDepth(const StereoRectification& rectification, const cv::Mat& left_image,
                            const cv::Mat& right_image, const StereoDepthOptions& options);

struct StereoDenseSummary {
  int pairs_in_rig = 0;
  int vertices = 0;            // vertices of the selected missions
  int depth_maps = 0;          // computed and stored
  int skipped_no_images = 0;   // a camera of the pair has no image resource
  int skipped_existing = 0;    // overwrite off and a depth map was there
  double valid_pixel_share = 0.0;  // mean share of pixels with depth
  std::vector<double> milliseconds_per_depth_map;
  std::string BriefReport() const;
  std::string FullReport() const;  // the brief report as a line (what the command prints)
};

// Computes depth maps for every vertex of `missions` (empty: all) from the image resources of
// each stereo pair of the mission's rig and stores them as depth resources of the left
// camera's frame. Throws InputError (the map unchanged) when a mission's rig has no stereo pair
// or no vertex has images of a pair; Cancelled through `progress` (the depth maps stored so far
// stay: the map is consistent, the console discards its working copy).
StereoDenseSummary StereoDenseReconstruction(mapstore::VIMap* map,
                                             const std::vector<mapstore::MissionId>& missions,
                                             const StereoDepthOptions& options,
                                             ProgressObserver* progress = nullptr);

// An image resource decoded as 8-bit gray; throws InputError naming the vertex and camera.
cv::Mat LoadGrayImage(const mapstore::VIMap& map, const mapstore::VertexId& vertex, int camera);

}  // namespace vilma::mapping
