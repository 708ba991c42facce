// What vilma-estimatord's stages share (docs/daemon.md "Pipeline"): the items that move through
// the queues, the queues themselves (bounded lock-free single-producer single-consumer rings),
// the wake-ups of sleeping consumers, the counters and the run's flags. No LCM here: only
// input_stage.cpp includes it; the other stages reach LCM through the two small interfaces at
// the end (MessageSink, MissionStreamTransport).
//
//   input --InputItem--> sync --FilterItem--> filter --OutputItem--> publish
//                                             |   ^ LocResultItem
//                                    LocItem  v   |
//                                             localization
//                                             | MapItem
//                                             v
//                                             map building (+ mission stream)
#pragma once

#include <semaphore.h>

#include <array>
#include <atomic>
#include <boost/lockfree/spsc_queue.hpp>
#include <cerrno>
#include <chrono>
#include <cstdint>
#include <ctime>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <thread>
#include <vector>

#include "vilma/core/geometry.h"
#include "vilma/core/imu.h"
#include "vilma/daemon/daemon_counters.h"
#include "vilma/daemon/systemd_notify.h"
#include "vilma/localizer/localizer.h"
#include "vilma/mapping/map_builder.h"

namespace vilma::mapstore {
class LcmMissionStreamSender;  // mapstore/stream/mission_stream_sender.h
}  // namespace vilma::mapstore

namespace vilma::daemon {

constexpr int64_t kMs = 1000000;  // [ns]

// Cameras whose images the map-builder stage can carry per frame (fixed: no allocation).
constexpr int kMaxMapCameras = 4;

inline int64_t SteadyNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
}

// Row-major copy into an LCM message's 36 doubles.
inline void CopyRowMajor(const Matrix6d& C, double* out36) {
  for (int i = 0; i < 6; ++i) {
    for (int j = 0; j < 6; ++j) out36[6 * i + j] = C(i, j);
  }
}

template <typename T>
using Spsc = boost::lockfree::spsc_queue<T>;

