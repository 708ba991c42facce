// The filter stage: estimator::VioFilterStage (the VioFilter and its one FilterState -> pose
// conversion, shared with `vilma vio`) on the synchronized IMU samples and frames, one pose per
// frame to the publisher (VILMA_ODOM; VILMA_POSE in LOC mode), the systemd watchdog petted
// while it makes progress. It also runs the producer sides of the map stage (MapFeeder: the
// thinning rule, mission breaks at a new M frame) and of the localization stage (LocClient:
// query scheduling, T_G_M), which are filter-thread state.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <vector>

#include "loc_stage.h"
#include "map_stage.h"
#include "pipeline.h"
#include "vilma/core/rig.h"
#include "vilma/estimator/filter_options.h"
#include "vilma/estimator/vio_pipeline.h"

namespace vilma::daemon {

// The daemon options the filter stage uses.
struct FilterStageOptions {
  estimator::FilterOptions estimator;
  int vio_camera = 0;
  int queue_capacity = 4096;       // sync -> filter [items]
  int64_t fault_stall_after = -1;  // test: the filter thread stalls after N frames
  int64_t fault_reset_at = -1;     // test: the filter resets at its N-th frame
  estimator::TimeJumpOptions time_jump;  // restart or resume at a timestamp jump
};

class FilterStage {
 public:
  // `output` belongs to the publisher. Throws InputError for a rig the filter cannot use.
  FilterStage(const FilterStageOptions& options, const SensorRig& rig, Pipeline* pipeline,
              Spsc<OutputItem>* output);

  Spsc<FilterItem>& queue() { return queue_; }
  // Frames queued for the filter or being filtered (the sync stage's backpressure).
  std::atomic<int>& frames_in_flight() { return frames_in_flight_; }
  // Map building: IMU samples, breaks and the wanted frames go to `stage` (before Run).
  void ConnectMap(const MappingOptions& options, MapStage* stage);
  // LOC mode: tracking frames go to `stage`, its results come back (before Run).
  void ConnectLoc(const LocalizationOptions& options, LocStage* stage);
  // The thread loop: until the sync stage is done and the queue is empty. Sets filter_done.
  void Run();

 private:
  void OnFrame(FilterItem& item);

  const FilterStageOptions options_;
  const SensorRig& rig_;
  Pipeline& p_;
  Spsc<FilterItem> queue_;
  Spsc<OutputItem>& output_;
  std::atomic<int> frames_in_flight_{0};
  estimator::VioFilterStage vio_;
  std::unique_ptr<MapFeeder> map_;
  std::unique_ptr<LocClient> loc_;
  int64_t frames_ = 0;
  // The frame as VioFilterStage::AddFrame takes it, per rig camera up to the VIO and the
  // stereo camera (reused: no allocation per frame).
  std::vector<int64_t> frame_t_cam_ns_;
  std::vector<cv::Mat> frame_images_;
};

}  // namespace vilma::daemon
