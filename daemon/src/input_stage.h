// The input stage: LCM subscriptions (live) or an lcm-logger file (--input-log), message
// decoding into pool slots, and the daemon's LCM instances. The only daemon file that includes
// LCM is input_stage.cpp: the publisher and the mission stream reach LCM through the
// MessageSink and MissionStreamTransport it hands out (pipeline.h).
#pragma once

#include <memory>
#include <string>
#include <vector>

#include "pipeline.h"
#include "vilma/core/rig.h"
#include "vilma/daemon/daemon_options.h"
#include "vilma/daemon/image_pool.h"

namespace vilma::daemon {

class InputStage {
 public:
  // Opens LCM (live: subscribes to the IMU and the first `num_cameras` camera channels; log
  // mode: opens the log and a separate LCM instance for the output). Throws InputError for an
  // LCM URL that does not open or an unreadable log.
  InputStage(const DaemonOptions& options, const SensorRig& rig, int num_cameras,
             Pipeline* pipeline, ImagePool* pool, Spsc<InputItem>* out);
  ~InputStage();
  InputStage(const InputStage&) = delete;
  InputStage& operator=(const InputStage&) = delete;

  // The thread loop: until stop or the end of the log. Sets input_done.
  void Run();
  // Where the publisher's messages go (the live LCM, or the log mode's output LCM).
  MessageSink& sink();
  // Closes every LCM instance (a file:// provider flushes its file here). After the threads.
  void Close();

 private:
  struct Lcm;  // the LCM instances and their handlers (input_stage.cpp)
  void Dispatch(const std::string& channel, const void* data, int size);
  void HandleImu(const void* data, int size, int64_t recv_ns, int64_t recv_wall_us);
  void HandleImage(int camera, const void* data, int size, int64_t recv_ns, int64_t recv_wall_us);

  const SensorRig& rig_;
  const std::string input_log_;
  const double log_slot_wait_s_;  // QueueOptions::log_slot_wait_s
  Pipeline& p_;
  ImagePool& pool_;
  Spsc<InputItem>& out_;
  std::string imu_channel_;
  std::vector<std::string> camera_channels_;
  std::unique_ptr<Lcm> lcm_;
};

// The mission stream's own LCM instance (mapping.stream.lcm_url, else the daemon's lcm_url),
// handled by the map thread. Throws InputError for a URL that does not open.
std::unique_ptr<MissionStreamTransport> OpenMissionStreamTransport(const DaemonOptions& options);

}  // namespace vilma::daemon
