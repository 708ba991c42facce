// Reading a camera-IMU calibration recording with a known target (docs/optimization.md
// "Target calibration"): the layout of ../shared/data/euroc_imu_april (the yac library's test
// data, recorded for EuRoC):
//   <dir>/imu0.csv            ts [ns], wx, wy, wz [rad/s], ax, ay, az [m/s^2] (a '#' header)
//   <dir>/<camera>/<ts>.csv   one file per image: the detected target corners, one per row:
//       ts, tag_rows, tag_cols, tag_size, tag_spacing, kp_x, kp_y [px],
//       p_x, p_y, p_z [m, in the target frame T], tag_id, corner_idx
//     (a '#' header; a file with the header only: nothing was detected in that image).
// Every reader throws InputError naming the file, the line and the field, and what it
// expected: a row with the wrong column count, a number that does not parse, a stamp that
// differs from the file name's, a corner listed twice, samples out of time order.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "vilma/core/imu.h"

namespace vilma::mapping {

struct TargetCorner {
  int tag_id = 0;
  int corner_index = 0;                          // 0..3 within the tag
  Eigen::Vector2d uv = Eigen::Vector2d::Zero();  // detected keypoint [px]
  Eigen::Vector3d p_T = Eigen::Vector3d::Zero(); // the corner on the target [m]
  // One id per physical corner (tag_id * 4 + corner_index).
  int64_t key() const { return static_cast<int64_t>(tag_id) * 4 + corner_index; }
};

struct TargetImage {
  int64_t t_ns = 0;  // the image's stamp (camera clock) [ns]
  std::vector<TargetCorner> corners;
};

// One detection file; `t_ns` is the stamp its name gives (rows must carry the same).
TargetImage ReadTargetImage(const std::string& path, int64_t t_ns);
// Every `<ts>.csv` of a camera folder, in time order (the name must be the integer stamp).
std::vector<TargetImage> ReadTargetCamera(const std::string& folder);
// imu0.csv in the layout above, strictly increasing stamps.
std::vector<ImuSample> ReadTargetImu(const std::string& path);

}  // namespace vilma::mapping
