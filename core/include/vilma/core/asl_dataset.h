// ASL / EuRoC dataset folders (architecture.md section 7):
//   mav0/cam<i>/data.csv + data/<t_ns>.png, mav0/imu0/data.csv,
//   mav0/state_groundtruth_estimate0/data.csv, */sensor.yaml.
// Reading tolerates the inconsistencies of real datasets (rows without an image) with a
// warning; structural errors throw InputError naming file, line and field.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstddef>
#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "vilma/core/atomic_file.h"  // WriteFileAtomically, used by the writers of datasets
#include "vilma/core/imu.h"

namespace vilma {

struct CameraFrame {
  int64_t t_ns = 0;
  std::string image_path;  // absolute or relative to the working directory
};

struct AslCamera {
  std::string name;  // "cam0"
  std::vector<CameraFrame> frames;  // sorted by time, only rows whose image exists
};

// EuRoC ground truth row: position, orientation, velocity, biases of the IMU (body) frame in
// the world frame W.
struct GroundTruthState {
  int64_t t_ns = 0;
  Eigen::Vector3d p_W_I = Eigen::Vector3d::Zero();
  Eigen::Quaterniond q_W_I = Eigen::Quaterniond::Identity();
  Eigen::Vector3d v_W = Eigen::Vector3d::Zero();
  Eigen::Vector3d b_g = Eigen::Vector3d::Zero();
  Eigen::Vector3d b_a = Eigen::Vector3d::Zero();
};

class AslDataset {
 public:
  // Opens `root` (a folder that contains `mav0/`, or `mav0` itself). Cameras are the
  // `cam<i>` folders found; IMU and ground truth are optional (empty if absent).
  static AslDataset Open(const std::string& root);

  const std::string& mav0_dir() const { return mav0_dir_; }
  const std::vector<AslCamera>& cameras() const { return cameras_; }
  const std::vector<ImuSample>& imu() const { return imu_; }
  const std::vector<GroundTruthState>& ground_truth() const { return ground_truth_; }
  // Problems that did not stop the reading (e.g. "cam1/data.csv: 5 rows name images that do
  // not exist; skipped").
  const std::vector<std::string>& warnings() const { return warnings_; }

  // Loads one image as 8-bit grayscale (or as stored with `unchanged`); throws InputError.
  static cv::Mat LoadImage(const std::string& path, bool unchanged = false);

 private:
  std::string mav0_dir_;
  std::vector<AslCamera> cameras_;
  std::vector<ImuSample> imu_;
  std::vector<GroundTruthState> ground_truth_;
  std::vector<std::string> warnings_;
};

// One message of a dataset in arrival order: IMU sample `index` (stream -1) or frame `index` of
// camera `stream`.
struct AslEvent {
  int64_t t_ns = 0;
  int stream = -1;
  std::size_t index = 0;
};

// The dataset's messages in the order vilma-replay sends (and logs) them: the IMU samples and
// the frames of `cameras` merged by stamp, at equal stamps the IMU first and then the cameras by
// index (a stable sort), only stamps in [t_begin_ns, t_end_ns]. Feeding a VioPipeline in this
// order is what makes `vilma vio` equal to a replay through the daemon. Throws
// std::out_of_range for a camera the dataset does not have.
std::vector<AslEvent> ArrivalOrder(const AslDataset& dataset, const std::vector<int>& cameras,
                                   int64_t t_begin_ns = INT64_MIN, int64_t t_end_ns = INT64_MAX);

// Writes an ASL dataset incrementally: images go straight to disk, the CSV files are written
// by Finish() (atomically: temporary file + rename).
class AslDatasetWriter {
 public:
  // Creates `root/mav0/...` for `num_cameras` cameras (cam0, cam1, ...).
  AslDatasetWriter(const std::string& root, int num_cameras);

  void AddImage(int camera_index, int64_t t_ns, const cv::Mat& image);
  void AddImu(const ImuSample& sample);
  void AddGroundTruth(const GroundTruthState& state);
  void Finish();

  const std::string& mav0_dir() const { return mav0_dir_; }

 private:
  std::string mav0_dir_;
  std::vector<std::vector<int64_t>> camera_stamps_;
  std::vector<ImuSample> imu_;
  std::vector<GroundTruthState> ground_truth_;
};

}  // namespace vilma