// Pushes, waiting while the queue is full (--input-log: blocking backpressure instead of drops).
// False only when a stop request cut the wait short.
template <typename Queue, typename Item>
bool PushBlocking(Queue& queue, const Item& item, const std::atomic<bool>& stop) {
  while (!queue.push(item)) {
    if (stop.load(std::memory_order_relaxed)) return false;
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  return true;
}

// Wakes a consumer that waits for its queue. A POSIX semaphore is a futex: sem_post makes a
// system call only when a thread sleeps on it, and there is no mutex. The count is kept at
// most 1 (a lost race only causes one spurious wake-up).
class Wakeup {
 public:
  Wakeup() { sem_init(&sem_, 0, 0); }
  ~Wakeup() { sem_destroy(&sem_); }
  Wakeup(const Wakeup&) = delete;
  Wakeup& operator=(const Wakeup&) = delete;
  void Notify() {
    int value = 0;
    sem_getvalue(&sem_, &value);
    if (value < 1) sem_post(&sem_);
  }
  void Wait(int64_t timeout_ns) {
    timespec ts;
    clock_gettime(CLOCK_MONOTONIC, &ts);
    const int64_t ns = ts.tv_nsec + timeout_ns;
    ts.tv_sec += static_cast<time_t>(ns / 1000000000);
    ts.tv_nsec = static_cast<long>(ns % 1000000000);
    while (sem_clockwait(&sem_, CLOCK_MONOTONIC, &ts) == -1 && errno == EINTR) {
    }
  }

 private:
  sem_t sem_;
};

// ---------------------------------------------------------------- items

struct InputItem {  // input -> sync
  enum class Kind : uint8_t { kImu, kImage };
  Kind kind = Kind::kImu;
  int camera = 0;
  ImuSample imu;
  int64_t t_cam_ns = 0;         // image stamp, camera clock [ns]
  int64_t recv_steady_ns = 0;   // when the input thread got it [steady ns]
  int64_t recv_latency_us = 0;  // wall receive time - utime [us] (sensor clock = wall clock?)
  cv::Mat image;                // GRAY8, in a pool slot
};

struct FilterItem {  // sync -> filter
  enum class Kind : uint8_t { kImu, kFrame, kRestart };
  Kind kind = Kind::kImu;
  ImuSample imu;  // kRestart: imu.t_ns is the first IMU stamp on the new time base
  int64_t t_cam_ns = 0;
  int64_t recv_steady_ns = 0;
  int64_t recv_latency_us = 0;
  int64_t synced_steady_ns = 0;
  cv::Mat image;
  // Stereo (estimator stereo.enabled): the second camera's stamp and image of the frame (pool
  // slot), empty when that camera's image did not come (the synchronizer released the frame
  // incomplete): the filter then updates with the VIO camera only (frames_without_stereo).
  int64_t stereo_t_cam_ns = 0;
  cv::Mat stereo_image;
  // With map building: every subscribed camera's image of the frame (pool slots).
  std::array<cv::Mat, kMaxMapCameras> map_images;
};

struct MapItem {  // filter -> map builder
  // kBreak: the filter's M frame starts anew (reset or restart): the mission ends here and the
  // items that follow belong to a new one.
  enum class Kind : uint8_t { kImu, kFrame, kBreak };
  Kind kind = Kind::kImu;
  ImuSample imu;
  mapping::FrameState state;
  std::array<cv::Mat, kMaxMapCameras> images;
};

struct LocItem {  // filter -> localizer: a tracking frame to localize
  int64_t t_ns = 0;
  uint64_t epoch = 0;  // M frame generation (filter restarts and resets increment it)
  Transformation T_M_I;
  cv::Mat image;  // the VIO camera's image (pool slot)
};

struct LocResultItem {  // localizer -> filter
  int64_t t_ns = 0;
  uint64_t epoch = 0;
  Transformation T_M_I;  // the filter's pose at that frame
  localizer::LocalizationStatus status = localizer::LocalizationStatus::kNoKeypoints;
  Transformation T_G_I;
  Matrix6d covariance_I = Matrix6d::Zero();
  int inliers = 0;
  int num_keypoints = 0;
  int num_matches = 0;    // after the covisibility filter (RANSAC input)
  double stage_ms = 0.0;  // extraction + Localize, wall time [ms]
};

// What the filter thread did with a localization result (localization_t.decision).
enum class LocDecision : uint8_t {
  kAccepted,         // into the T_G_M estimate (also a re-initialization)
  kRejectedInliers,  // fewer than localization.min_inliers
  kRejectedGravity,  // T_G_M not a yaw rotation
  kRejectedJump,     // gated against the estimate
  kRejectedStale,    // for a previous M frame
  kFailed            // the library found no pose
};

inline const char* LocDecisionName(LocDecision d) {
  switch (d) {
    case LocDecision::kAccepted: return "accepted";
    case LocDecision::kRejectedInliers: return "rejected_inliers";
    case LocDecision::kRejectedGravity: return "rejected_gravity";
    case LocDecision::kRejectedJump: return "rejected_jump";
    case LocDecision::kRejectedStale: return "rejected_stale";
    case LocDecision::kFailed: return "failed";
  }
  return "failed";
}

// One localization attempt for VILMA_LOC (filter -> publisher, inside OutputItem).
struct LocRecord {
  int64_t t_ns = 0;  // query frame, IMU clock [ns]
  localizer::LocalizationStatus status = localizer::LocalizationStatus::kNoKeypoints;
  LocDecision decision = LocDecision::kFailed;
  int32_t num_keypoints = 0;
  int32_t num_matches = 0;
  int32_t num_inliers = 0;
  double position[3] = {0, 0, 0};        // p_G_I [m]
  double orientation[4] = {1, 0, 0, 0};  // q_G_I (w, x, y, z)
  double covariance[36] = {};            // (position, rotation), global left, as pose_t
  double stage_ms = 0.0;
};

// pose_t status values (msgs/lcm/vilma/pose_t.lcm), so that the stages need no LCM type.
enum PoseStatus : int32_t { kPoseInvalid = 0, kPoseInitializing = 1, kPoseTracking = 2,
                            kPoseLocalized = 3, kPoseLost = 4 };

struct OutputItem {  // filter -> publisher
  // kFrame: a filtered frame (VILMA_ODOM, VILMA_POSE); kLoc: a localization attempt
  // (VILMA_LOC, `loc` only). One queue keeps the filter thread's order on the wire.
  enum class Kind : uint8_t { kFrame, kLoc };
  Kind kind = Kind::kFrame;
  int64_t t_ns = 0;  // state time, IMU clock [ns]
  int32_t status = kPoseInvalid;
  double position[3] = {0, 0, 0};  // p_M_I [m]
  double orientation[4] = {1, 0, 0, 0};  // q_M_I (w, x, y, z)
  double velocity[3] = {0, 0, 0};  // v_M [m/s]
  double angular_velocity[3] = {0, 0, 0};  // omega_I [rad/s]
  double covariance[36] = {};
  int32_t features = 0;
  int64_t recv_steady_ns = 0;
  int64_t recv_latency_us = 0;
  int64_t synced_steady_ns = 0;
  int64_t filter_start_ns = 0;
  int64_t filtered_steady_ns = 0;
  // LOC mode, once T_G_M is known: T_G_I of this frame.
  bool global = false;
  double g_position[3] = {0, 0, 0};
  double g_orientation[4] = {1, 0, 0, 0};
  double g_velocity[3] = {0, 0, 0};
  double g_covariance[36] = {};
  LocRecord loc;  // kind kLoc
};

// ---------------------------------------------------------------- shared state

// The counters (daemon_counters.h), one relaxed atomic each. Each counter is written by one
// stage (its thread) and read by the publisher.
class Counters {
 public:
  Counters() {
    for (auto& c : values_) c.store(0);
  }
  void Add(Counter c, int64_t n = 1) { values_[c].fetch_add(n, std::memory_order_relaxed); }
  void Set(Counter c, int64_t v) { values_[c].store(v, std::memory_order_relaxed); }
  int64_t Get(Counter c) const { return values_[c].load(std::memory_order_relaxed); }
  // The drop counters summed (DaemonSummary::drops, the status's "drops").
  int64_t Drops() const;
  // malformed_imu + malformed_images + images_wrong_size.
  int64_t Malformed() const {
    return Get(kMalformedImu) + Get(kMalformedImages) + Get(kImagesWrongSize);
  }

 private:
  std::array<std::atomic<int64_t>, kNumCounters> values_{};
};

// At most one line per second per topic on stderr (bad input must not flood the journal).
// Topics are numbered by the stages; each topic is used by one thread.
class LimitedLog {
 public:
  LimitedLog() {
    for (auto& t : last_ns_) t.store(0);
  }
  void operator()(int topic, const char* format, ...) __attribute__((format(printf, 3, 4)));

 private:
  std::array<std::atomic<int64_t>, 16> last_ns_{};
};

// What every stage sees: the run's flags, counters, wake-ups and gauges.
struct Pipeline {
  explicit Pipeline(bool log_mode_in) : log_mode(log_mode_in) {}
  // --input-log: blocking backpressure and deterministic hand-offs instead of drops.
  const bool log_mode;
  std::atomic<bool> stop{false};  // RequestStop()
  // Set by each stage when it has drained its input after the previous stage ended.
  std::atomic<bool> input_done{false}, sync_done{false}, filter_done{false}, map_done{false},
      loc_done{false};
  Counters counters;
  LimitedLog log;
  // The consumer of each queue sleeps on its wake-up; the producers post it.
  Wakeup sync_wake, filter_wake, output_wake, map_wake, loc_wake;
  // Gauges for VILMA_STATUS (written by the filter, the sync and the publisher stage).
  std::atomic<int> filter_state{kPoseInitializing};
  std::atomic<int> features{0};
  std::atomic<bool> filter_stalled{false};
  std::atomic<int> input_depth_max{0}, filter_depth_max{0}, output_depth_max{0};
  // Filter thread only (petted while the filter makes progress), and the wiring.
  SystemdNotifier notifier;
};

// Push in the pipeline's mode: blocking with --input-log, else try once.
template <typename Queue, typename Item>
bool Push(const Pipeline& p, Queue& queue, const Item& item) {
  return p.log_mode ? PushBlocking(queue, item, p.stop) : queue.push(item);
}

// ---------------------------------------------------------------- LCM behind interfaces

// Where encoded messages go (the LCM instance that publishes; input_stage.cpp).
class MessageSink {
 public:
  virtual ~MessageSink() = default;
  virtual void Publish(const std::string& channel, const void* data, int size) = 0;
};

// Encodes an LCM message type (generated code: encode/getEncodedSize) into `buffer` (reused:
// no allocation once it is large enough) and publishes it.
template <typename Message>
void PublishMessage(MessageSink& sink, const std::string& channel, const Message& msg,
                    std::vector<uint8_t>* buffer) {
  const int size = msg.getEncodedSize();
  if (buffer->size() < static_cast<std::size_t>(size)) buffer->resize(static_cast<std::size_t>(size));
  msg.encode(buffer->data(), 0, size);
  sink.Publish(channel, buffer->data(), size);
}

// The mission stream's LCM (its own instance, handled by the map thread).
class MissionStreamTransport {
 public:
  virtual ~MissionStreamTransport() = default;
  virtual std::unique_ptr<mapstore::LcmMissionStreamSender> MakeSender(
      const mapstore::MissionId& id, const std::string& name) = 0;
  // Handles acks for up to timeout_ms [ms]; > 0 when a message was handled.
  virtual int Handle(int timeout_ms) = 0;
};

}  // namespace vilma::daemon
