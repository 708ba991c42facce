// The sync stage: IMU samples and images from the input stage through the SensorSynchronizer
// into frames for the filter (docs/daemon.md "Pipeline"). Forwards every IMU sample once,
// thins frames while the filter is behind (live) or waits for it (--input-log), turns a time
// jump into a filter restart, and reports silent cameras.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <vector>

#include "pipeline.h"
#include "vilma/core/sensor_sync.h"

namespace vilma::daemon {

// The daemon options the sync stage uses.
struct SyncStageOptions {
  SensorSyncOptions sync;
  std::vector<int64_t> camera_offsets_ns;  // per subscribed camera (rig time_offset_ns)
  int vio_camera = 0;                      // the filter's camera
  int stereo_camera = -1;                  // stereo: the second camera (-1: mono)
  double camera_silence_s = 0.5;           // silence reported after this long [s of IMU time]
  int input_capacity = 4096;               // queue input -> sync [items]
  int max_frames_in_flight = 2;            // frames queued for the filter at most
  bool with_all_images = false;            // map building: every camera's image goes along
};

class SyncStage {
 public:
  // `out` and `frames_in_flight` belong to the filter stage (frames queued or being filtered).
  // Throws InputError for invalid synchronizer options.
  SyncStage(const SyncStageOptions& options, Pipeline* pipeline, Spsc<FilterItem>* out,
            std::atomic<int>* frames_in_flight);
  ~SyncStage();

  Spsc<InputItem>& queue() { return queue_; }
  // The thread loop: until the input stage is done and the queue is empty. Sets sync_done.
  void Run();

 private:
  void Forward(SyncedFrame& frame);
  void PushFilter(const FilterItem& item);

  const SyncStageOptions options_;
  Pipeline& p_;
  Spsc<InputItem> queue_;
  Spsc<FilterItem>& out_;
  std::atomic<int>& frames_in_flight_;
  std::unique_ptr<SensorSynchronizer> sync_;
  int64_t last_forwarded_imu_ns_;
  // Receive times of the latest VIO-camera images, by stamp (frames come out in order).
  struct Received {
    int64_t t_cam_ns = -1, recv_ns = 0, latency_us = 0;
  };
  std::array<Received, 64> received_{};
  std::size_t next_received_ = 0;
};

}  // namespace vilma::daemon
