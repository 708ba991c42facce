// The publishing stage: VILMA_ODOM (and in LOC mode VILMA_POSE, VILMA_LOC) in the filter's
// order, and VILMA_STATUS every status_period_s: the counters, queue depths, CPU load and the
// per-stage latencies (p50 / p99 over the latest frames). Messages go out through the input
// stage's LCM (MessageSink): no LCM here.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "pipeline.h"
#include "vilma/daemon/daemon_options.h"
#include "vilma/daemon/image_pool.h"
#include "vilma/daemon/latency_window.h"

namespace vilma::daemon {

// The daemon options the publisher uses (channel names with the suffix applied).
struct PublishStageOptions {
  std::string odometry_channel, pose_channel, localization_channel, status_channel;
  double status_period_s = 1.0;
  int queue_capacity = 256;    // filter -> publisher [items]
  bool wait_for_map = false;   // map building: the last status comes after the map stage's end
};
PublishStageOptions MakePublishStageOptions(const DaemonOptions& options);

class PublishStage {
 public:
  PublishStage(const PublishStageOptions& options, Pipeline* pipeline, const ImagePool* pool);

  Spsc<OutputItem>& queue() { return queue_; }
  // The thread loop: until the filter (and the map stage) are done and the queue is empty;
  // then a last status (STOPPING).
  void Run(MessageSink* sink);

 private:
  void PublishStatus(MessageSink& sink, int state, int64_t now_ns);

  const PublishStageOptions options_;
  Pipeline& p_;
  const ImagePool& pool_;
  Spsc<OutputItem> queue_;
  std::vector<uint8_t> buffer_;  // encoded messages, reused
  LatencyWindow lat_receive_, lat_sync_, lat_filter_wait_, lat_filter_, lat_publish_, lat_total_;
  int64_t last_cpu_us_ = -1, last_cpu_wall_ns_ = 0;
  double cpu_load_ = 0.0;
  int64_t status_seq_ = 0;
};

}  // namespace vilma::daemon
