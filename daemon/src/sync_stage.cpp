#include "sync_stage.h"

#include <limits>
#include <stdexcept>

#include "vilma/core/error.h"
#include "vilma/core/time.h"

namespace vilma::daemon {

SyncStage::SyncStage(const SyncStageOptions& options, Pipeline* pipeline, Spsc<FilterItem>* out,
                     std::atomic<int>* frames_in_flight)
    : options_(options),
      p_(*pipeline),
      queue_(static_cast<std::size_t>(options.input_capacity)),
      out_(*out),
      frames_in_flight_(*frames_in_flight),
      last_forwarded_imu_ns_(std::numeric_limits<int64_t>::min()) {
  try {
    sync_ = std::make_unique<SensorSynchronizer>(options.sync, options.camera_offsets_ns);
  } catch (const std::invalid_argument& e) {
    throw InputError(std::string("daemon options: sync: ") + e.what());
  }
}

// Frames still held by the synchronizer (waiting for IMU that will not come) are released with
// it, back to the pool.
SyncStage::~SyncStage() = default;

void SyncStage::PushFilter(const FilterItem& item) {
  if (!Push(p_, out_, item)) {
    if (item.kind == FilterItem::Kind::kFrame) {
      p_.counters.Add(kFramesDroppedFilterQueue);
      frames_in_flight_.fetch_sub(1);
    } else {
      p_.counters.Add(kImuDroppedFilterQueue);
      p_.log(1, "BUG: filter queue full, IMU sample dropped (queues.filter_capacity)");
    }
    return;
  }
  p_.filter_wake.Notify();
}

void SyncStage::Forward(SyncedFrame& f) {
  const int vio = options_.vio_camera;
  if (f.time_jump_before) {
    // The filter cannot go back in time: it restarts (the synchronizer cleared its history).
    // The filter stage decides: restart, or resume the pre-jump filter (it needs the first
    // stamp on the new time base for that).
    FilterItem restart;
    restart.kind = FilterItem::Kind::kRestart;
    restart.imu.t_ns = f.imu.empty() ? f.t_imu_ns : f.imu.front().t_ns;
    PushFilter(restart);
    last_forwarded_imu_ns_ = std::numeric_limits<int64_t>::min();
  }
  FilterItem out;
  out.kind = FilterItem::Kind::kImu;
  for (const ImuSample& s : f.imu) {
    // Consecutive frames share their boundary sample; forward each sample once.
    if (s.t_ns <= last_forwarded_imu_ns_) continue;
    out.imu = s;
    PushFilter(out);
    last_forwarded_imu_ns_ = s.t_ns;
  }
  const cv::Mat& image = f.images[static_cast<std::size_t>(vio)];
  if (image.empty()) {
    p_.counters.Add(kFramesWithoutVioCamera);
    return;
  }
  if (frames_in_flight_.load() >= options_.max_frames_in_flight) {
    if (!p_.log_mode) {
      p_.counters.Add(kFramesDroppedBusy);
      return;
    }
    while (frames_in_flight_.load() >= options_.max_frames_in_flight && !p_.stop.load()) {
      std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
  }
  FilterItem frame_item;
  frame_item.kind = FilterItem::Kind::kFrame;
  frame_item.t_cam_ns = f.t_cam_ns[static_cast<std::size_t>(vio)];
  frame_item.image = image;
  if (options_.stereo_camera >= 0) {
    // The pair as the synchronizer grouped it (VioPipeline forwards the same frame to the same
    // VioFilterStage): an empty image when the second camera's image did not come in time.
    const std::size_t s = static_cast<std::size_t>(options_.stereo_camera);
    frame_item.stereo_image = f.images[s];
    frame_item.stereo_t_cam_ns = f.t_cam_ns[s];
  }
  if (options_.with_all_images) {
    for (std::size_t c = 0; c < options_.camera_offsets_ns.size(); ++c) {
      frame_item.map_images[c] = f.images[c];
    }
  }
  frame_item.synced_steady_ns = SteadyNs();
  frame_item.recv_steady_ns = frame_item.synced_steady_ns;
  for (const Received& r : received_) {
    if (r.t_cam_ns == frame_item.t_cam_ns) {
      frame_item.recv_steady_ns = r.recv_ns;
      frame_item.recv_latency_us = r.latency_us;
      break;
    }
  }
  frames_in_flight_.fetch_add(1);
  PushFilter(frame_item);
}

void SyncStage::Run() {
  SensorSynchronizer& sync = *sync_;
  const int num_cameras = static_cast<int>(options_.camera_offsets_ns.size());
  const int64_t silence_ns = SecondsToNs(options_.camera_silence_s);
  std::vector<int64_t> last_image_imu_ns(static_cast<std::size_t>(num_cameras), -1);
  std::vector<bool> silent(static_cast<std::size_t>(num_cameras), false);
  InputItem item;
  SyncedFrame frame;
  while (true) {
    bool any = false;
    const int depth = static_cast<int>(queue_.read_available());
    if (depth > p_.input_depth_max.load()) p_.input_depth_max.store(depth);
    while (queue_.pop(item)) {
      any = true;
      if (item.kind == InputItem::Kind::kImu) {
        sync.AddImu(item.imu);
        for (int c = 0; c < num_cameras; ++c) {
          const std::size_t k = static_cast<std::size_t>(c);
          if (last_image_imu_ns[k] >= 0 && !silent[k] &&
              item.imu.t_ns - last_image_imu_ns[k] > silence_ns) {
            silent[k] = true;
            p_.counters.Add(kCameraSilences);
            p_.log(9, "camera %d silent for more than %.2f s", c, options_.camera_silence_s);
          }
        }
      } else {
        const std::size_t k = static_cast<std::size_t>(item.camera);
        last_image_imu_ns[k] = item.t_cam_ns + options_.camera_offsets_ns[k];
        silent[k] = false;
        if (item.camera == options_.vio_camera) {
          received_[next_received_] = {item.t_cam_ns, item.recv_steady_ns, item.recv_latency_us};
          next_received_ = (next_received_ + 1) % received_.size();
        }
        sync.AddImage(item.camera, item.t_cam_ns, item.image);
        item.image.release();  // the synchronizer holds its own reference
      }
      while (sync.PopFrame(&frame)) {
        Forward(frame);
        for (cv::Mat& m : frame.images) m.release();
      }
    }
    const SensorSyncCounters& s = sync.counters();
    for (const SyncCounterField& f : kSyncCounterFields) p_.counters.Set(f.id, s.*f.field);
    if (!any) {
      if (p_.input_done.load() && queue_.read_available() == 0) break;
      p_.sync_wake.Wait(50 * kMs);
    }
  }
  p_.sync_done.store(true);
  p_.filter_wake.Notify();
}

}  // namespace vilma::daemon
