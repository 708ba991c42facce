#include "vilma/daemon/estimator_daemon.h"

#include <semaphore.h>
#include <sys/resource.h>

#include <array>
#include <atomic>
#include <boost/lockfree/spsc_queue.hpp>
#include <cerrno>
#include <chrono>
#include <cstdarg>
#include <cstdio>
#include <ctime>
#include <deque>
#include <filesystem>
#include <limits>
#include <lcm/lcm-cpp.hpp>
#include <optional>
#include <random>
#include <sstream>
#include <thread>
#include <vector>

#include <vilma/localization_t.hpp>
#include <vilma/pose_t.hpp>
#include <vilma/status_t.hpp>

#include "vilma/core/error.h"
#include "vilma/core/sensor_sync.h"
#include "vilma/core/time.h"
#include "vilma/daemon/daemon_counters.h"
#include "vilma/daemon/image_pool.h"
#include "vilma/daemon/latency_window.h"
#include "vilma/daemon/systemd_notify.h"
#include "vilma/drivers/lcm_convert.h"
#include "vilma/drivers/lcm_log.h"
#include "vilma/drivers/lcm_url.h"
#include "vilma/estimator/filter_state.h"
#include "vilma/estimator/global_frame_estimator.h"
#include "vilma/estimator/vio_filter.h"
#include "vilma/localizer/keyframe_features.h"
#include "vilma/localizer/localizer.h"
#include "vilma/mapping/locmap/localization_map_builder.h"
#include "vilma/mapping/map_builder.h"
#include "vilma/mapstore/delta_split.h"
#include "vilma/mapstore/map_io.h"
#include "vilma/mapstore/stream/mission_stream_sender.h"

namespace vilma::daemon {
namespace {

// Covariance of (R a, R b) when (a, b) has covariance C: A C A^T with A = diag(R, R) (a
// position and a rotation error moved into another frame).
Matrix6d RotateCovariance(const Eigen::Matrix3d& R, const Matrix6d& C) {
  Matrix6d A = Matrix6d::Zero();
  A.block<3, 3>(0, 0) = R;
  A.block<3, 3>(3, 3) = R;
  return A * C * A.transpose();
}

// Row-major copy into an LCM message's 36 doubles.
void CopyRowMajor(const Matrix6d& C, double* out36) {
  for (int i = 0; i < 6; ++i) {
    for (int j = 0; j < 6; ++j) out36[6 * i + j] = C(i, j);
  }
}

constexpr int64_t kMs = 1000000;  // [ns]

int64_t SteadyNs() {
  return std::chrono::duration_cast<std::chrono::nanoseconds>(
             std::chrono::steady_clock::now().time_since_epoch())
      .count();
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

// Counters that are drops (summed into "drops").
constexpr std::array<Counter, 11> kDropCounters = {
    kImagesDroppedPool,     kImagesDroppedInputQueue, kImuDroppedInputQueue,
    kImuDroppedFilterQueue, kFramesDroppedBusy,       kFramesDroppedFilterQueue,
    kPosesDroppedOutput,    kSyncFramesDroppedOverflow, kMapFramesDropped,
    kMapImuDropped,         kLocMessagesDropped};

// Cameras whose images the map-builder stage can carry per frame (fixed: no allocation).
constexpr int kMaxMapCameras = 4;

struct InputItem {
  enum class Kind : uint8_t { kImu, kImage };
  Kind kind = Kind::kImu;
  int camera = 0;
  ImuSample imu;
  int64_t t_cam_ns = 0;         // image stamp, camera clock [ns]
  int64_t recv_steady_ns = 0;   // when the input thread got it [steady ns]
  int64_t recv_latency_us = 0;  // wall receive time - utime [us] (sensor clock = wall clock?)
  cv::Mat image;                // GRAY8, in a pool slot
};

struct FilterItem {
  enum class Kind : uint8_t { kImu, kFrame, kRestart };
  Kind kind = Kind::kImu;
  ImuSample imu;
  int64_t t_cam_ns = 0;
  int64_t recv_steady_ns = 0;
  int64_t recv_latency_us = 0;
  int64_t synced_steady_ns = 0;
  cv::Mat image;
  // With map building: every subscribed camera's image of the frame (pool slots).
  std::array<cv::Mat, kMaxMapCameras> map_images;
};

// Filter -> map builder.
struct MapItem {
  // kBreak: the filter's M frame starts anew (reset or restart): the mission ends here and the
  // items that follow belong to a new one.
  enum class Kind : uint8_t { kImu, kFrame, kBreak };
  Kind kind = Kind::kImu;
  ImuSample imu;
  mapping::FrameState state;
  std::array<cv::Mat, kMaxMapCameras> images;
};

// Filter -> localizer: a tracking frame to localize.
struct LocItem {
  int64_t t_ns = 0;
  uint64_t epoch = 0;  // M frame generation (filter restarts and resets increment it)
  Transformation T_M_I;
  cv::Mat image;       // the VIO camera's image (pool slot)
};

// Localizer -> filter.
struct LocResultItem {
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

const char* LocDecisionName(LocDecision d) {
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

struct OutputItem {
  // kFrame: a filtered frame (VILMA_ODOM, VILMA_POSE); kLoc: a localization attempt
  // (VILMA_LOC, `loc` only). One queue keeps the filter thread's order on the wire.
  enum class Kind : uint8_t { kFrame, kLoc };
  Kind kind = Kind::kFrame;
  int64_t t_ns = 0;  // state time, IMU clock [ns]
  int32_t status = pose_t::INVALID;
  double position[3] = {0, 0, 0};
  double orientation[4] = {1, 0, 0, 0};
  double velocity[3] = {0, 0, 0};
  double angular_velocity[3] = {0, 0, 0};
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

template <typename T>
using Spsc = boost::lockfree::spsc_queue<T>;

}  // namespace

struct EstimatorDaemon::Impl {
  Impl(const DaemonOptions& o, const SensorRig& r);

  // ---- configuration ----
  DaemonOptions options;
  SensorRig rig;
  bool log_mode = false;
  int num_cameras = 0;
  std::vector<std::string> camera_channels;
  std::string imu_channel, odom_channel, status_channel;
  std::vector<int64_t> camera_offsets_ns;

  // ---- shared state ----
  std::atomic<bool> stop{false};
  std::atomic<bool> input_done{false}, sync_done{false}, filter_done{false}, map_done{false};
  std::atomic<bool> loc_done{false};
  std::atomic<int> frames_in_flight{0};
  std::array<std::atomic<int64_t>, kNumCounters> counters{};
  std::atomic<int> filter_state{pose_t::INITIALIZING};
  std::atomic<int> features{0};
  std::atomic<bool> filter_stalled{false};
  std::atomic<int> input_depth_max{0}, filter_depth_max{0}, output_depth_max{0};
  SystemdNotifier notifier;

  // Declared before the queues and the synchronizer that hold its images: destroyed last.
  std::unique_ptr<ImagePool> pool;
  Spsc<InputItem> input_queue;
  Spsc<FilterItem> filter_queue;
  Spsc<OutputItem> output_queue;
  std::unique_ptr<Spsc<MapItem>> map_queue;  // with map building only
  Wakeup sync_wake, filter_wake, output_wake, map_wake;
  // Built in the constructor, so that bad options or rigs throw there (in the caller's thread);
  // then owned by the sync and filter threads. Declared after the pool: destroyed before it.
  std::unique_ptr<SensorSynchronizer> synchronizer;
  std::unique_ptr<estimator::VioFilter> vio_filter;

  // ---- map-builder stage (map thread only, after construction) ----
  bool mapping_enabled = false;
  std::unique_ptr<mapping::MapBuilder> builder;
  std::unique_ptr<lcm::LCM> stream_lcm;  // the mission stream's own LCM, handled by the map thread
  std::unique_ptr<mapstore::LcmMissionStreamSender> stream;
  std::atomic<int> map_frames_in_flight{0};
  // Missions (docs/daemon.md "Missions and filter resets"): one per continuous odometry
  // segment. Mission k has the seed MissionSeed(k) and the name MissionName(k).
  mapping::MapBuilderOptions map_builder_options;  // cameras resolved
  uint64_t mission_seed_base = 0;
  int mission_index = 0;
  mapstore::MissionStreamSenderOptions sender_options;
  std::vector<mapstore::VIMap> finished_maps;  // kept missions, for --save-map
  int missions_kept = 0;
  bool map_run_ended = false;  // the last mission ended (its counters are in map_stats_done)
  mapping::MapBuilderStats map_stats_done;  // counters of the kept missions that ended
  mapstore::MissionStreamSenderCounters stream_counters_done;  // of the senders that ended
  // A mission that ended while streaming: its last delta and END go out while the next
  // mission streams (the map thread never waits for mapstored in the middle of a run).
  struct EndingStream {
    std::unique_ptr<mapstore::LcmMissionStreamSender> sender;
    std::deque<mapstore::MissionDelta> backlog;
    int64_t deadline_ns = 0;  // steady clock: stream.end_timeout_s after the mission ended
  };
  std::vector<EndingStream> ending_streams;
  int streams_finished = 0, streams_unfinished = 0;
  // Result of the end of the mission (read after the map thread joined).
  bool map_saved = false;
  bool stream_finished = false;
  std::string map_error;
  std::string map_report;

  // ---- localizer stage ----
  bool localization_enabled = false;
  std::unique_ptr<localizer::Localizer> loc;                  // const, used by the loc thread
  std::unique_ptr<localizer::FeatureExtractor> loc_extractor;  // loc thread only
  std::unique_ptr<Spsc<LocItem>> loc_queue;                   // filter -> localizer
  std::unique_ptr<Spsc<LocResultItem>> loc_result_queue;      // localizer -> filter
  std::atomic<int> loc_in_flight{0};
  Wakeup loc_wake;
  std::string loc_report;
  std::string pose_channel, loc_channel;

  // ---- input stage (input thread only) ----
  std::unique_ptr<lcm::LCM> input_lcm;   // live mode
  std::unique_ptr<LcmLogReader> reader;  // log mode
  std::unique_ptr<lcm::LCM> output_lcm;  // log mode: a separate instance for output
  lcm::LCM* publish_lcm = nullptr;
  image_t image_msg;  // reused: its data vector keeps its capacity
  imu_t imu_msg;
  std::array<std::atomic<int64_t>, 16> last_log_ns{};  // per topic; topics are used by one thread each

  void Count(Counter c, int64_t n = 1) { counters[c].fetch_add(n, std::memory_order_relaxed); }
  int64_t Get(Counter c) const { return counters[c].load(std::memory_order_relaxed); }
  // At most one line per second per topic on stderr (bad input must not flood the journal).
  void LogLimited(int topic, const char* format, ...) __attribute__((format(printf, 3, 4)));

  void OnLcmMessage(const lcm::ReceiveBuffer* rbuf, const std::string& channel);
  void Dispatch(const std::string& channel, const void* data, int size);
  void HandleImu(const void* data, int size, int64_t recv_ns, int64_t recv_wall_us);
  void HandleImage(int camera, const void* data, int size, int64_t recv_ns, int64_t recv_wall_us);
  template <typename Queue, typename Item>
  bool PushBlocking(Queue& queue, const Item& item);
  void InputLoop();

  // ---- sync stage ----
  void SyncLoop();
  void PushFilter(const FilterItem& item);

  // ---- filter stage ----
  void FilterLoop();
  void PushMap(const MapItem& item);

  // ---- map-builder stage ----
  void SetUpMapping();
  uint64_t MissionSeed(int k) const;
  std::string MissionName(int k) const;
  std::unique_ptr<mapstore::LcmMissionStreamSender> MakeSender(const mapstore::MissionId& id,
                                                              const std::string& name);
  void MapLoop();
  void CopyMapCounters();

  // ---- publisher ----
  void PublishLoop();

  // ---- localizer stage ----
  void SetUpLocalization();
  void LocLoop();
  void PublishStatus(int state, int64_t now_ns);
  LatencyWindow lat_receive, lat_sync, lat_filter_wait, lat_filter, lat_publish, lat_total;
  int64_t last_cpu_us = -1, last_cpu_wall_ns = 0;
  double cpu_load = 0.0;
  int64_t status_seq = 0;
};

EstimatorDaemon::Impl::Impl(const DaemonOptions& o, const SensorRig& r)
    : options(o),
      rig(r),
      input_queue(static_cast<std::size_t>(o.queues.input_capacity)),
      filter_queue(static_cast<std::size_t>(o.queues.filter_capacity)),
      output_queue(static_cast<std::size_t>(o.queues.output_capacity)) {
  const std::string error = options.Validate();
  if (!error.empty()) throw InputError("daemon options: " + error);
  log_mode = !options.input_log.empty();
  num_cameras = std::min(static_cast<int>(rig.cameras.size()),
                         static_cast<int>(options.channels.cameras.size()));
  if (options.vio_camera >= num_cameras) {
    throw InputError(FormatInputError("rig", "cameras[" + std::to_string(options.vio_camera) + "]",
                                      "the camera given by vio_camera (the rig has " +
                                          std::to_string(rig.cameras.size()) + ")"));
  }
  std::size_t slot_bytes = 0;
  for (int i = 0; i < num_cameras; ++i) {
    const Camera& c = rig.cameras[static_cast<std::size_t>(i)].camera;
    slot_bytes = std::max(slot_bytes, static_cast<std::size_t>(c.width()) *
                                          static_cast<std::size_t>(c.height()));
    camera_channels.push_back(
        ChannelName(options.channels.cameras[static_cast<std::size_t>(i)], options.channel_suffix));
    camera_offsets_ns.push_back(rig.cameras[static_cast<std::size_t>(i)].time_offset_ns);
  }
  // Every slot the synchronizer and the queues can hold at once, plus margin: with fewer, the
  // log mode's blocking input could wait for a slot that only newer input would free.
  // With map building, a frame queued for the filter holds every camera's image (and the
  // filter's current frame still holds them while it waits to hand them to the builder), and
  // the frames queued for the builder (mapping.max_frames_in_flight, the one it works on
  // included) hold theirs too.
  mapping_enabled = options.mapping.enabled;
  localization_enabled = options.localization.enabled;
  const int needed = RequiredImagePoolSlots(options, num_cameras);
  if (options.queues.image_pool_slots < needed) {
    throw InputError(FormatInputError("daemon options", "queues.image_pool_slots",
                                      ImagePoolRuleText(options, num_cameras)));
  }
  pool = std::make_unique<ImagePool>(options.queues.image_pool_slots, slot_bytes);
  try {
    synchronizer = std::make_unique<SensorSynchronizer>(options.sync, camera_offsets_ns);
  } catch (const std::invalid_argument& e) {
    throw InputError(std::string("daemon options: sync: ") + e.what());
  }
  vio_filter = std::make_unique<estimator::VioFilter>(rig, options.vio_camera, options.estimator);
  imu_channel = ChannelName(options.channels.imu, options.channel_suffix);
  odom_channel = ChannelName(options.channels.odometry, options.channel_suffix);
  status_channel = ChannelName(options.channels.status, options.channel_suffix);
  pose_channel = ChannelName(options.channels.pose, options.channel_suffix);
  loc_channel = ChannelName(options.channels.localization, options.channel_suffix);
  for (auto& c : counters) c.store(0);
  for (auto& t : last_log_ns) t.store(0);

  const std::string url = ResolveLcmUrl(options.lcm_url);
  if (log_mode) {
    reader = std::make_unique<LcmLogReader>(options.input_log);
    output_lcm = std::make_unique<lcm::LCM>(url);
    if (!output_lcm->good()) {
      throw InputError(FormatInputError("--lcm-url", url, "an LCM URL that opens"));
    }
    publish_lcm = output_lcm.get();
  } else {
    input_lcm = std::make_unique<lcm::LCM>(WithDefaultRecvBufSize(url));
    if (!input_lcm->good()) {
      throw InputError(FormatInputError("--lcm-url", url, "an LCM URL that opens"));
    }
    publish_lcm = input_lcm.get();
    input_lcm->subscribe(imu_channel, &Impl::OnLcmMessage, this);
    for (const std::string& channel : camera_channels) {
      input_lcm->subscribe(channel, &Impl::OnLcmMessage, this);
    }
  }
  if (mapping_enabled) SetUpMapping();
  if (localization_enabled) SetUpLocalization();
}

void EstimatorDaemon::Impl::SetUpLocalization() {
  const LocalizationOptions& lo = options.localization;
  namespace fs = std::filesystem;
  std::error_code ec;
  const auto t0 = std::chrono::steady_clock::now();
  auto map = std::make_shared<localizer::LocalizationMap>();
  if (fs::is_directory(lo.map, ec)) {
    // A VI-map folder: the localization summary map is built from it now.
    const mapstore::VIMap vimap = mapstore::LoadMap(lo.map);
    localizer::LocalizerOptions lopt = lo.localizer_file.empty()
                                           ? localizer::LocalizerOptions()
                                           : localizer::LoadLocalizerOptions(lo.localizer_file);
    mapping::LocalizationMapReport report;
    *map = mapping::BuildLocalizationMap(vimap, lopt.map, &report);
    if (report.missions_skipped > 0) {
      std::fprintf(stderr,
                   "vilma-estimatord: localization map %s: %d of %zu missions used (the others "
                   "are not anchored: their frames are unknown in G)\n",
                   lo.map.c_str(), report.missions_used, vimap.mission_ids().size());
    }
  } else if (fs::is_regular_file(lo.map, ec)) {
    *map = localizer::LoadLocalizationMap(lo.map);
  } else {
    throw InputError(FormatInputError(lo.map, "localization.map / --localization-map",
                                      "a localization map file or a VI-map folder"));
  }
  if (map->num_landmarks() == 0) {
    throw InputError(FormatInputError(lo.map, "localization.map", "a map with good landmarks"));
  }
  const localizer::LocalizerOptions lopt = lo.localizer_file.empty()
                                               ? localizer::LocalizerOptions()
                                               : localizer::LoadLocalizerOptions(lo.localizer_file);
  loc = std::make_unique<localizer::Localizer>(map, lopt);
  // The query profile (localization.features): by default the map builder's features with a
  // scale pyramid, so that the query matches the map across distances.
  loc_extractor = std::make_unique<localizer::FeatureExtractor>(lo.features);
  loc_queue = std::make_unique<Spsc<LocItem>>(4);
  loc_result_queue = std::make_unique<Spsc<LocResultItem>>(4);
  std::ostringstream r;
  r << "localization map " << lo.map << ": " << map->num_landmarks() << " landmarks, "
    << map->num_descriptors() << " descriptors, loaded and indexed in "
    << static_cast<int>(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count())
    << " ms; query features "
    << (lo.features_file.empty() ? std::string("built-in profile") : lo.features_file) << " ("
    << lo.features.detector.num_levels << " levels, " << lo.features.detector.max_keypoints
    << " keypoints at most)";
  loc_report = r.str();
  std::fprintf(stderr, "vilma-estimatord: %s\n", loc_report.c_str());
}

// The localizer thread: extracts the keyframe features of each frame handed over and localizes
// them against the map (Localizer::Localize: retrieval, covisibility, P3P RANSAC); the result
// goes back to the filter thread, which owns the T_G_M estimate.
void EstimatorDaemon::Impl::LocLoop() {
  const CameraConfig& cam = rig.cameras[static_cast<std::size_t>(options.vio_camera)];
  LatencyWindow stage_ms;
  double max_us = 0.0;
  std::vector<Eigen::Vector2d> uv;
  LocItem item;
  while (true) {
    bool any = false;
    while (loc_queue->pop(item)) {
      any = true;
      const int64_t t0 = SteadyNs();
      const localizer::KeyframeFeatures f = loc_extractor->Extract(item.image);
      item.image.release();  // back to the pool
      uv.clear();
      for (const cv::KeyPoint& k : f.keypoints) uv.emplace_back(k.pt.x, k.pt.y);
      LocResultItem out;
      out.t_ns = item.t_ns;
      out.epoch = item.epoch;
      out.T_M_I = item.T_M_I;
      out.num_keypoints = static_cast<int>(uv.size());
      if (uv.empty()) {
        out.status = localizer::LocalizationStatus::kNoKeypoints;
      } else {
        const localizer::LocalizationResult r =
            loc->Localize(cam.camera, cam.T_I_C, uv, f.descriptors.ptr<uint8_t>());
        out.status = r.status;
        out.T_G_I = r.T_G_I;
        out.covariance_I = r.covariance_I;
        out.inliers = static_cast<int>(r.inliers.size());
        out.num_matches = static_cast<int>(r.matches.size());
      }
      const double ms = static_cast<double>(SteadyNs() - t0) * 1e-6;
      out.stage_ms = ms;
      stage_ms.Add(ms);
      max_us = std::max(max_us, ms * 1e3);
      counters[kLocStageUsP50].store(static_cast<int64_t>(stage_ms.Percentile(0.5) * 1e3),
                                     std::memory_order_relaxed);
      counters[kLocStageUsMax].store(static_cast<int64_t>(max_us), std::memory_order_relaxed);
      // Capacity 4 with at most one query in flight: never full.
      while (!loc_result_queue->push(out) && !stop.load()) {
        std::this_thread::sleep_for(std::chrono::microseconds(200));
      }
      loc_in_flight.fetch_sub(1);
      filter_wake.Notify();
    }
    if (!any) {
      if (filter_done.load() && loc_queue->read_available() == 0) break;
      loc_wake.Wait(50 * kMs);
    }
  }
  loc_done.store(true);
}

void EstimatorDaemon::Impl::SetUpMapping() {
  const MappingOptions& m = options.mapping;
  if (num_cameras > kMaxMapCameras) {
    throw InputError(FormatInputError("daemon options", "mapping.enabled",
                                      "at most " + std::to_string(kMaxMapCameras) +
                                          " cameras in channels.cameras with map building"));
  }
  mapping::MapBuilderOptions builder_options = m.map_builder;
  if (builder_options.cameras.empty()) {
    // Features in every camera the daemon subscribes to (not the rig's others: no images).
    for (int c = 0; c < num_cameras; ++c) builder_options.cameras.push_back(c);
  }
  for (int c : builder_options.cameras) {
    if (c < 0 || c >= num_cameras) {
      throw InputError(FormatInputError(
          "daemon options", "mapping.map_builder.cameras",
          "camera indices below " + std::to_string(num_cameras) + " (the subscribed cameras)"));
    }
  }
  if (!m.save_dir.empty()) {
    // Checked now rather than after an hour of mapping: the folder must not hold a map
    // (saving would replace it), and must be creatable.
    namespace fs = std::filesystem;
    std::error_code ec;
    if (fs::exists(m.save_dir, ec) &&
        (!fs::is_directory(m.save_dir, ec) || !fs::is_empty(m.save_dir, ec))) {
      throw InputError(FormatInputError(m.save_dir, "mapping.save_dir / --save-map",
                                        "a folder that does not exist yet or is empty"));
    }
    fs::create_directories(m.save_dir, ec);
    if (ec) {
      throw InputError(FormatInputError(m.save_dir, "mapping.save_dir / --save-map",
                                        "a folder that can be created (" + ec.message() + ")"));
    }
  }
  uint64_t seed = m.mission_seed;
  if (seed == 0) {
    if (log_mode) {
      // From the log's content: the same log gives the same ids, two sessions' logs give
      // missions that can be merged (distinct ids).
      seed = mapstore::SeedFromFileContent(options.input_log);
    } else {
      std::random_device device;
      seed = (static_cast<uint64_t>(device()) << 32) ^ device();
      if (seed == 0) seed = 1;
    }
  }
  map_builder_options = builder_options;
  mission_seed_base = seed;
  builder = std::make_unique<mapping::MapBuilder>(rig, builder_options, MissionSeed(0), MissionName(0));
  Count(kMapMissions);
  map_queue = std::make_unique<Spsc<MapItem>>(static_cast<std::size_t>(m.queue_capacity));
  if (m.stream.enabled) {
    const std::string url =
        ResolveLcmUrl(m.stream.lcm_url.empty() ? options.lcm_url : m.stream.lcm_url);
    stream_lcm = std::make_unique<lcm::LCM>(WithDefaultRecvBufSize(url));
    if (!stream_lcm->good()) {
      throw InputError(FormatInputError("daemon options", "mapping.stream.lcm_url",
                                        "an LCM URL that opens (" + url + ")"));
    }
    sender_options.max_window_chunks = static_cast<std::size_t>(m.stream.max_window_chunks);
    sender_options.retransmit_timeout_s = m.stream.retransmit_timeout_s;
    sender_options.max_retransmit_timeout_s =
        std::max(sender_options.max_retransmit_timeout_s, m.stream.retransmit_timeout_s);
    stream = MakeSender(builder->mission_id(), MissionName(0));
  }
}

// Mission 0 keeps the configured seed (the ids of a run without resets are unchanged); mission
// k > 0 gets a seed mixed from it and k (splitmix64's finalizer), so ids stay deterministic
// with --input-log and the missions of one run never share ids.
uint64_t EstimatorDaemon::Impl::MissionSeed(int k) const {
  if (k == 0) return mission_seed_base;
  uint64_t z = mission_seed_base + 0x9E3779B97F4A7C15ULL * static_cast<uint64_t>(k);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ULL;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBULL;
  z ^= z >> 31;
  return z == 0 ? 1 : z;
}

// "<mission_name>-<k>" after a reset; "" stays "" (mapstored then names the folder by the id).
std::string EstimatorDaemon::Impl::MissionName(int k) const {
  const std::string& name = options.mapping.mission_name;
  if (k == 0 || name.empty()) return name;
  return name + "-" + std::to_string(k);
}

std::unique_ptr<mapstore::LcmMissionStreamSender> EstimatorDaemon::Impl::MakeSender(
    const mapstore::MissionId& id, const std::string& name) {
  const MappingOptions& m = options.mapping;
  return std::make_unique<mapstore::LcmMissionStreamSender>(
      stream_lcm.get(), ChannelName(m.stream.chunk_channel, options.channel_suffix),
      ChannelName(m.stream.ack_channel, options.channel_suffix), id, name, sender_options);
}

void EstimatorDaemon::Impl::LogLimited(int topic, const char* format, ...) {
  const int64_t now = SteadyNs();
  std::atomic<int64_t>& last = last_log_ns[static_cast<std::size_t>(topic) % last_log_ns.size()];
  const int64_t previous = last.load(std::memory_order_relaxed);
  if (previous != 0 && now - previous < 1000 * kMs) return;
  last.store(now, std::memory_order_relaxed);
  char line[512];
  va_list args;
  va_start(args, format);
  std::vsnprintf(line, sizeof(line), format, args);
  va_end(args);
  std::fprintf(stderr, "vilma-estimatord: %s\n", line);
}

// ---------------------------------------------------------------- input stage

void EstimatorDaemon::Impl::OnLcmMessage(const lcm::ReceiveBuffer* rbuf,
                                         const std::string& channel) {
  // Never throws: LCM would abort the handle loop (and the decoders return errors instead).
  try {
    Dispatch(channel, rbuf->data, static_cast<int>(rbuf->data_size));
  } catch (const std::exception& e) {
    Count(kLcmErrors);
    LogLimited(7, "handler error on %s: %s", channel.c_str(), e.what());
  }
}

void EstimatorDaemon::Impl::Dispatch(const std::string& channel, const void* data, int size) {
  const int64_t recv_ns = SteadyNs();
  const int64_t recv_wall_us = WallClockUtime();
  if (channel == imu_channel) {
    HandleImu(data, size, recv_ns, recv_wall_us);
    return;
  }
  for (int i = 0; i < num_cameras; ++i) {
    if (channel == camera_channels[static_cast<std::size_t>(i)]) {
      HandleImage(i, data, size, recv_ns, recv_wall_us);
      return;
    }
  }
}

template <typename Queue, typename Item>
bool EstimatorDaemon::Impl::PushBlocking(Queue& queue, const Item& item) {
  while (!queue.push(item)) {
    if (stop.load(std::memory_order_relaxed)) return false;
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  return true;
}

void EstimatorDaemon::Impl::HandleImu(const void* data, int size, int64_t recv_ns,
                                      int64_t recv_wall_us) {
  Count(kImuReceived);
  InputItem item;
  const std::string error = DecodeImuMessage(data, size, &imu_msg, &item.imu);
  if (!error.empty()) {
    Count(kMalformedImu);
    LogLimited(0, "malformed message on %s: %s", imu_channel.c_str(), error.c_str());
    return;
  }
  item.kind = InputItem::Kind::kImu;
  item.recv_steady_ns = recv_ns;
  item.recv_latency_us = recv_wall_us - imu_msg.utime;
  const bool pushed = log_mode ? PushBlocking(input_queue, item) : input_queue.push(item);
  if (!pushed) {
    Count(kImuDroppedInputQueue);
    LogLimited(1, "BUG: input queue full, IMU sample dropped (queues.input_capacity)");
    return;
  }
  sync_wake.Notify();
}

void EstimatorDaemon::Impl::HandleImage(int camera, const void* data, int size, int64_t recv_ns,
                                        int64_t recv_wall_us) {
  Count(kImagesReceived);
  const std::string& channel = camera_channels[static_cast<std::size_t>(camera)];
  std::string error = DecodeImageMessage(data, size, &image_msg);
  if (!error.empty()) {
    Count(kMalformedImages);
    LogLimited(2, "malformed message on %s: %s", channel.c_str(), error.c_str());
    return;
  }
  const Camera& model = rig.cameras[static_cast<std::size_t>(camera)].camera;
  if (image_msg.width != model.width() || image_msg.height != model.height()) {
    Count(kImagesWrongSize);
    LogLimited(3, "image on %s is %dx%d, the rig's camera is %dx%d: dropped", channel.c_str(),
               image_msg.width, image_msg.height, model.width(), model.height());
    return;
  }
  cv::Mat slot = pool->TryAcquire(image_msg.height, image_msg.width, CV_8UC1);
  if (slot.empty() && log_mode) {
    // Blocking backpressure; bounded so that a logic error cannot hang the daemon.
    const int64_t give_up = SteadyNs() + 5000 * kMs;
    while (slot.empty() && !stop.load() && SteadyNs() < give_up) {
      std::this_thread::sleep_for(std::chrono::microseconds(200));
      slot = pool->TryAcquire(image_msg.height, image_msg.width, CV_8UC1);
    }
  }
  if (slot.empty()) {
    Count(kImagesDroppedPool);
    LogLimited(4, "no free image slot: image on %s dropped", channel.c_str());
    return;
  }
  if (image_msg.pixel_format == image_t::GRAY8) {
    // The common case without a temporary: rows (row_stride may pad them) into the slot.
    const cv::Mat view(image_msg.height, image_msg.width, CV_8UC1, image_msg.data.data(),
                       static_cast<std::size_t>(image_msg.row_stride));
    view.copyTo(slot);
  } else {
    cv::Mat gray;
    error = MessageToGray8(image_msg, &gray);
    if (!error.empty()) {
      Count(kMalformedImages);
      LogLimited(2, "malformed message on %s: %s", channel.c_str(), error.c_str());
      return;
    }
    gray.copyTo(slot);
  }
  InputItem item;
  item.kind = InputItem::Kind::kImage;
  item.camera = camera;
  item.t_cam_ns = UtimeToNs(image_msg.utime);
  item.recv_steady_ns = recv_ns;
  item.recv_latency_us = recv_wall_us - image_msg.utime;
  item.image = slot;
  const bool pushed = log_mode ? PushBlocking(input_queue, item) : input_queue.push(item);
  if (!pushed) {
    Count(kImagesDroppedInputQueue);
    LogLimited(5, "input queue full: image on %s dropped", channel.c_str());
    return;
  }
  sync_wake.Notify();
}

void EstimatorDaemon::Impl::InputLoop() {
  if (log_mode) {
    LcmLogEvent event;
    while (!stop.load() && reader->Next(&event)) {
      Dispatch(event.channel, event.data.data(), static_cast<int>(event.data.size()));
    }
  } else {
    while (!stop.load()) {
      if (input_lcm->handleTimeout(50) < 0) {
        Count(kLcmErrors);
        LogLimited(6, "lcm handle failed");
        std::this_thread::sleep_for(std::chrono::milliseconds(10));
      }
    }
  }
  input_done.store(true);
  sync_wake.Notify();
}

// ---------------------------------------------------------------- sync stage

void EstimatorDaemon::Impl::PushFilter(const FilterItem& item) {
  bool pushed = log_mode ? PushBlocking(filter_queue, item) : filter_queue.push(item);
  if (!pushed) {
    if (item.kind == FilterItem::Kind::kFrame) {
      Count(kFramesDroppedFilterQueue);
      frames_in_flight.fetch_sub(1);
    } else {
      Count(kImuDroppedFilterQueue);
      LogLimited(1, "BUG: filter queue full, IMU sample dropped (queues.filter_capacity)");
    }
    return;
  }
  filter_wake.Notify();
}

void EstimatorDaemon::Impl::SyncLoop() {
  SensorSynchronizer& sync = *synchronizer;
  const int vio = options.vio_camera;
  const int64_t silence_ns = SecondsToNs(options.camera_silence_s);
  std::vector<int64_t> last_image_imu_ns(static_cast<std::size_t>(num_cameras), -1);
  std::vector<bool> silent(static_cast<std::size_t>(num_cameras), false);
  // Receive times of the latest VIO-camera images, by stamp (frames come out in order).
  struct Received {
    int64_t t_cam_ns = -1, recv_ns = 0, latency_us = 0;
  };
  std::array<Received, 64> received{};
  std::size_t next_received = 0;
  int64_t last_forwarded_imu_ns = std::numeric_limits<int64_t>::min();
  InputItem item;
  SyncedFrame frame;

  auto forward = [&](SyncedFrame& f) {
    if (f.time_jump_before) {
      // The filter cannot go back in time: it restarts (the synchronizer cleared its history).
      FilterItem restart;
      restart.kind = FilterItem::Kind::kRestart;
      PushFilter(restart);
      Count(kTimeJumpRestarts);
      last_forwarded_imu_ns = std::numeric_limits<int64_t>::min();
      LogLimited(8, "timestamp jump: the filter restarts");
    }
    FilterItem out;
    out.kind = FilterItem::Kind::kImu;
    for (const ImuSample& s : f.imu) {
      // Consecutive frames share their boundary sample; forward each sample once.
      if (s.t_ns <= last_forwarded_imu_ns) continue;
      out.imu = s;
      PushFilter(out);
      last_forwarded_imu_ns = s.t_ns;
    }
    const cv::Mat& image = f.images[static_cast<std::size_t>(vio)];
    if (image.empty()) {
      Count(kFramesWithoutVioCamera);
      return;
    }
    if (frames_in_flight.load() >= options.queues.max_frames_in_flight) {
      if (!log_mode) {
        Count(kFramesDroppedBusy);
        return;
      }
      while (frames_in_flight.load() >= options.queues.max_frames_in_flight && !stop.load()) {
        std::this_thread::sleep_for(std::chrono::microseconds(200));
      }
    }
    FilterItem frame_item;
    frame_item.kind = FilterItem::Kind::kFrame;
    frame_item.t_cam_ns = f.t_cam_ns[static_cast<std::size_t>(vio)];
    frame_item.image = image;
    if (mapping_enabled) {
      for (int c = 0; c < num_cameras; ++c) {
        frame_item.map_images[static_cast<std::size_t>(c)] = f.images[static_cast<std::size_t>(c)];
      }
    }
    frame_item.synced_steady_ns = SteadyNs();
    frame_item.recv_steady_ns = frame_item.synced_steady_ns;
    for (const Received& r : received) {
      if (r.t_cam_ns == frame_item.t_cam_ns) {
        frame_item.recv_steady_ns = r.recv_ns;
        frame_item.recv_latency_us = r.latency_us;
        break;
      }
    }
    frames_in_flight.fetch_add(1);
    PushFilter(frame_item);
  };

  while (true) {
    bool any = false;
    const int depth = static_cast<int>(input_queue.read_available());
    if (depth > input_depth_max.load()) input_depth_max.store(depth);
    while (input_queue.pop(item)) {
      any = true;
      if (item.kind == InputItem::Kind::kImu) {
        sync.AddImu(item.imu);
        for (int c = 0; c < num_cameras; ++c) {
          const std::size_t k = static_cast<std::size_t>(c);
          if (last_image_imu_ns[k] >= 0 && !silent[k] &&
              item.imu.t_ns - last_image_imu_ns[k] > silence_ns) {
            silent[k] = true;
            Count(kCameraSilences);
            LogLimited(9, "camera %d silent for more than %.2f s", c, options.camera_silence_s);
          }
        }
      } else {
        const std::size_t k = static_cast<std::size_t>(item.camera);
        last_image_imu_ns[k] = item.t_cam_ns + camera_offsets_ns[k];
        silent[k] = false;
        if (item.camera == vio) {
          received[next_received] = {item.t_cam_ns, item.recv_steady_ns, item.recv_latency_us};
          next_received = (next_received + 1) % received.size();
        }
        sync.AddImage(item.camera, item.t_cam_ns, item.image);
        item.image.release();  // the synchronizer holds its own reference
      }
      while (sync.PopFrame(&frame)) {
        forward(frame);
        for (cv::Mat& m : frame.images) m.release();
      }
    }
    const SensorSyncCounters& s = sync.counters();
    for (const SyncCounterField& f : kSyncCounterFields) {
      counters[f.id].store(s.*f.field, std::memory_order_relaxed);
    }
    if (!any) {
      if (input_done.load() && input_queue.read_available() == 0) break;
      sync_wake.Wait(50 * kMs);
    }
  }
  sync_done.store(true);
  filter_wake.Notify();
  // Frames still held by the synchronizer (waiting for IMU that will not come) are released
  // with it, back to the pool.
}

// ---------------------------------------------------------------- filter stage

void EstimatorDaemon::Impl::FilterLoop() {
  const int vio = options.vio_camera;
  std::unique_ptr<estimator::VioFilter>& filter = vio_filter;
  bool ever_initialized = false;
  int64_t frames = 0;
  int64_t resets_before_restart = 0;
  Eigen::Vector3d last_omega = Eigen::Vector3d::Zero();
  // Thinning towards the map builder, as MapBuilder::WantsFrame (which belongs to the map
  // thread): a frame is wanted when 0.9 / vertex_rate_hz has passed since the last frame
  // handed over. The builder receives only the frames it wants, so both agree.
  const double vertex_rate_hz = options.mapping.map_builder.vertex_rate_hz;
  const int64_t min_vertex_dt_ns =
      vertex_rate_hz > 0.0 ? static_cast<int64_t>(0.9e9 / vertex_rate_hz) : 0;
  bool map_has_vertex = false;  // a frame went to the current mission
  int64_t map_last_vertex_ns = 0;
  MapItem map_item;
  // A new M frame (filter reset or restart): the mission ends. The break goes into the map
  // queue in order with the IMU samples and frames; live, when the queue is full, it is pushed
  // before the next frame (which is dropped while it cannot be). Nothing to end before the
  // current mission got a frame.
  bool map_break_pending = false;
  auto push_map_break = [&]() -> bool {
    MapItem brk;
    brk.kind = MapItem::Kind::kBreak;
    const bool pushed = log_mode ? PushBlocking(*map_queue, brk) : map_queue->push(brk);
    if (pushed) map_wake.Notify();
    return pushed;
  };
  auto end_map_mission = [&] {
    if (!mapping_enabled || !map_has_vertex) return;
    map_has_vertex = false;
    map_break_pending = !push_map_break();
  };
  // ---- LOC mode: T_G_M from the localizer's results (docs/daemon.md "Localization").
  estimator::GlobalFrameEstimator global_frame(options.localization.global_frame);
  uint64_t epoch = 0;  // M frame generation: results of an older M are stale
  bool loc_has_query = false;
  int64_t loc_last_query_ns = 0;
  int64_t loc_tracked_frames = 0;
  const double loc_rate = options.localization.max_rate_hz;
  const double camera_rate = rig.cameras[static_cast<std::size_t>(vio)].rate_hz;
  // Every N-th tracking frame, N = ceil(camera rate / max_rate_hz): never more often than
  // max_rate_hz (20 Hz / 2 Hz: every 10th; 25 Hz / 3 Hz: every 9th, 2.8 Hz).
  // --input-log counts frames exactly; live waits (N - 1/2) camera periods since the last
  // query, so that stamp jitter neither advances nor delays the query by a frame.
  const int64_t loc_every_n = std::max<int64_t>(
      1, camera_rate > 0.0 ? static_cast<int64_t>(std::ceil(camera_rate / loc_rate - 1e-9)) : 1);
  const int64_t loc_min_dt_ns =
      camera_rate > 0.0
          ? std::llround((static_cast<double>(loc_every_n) - 0.5) / camera_rate * 1e9)
          : std::llround(1e9 / loc_rate);
  auto reset_global = [&] {
    ++epoch;
    if (global_frame.initialized()) Count(kLocTgmResets);
    global_frame.Reset();
    counters[kLocInitialized].store(0, std::memory_order_relaxed);
  };
  auto decide = [&](const LocResultItem& res) {
    using localizer::LocalizationStatus;
    Count(LocStatusCounter(res.status));
    if (res.status != LocalizationStatus::kOk) return LocDecision::kFailed;
    if (res.epoch != epoch) {
      Count(kLocRejectedStale);
      return LocDecision::kRejectedStale;
    }
    if (res.inliers < options.localization.min_inliers) {
      Count(kLocRejectedInliers);
      return LocDecision::kRejectedInliers;
    }
    LocDecision d = LocDecision::kAccepted;
    switch (global_frame.Update(res.T_G_I, res.covariance_I, res.T_M_I)) {
      case estimator::GlobalFrameUpdate::kAccepted: Count(kLocTgmUpdates); break;
      case estimator::GlobalFrameUpdate::kRejectedGravity:
        Count(kLocRejectedGravity);
        d = LocDecision::kRejectedGravity;
        break;
      case estimator::GlobalFrameUpdate::kRejectedJump:
        Count(kLocRejectedJump);
        d = LocDecision::kRejectedJump;
        break;
      case estimator::GlobalFrameUpdate::kReinitialized:
        // Gated, but the gated results in a row outvoted the estimate: it restarts from this
        // one, which is thus accepted (loc_rejected_jump counts only results left unused).
        Count(kLocTgmResets);
        Count(kLocTgmUpdates);
        break;
    }
    counters[kLocInitialized].store(global_frame.initialized() ? 1 : 0, std::memory_order_relaxed);
    return d;
  };
  // Every result, used or not, goes out on VILMA_LOC through the publisher queue (no LCM here,
  // no allocation: the record is plain data).
  OutputItem loc_out;
  loc_out.kind = OutputItem::Kind::kLoc;
  auto apply_result = [&](const LocResultItem& res) {
    LocRecord& rec = loc_out.loc;
    rec = LocRecord();
    rec.decision = decide(res);
    rec.t_ns = res.t_ns;
    rec.status = res.status;
    rec.num_keypoints = res.num_keypoints;
    rec.num_matches = res.num_matches;
    rec.num_inliers = res.inliers;
    rec.stage_ms = res.stage_ms;
    if (res.status == localizer::LocalizationStatus::kOk) {
      const Eigen::Vector3d& p = res.T_G_I.translation();
      const Eigen::Quaterniond& q = res.T_G_I.rotation();
      for (int i = 0; i < 3; ++i) rec.position[i] = p[i];
      rec.orientation[0] = q.w();
      rec.orientation[1] = q.x();
      rec.orientation[2] = q.y();
      rec.orientation[3] = q.z();
      // The localizer's covariance is of xi = [rho; phi] in T_G_I Exp(xi) (body, right). To
      // first order p = p_G_I + R rho and R_G_I Exp(phi) = Exp(R phi) R_G_I, so pose_t's
      // global (left) errors are (R rho, R phi): Cov = A C A^T with A = diag(R_G_I, R_G_I).
      CopyRowMajor(RotateCovariance(q.toRotationMatrix(), res.covariance_I), rec.covariance);
    }
    const bool pushed = log_mode ? PushBlocking(output_queue, loc_out) : output_queue.push(loc_out);
    if (!pushed) {
      Count(kLocMessagesDropped);
    } else {
      output_wake.Notify();
    }
  };
  LocResultItem loc_result;
  FilterItem item;
  while (true) {
    bool any = false;
    const int depth = static_cast<int>(filter_queue.read_available());
    if (depth > filter_depth_max.load()) filter_depth_max.store(depth);
    while (filter_queue.pop(item)) {
      any = true;
      if (item.kind == FilterItem::Kind::kImu) {
        filter->AddImu(item.imu);
        last_omega = item.imu.omega_I;
        if (mapping_enabled) {
          map_item.kind = MapItem::Kind::kImu;
          map_item.imu = item.imu;
          PushMap(map_item);
        }
      } else if (item.kind == FilterItem::Kind::kRestart) {
        resets_before_restart += filter->stats().resets;
        filter = std::make_unique<estimator::VioFilter>(rig, vio, options.estimator);
        ever_initialized = false;
        end_map_mission();  // a new M frame: a new mission
        if (localization_enabled) reset_global();  // a new M frame
      } else {
        if (options.fault_stall_filter_after >= 0 && frames >= options.fault_stall_filter_after) {
          // Fault injection (--fault-stall-filter-after): the filter stops making progress,
          // so the watchdog is no longer petted. Only a stop request ends the stall.
          if (!filter_stalled.exchange(true)) {
            std::fprintf(stderr, "vilma-estimatord: fault injection: filter stalled after %lld frames\n",
                         static_cast<long long>(frames));
          }
          while (!stop.load()) std::this_thread::sleep_for(std::chrono::milliseconds(10));
        }
        if (frames == options.fault_reset_filter_at) {
          // Fault injection (--fault-reset-filter-at): the filter resets as on a failed health
          // check (at this frame, or at the first initialized one after it).
          filter->RequestReset("fault injection (--fault-reset-filter-at)");
          std::fprintf(stderr, "vilma-estimatord: fault injection: filter reset at frame %lld\n",
                       static_cast<long long>(frames));
        }
        OutputItem out;
        out.filter_start_ns = SteadyNs();
        const estimator::FrameResult r = filter->AddImage(item.t_cam_ns, item.image);
        out.filtered_steady_ns = SteadyNs();
        cv::Mat loc_image;  // LOC mode: the image may go to the localizer
        if (localization_enabled) loc_image = item.image;
        item.image.release();  // back to the pool
        frames_in_flight.fetch_sub(1);
        ++frames;
        Count(kFramesFiltered);
        counters[kFilterResets].store(resets_before_restart + filter->stats().resets,
                                      std::memory_order_relaxed);
        if (r.reset) LogLimited(10, "filter reset: %s", r.reset_reason.c_str());
        if (r.reset) end_map_mission();  // the filter re-initializes: a new M frame
        if (mapping_enabled && r.pose_valid && !r.reset) {
          const bool wanted = !map_has_vertex || r.t_ns - map_last_vertex_ns >= min_vertex_dt_ns;
          if (!wanted) {
            Count(kMapFramesThinned);
          } else {
            if (map_break_pending) map_break_pending = !push_map_break();
            bool room = !map_break_pending &&
                        map_frames_in_flight.load() < options.mapping.max_frames_in_flight;
            if (!room && log_mode) {
              // Deterministic: wait for the builder (it never waits for the filter).
              while (map_frames_in_flight.load() >= options.mapping.max_frames_in_flight &&
                     !stop.load()) {
                notifier.PetWatchdog(SteadyNs());
                std::this_thread::sleep_for(std::chrono::microseconds(200));
              }
              room = map_frames_in_flight.load() < options.mapping.max_frames_in_flight;
            }
            if (!room) {
              Count(kMapFramesDropped);
            } else {
              const estimator::FilterState& x = filter->state();
              map_item.kind = MapItem::Kind::kFrame;
              map_item.state.t_ns = r.t_ns;
              map_item.state.T_M_I = r.T_M_I;
              map_item.state.v_M = x.v_W;  // the filter's world frame W is the mission frame M
              map_item.state.gyro_bias = x.b_g;
              map_item.state.accel_bias = x.b_a;
              map_item.images = item.map_images;
              map_frames_in_flight.fetch_add(1);
              const bool pushed =
                  log_mode ? PushBlocking(*map_queue, map_item) : map_queue->push(map_item);
              if (pushed) {
                map_has_vertex = true;
                map_last_vertex_ns = r.t_ns;
                Count(kMapFramesQueued);
                map_wake.Notify();
              } else {
                map_frames_in_flight.fetch_sub(1);
                Count(kMapFramesDropped);
              }
              for (cv::Mat& m : map_item.images) m.release();
            }
          }
        }
        for (cv::Mat& m : item.map_images) m.release();  // back to the pool
        if (localization_enabled) {
          if (r.reset) reset_global();  // the filter re-initializes: a new M frame
          // Live: results that came back since the last frame.
          while (loc_result_queue->pop(loc_result)) apply_result(loc_result);
          if (r.pose_valid && !r.reset) {
            bool wanted;
            if (log_mode) {
              wanted = loc_tracked_frames % loc_every_n == 0;
            } else {
              wanted = !loc_has_query || r.t_ns - loc_last_query_ns >= loc_min_dt_ns;
            }
            ++loc_tracked_frames;
            if (!wanted) {
              Count(kLocThinned);
            } else if (!log_mode && loc_in_flight.load() > 0) {
              Count(kLocBusy);  // the next frame tries again
            } else {
              LocItem q;
              q.t_ns = r.t_ns;
              q.epoch = epoch;
              q.T_M_I = r.T_M_I;
              q.image = loc_image;
              loc_in_flight.fetch_add(1);
              if (loc_queue->push(q)) {
                Count(kLocAttempts);
                loc_has_query = true;
                loc_last_query_ns = r.t_ns;
                loc_wake.Notify();
                if (log_mode) {
                  // Deterministic: the result is applied at this very frame on every run.
                  while (loc_in_flight.load() > 0 && !stop.load()) {
                    notifier.PetWatchdog(SteadyNs());
                    std::this_thread::sleep_for(std::chrono::microseconds(100));
                  }
                  while (loc_result_queue->pop(loc_result)) apply_result(loc_result);
                }
              } else {
                loc_in_flight.fetch_sub(1);
                Count(kLocBusy);
              }
              q.image.release();
            }
          }
          loc_image.release();
          if (r.pose_valid && !r.reset && global_frame.initialized()) {
            // VILMA_POSE: T_G_I = T_G_M T_M_I.
            const Transformation T_G_M = global_frame.T_G_M();
            const Transformation T_G_I = T_G_M * r.T_M_I;
            const Eigen::Quaterniond& qg = T_G_I.rotation();
            const Eigen::Vector3d v_G = T_G_M.rotation() * filter->state().v_W;
            out.global = true;
            for (int i = 0; i < 3; ++i) {
              out.g_position[i] = T_G_I.translation()[i];
              out.g_velocity[i] = v_G[i];
            }
            out.g_orientation[0] = qg.w();
            out.g_orientation[1] = qg.x();
            out.g_orientation[2] = qg.y();
            out.g_orientation[3] = qg.z();
            // Filled below from the odometry covariance rotated into G, plus the T_G_M
            // uncertainty (position block, yaw variance on the z rotation).
          }
        }
        if (r.pose_valid) ever_initialized = true;
        int32_t status = pose_t::INITIALIZING;
        if (r.reset || (!r.pose_valid && ever_initialized)) {
          status = pose_t::LOST;
        } else if (r.pose_valid) {
          status = pose_t::TRACKING;
        }
        out.status = status;
        filter_state.store(out.status, std::memory_order_relaxed);
        features.store(r.num_features, std::memory_order_relaxed);
        out.t_ns = r.pose_valid ? r.t_ns
                                : item.t_cam_ns + rig.cameras[static_cast<std::size_t>(vio)].time_offset_ns;
        out.features = r.num_features;
        out.recv_steady_ns = item.recv_steady_ns;
        out.recv_latency_us = item.recv_latency_us;
        out.synced_steady_ns = item.synced_steady_ns;
        if (r.pose_valid) {
          const estimator::FilterState& x = filter->state();
          const Eigen::Vector3d& p = r.T_M_I.translation();
          const Eigen::Quaterniond& q = r.T_M_I.rotation();
          const Eigen::Vector3d omega_I = last_omega - x.b_g;
          for (int i = 0; i < 3; ++i) {
            out.position[i] = p[i];
            out.velocity[i] = x.v_W[i];
            out.angular_velocity[i] = omega_I[i];
          }
          out.orientation[0] = q.w();
          out.orientation[1] = q.x();
          out.orientation[2] = q.y();
          out.orientation[3] = q.z();
          // The filter's attitude error is right-perturbed (q = q Exp(dtheta), local); pose_t
          // wants the global (left) error delta = R dtheta. Hence with R = R_M_I:
          //   Cov = [P_pp, P_pt R^T; R P_tp, R P_tt R^T].
          const Eigen::MatrixXd& P = filter->covariance();
          if (P.rows() >= estimator::kIdxQ + 3) {
            const Eigen::Matrix3d R = q.toRotationMatrix();
            Eigen::Matrix<double, 6, 6> C;
            C.block<3, 3>(0, 0) = P.block<3, 3>(estimator::kIdxP, estimator::kIdxP);
            C.block<3, 3>(0, 3) = P.block<3, 3>(estimator::kIdxP, estimator::kIdxQ) * R.transpose();
            C.block<3, 3>(3, 0) = C.block<3, 3>(0, 3).transpose();
            C.block<3, 3>(3, 3) = R * P.block<3, 3>(estimator::kIdxQ, estimator::kIdxQ) * R.transpose();
            CopyRowMajor(C, out.covariance);
            if (out.global) {
              // Global error in G: rotate the M blocks with R_G_M, add the T_G_M covariance
              // (position; yaw on the z rotation). Cross terms between both neglected.
              Matrix6d G =
                  RotateCovariance(global_frame.T_G_M().rotation().toRotationMatrix(), C);
              const Eigen::Matrix4d P_gm = global_frame.covariance();
              G.block<3, 3>(0, 0) += P_gm.block<3, 3>(0, 0);
              G(5, 5) += P_gm(3, 3);
              CopyRowMajor(G, out.g_covariance);
            }
          }
        }
        const bool pushed = log_mode ? PushBlocking(output_queue, out) : output_queue.push(out);
        if (!pushed) {
          Count(kPosesDroppedOutput);
        } else {
          output_wake.Notify();
        }
      }
      // Petted while the filter makes progress (here) or waits for data (below); a stalled
      // filter stops petting and systemd restarts the service.
      notifier.PetWatchdog(SteadyNs());
    }
    if (!any) {
      if (sync_done.load() && filter_queue.read_available() == 0) break;
      notifier.PetWatchdog(SteadyNs());
      filter_wake.Wait(50 * kMs);
    }
  }
  if (localization_enabled) {
    // Live: a query may still be in the localizer. Its result is reported too (every attempt
    // gets its VILMA_LOC); bounded, the localizer runs at most one query (tens of ms).
    const int64_t deadline = SteadyNs() + 5 * 1000 * kMs;
    // Not cut short by `stop`: live input ends by SIGTERM, which sets it, and the localizer
    // thread finishes its query whatever `stop` says (it runs until filter_done).
    while (loc_in_flight.load() > 0 && SteadyNs() < deadline) {
      notifier.PetWatchdog(SteadyNs());
      std::this_thread::sleep_for(std::chrono::microseconds(200));
    }
    while (loc_result_queue->pop(loc_result)) apply_result(loc_result);
  }
  filter_done.store(true);
  output_wake.Notify();
  map_wake.Notify();
  loc_wake.Notify();
}

void EstimatorDaemon::Impl::PushMap(const MapItem& item) {
  const bool pushed = log_mode ? PushBlocking(*map_queue, item) : map_queue->push(item);
  if (!pushed) {
    Count(kMapImuDropped);
    // (With --input-log a push only fails when a stop request cut the wait short.)
    if (!log_mode) {
      LogLimited(11, "BUG: map builder queue full, IMU sample dropped (mapping.queue_capacity)");
    }
    return;
  }
  map_wake.Notify();
}

// ---------------------------------------------------------------- map-builder stage

namespace {
void AddStreamCounters(const mapstore::MissionStreamSenderCounters& c,
                       mapstore::MissionStreamSenderCounters* sum) {
  sum->sent += c.sent;
  sum->retransmitted += c.retransmitted;
  sum->acked += c.acked;
  sum->window_full += c.window_full;
  sum->disk_full_acks += c.disk_full_acks;
  sum->error_acks += c.error_acks;
  sum->ignored_acks += c.ignored_acks;
  sum->bytes_sent += c.bytes_sent;
}

// Adds the counters of a mission that ended to the run's (what VILMA_STATUS reports).
void AddBuilderStats(const mapping::MapBuilderStats& b, mapping::MapBuilderStats* sum) {
  sum->vertices += b.vertices;
  sum->imu_edges += b.imu_edges;
  sum->keypoints += b.keypoints;
  sum->landmarks += b.landmarks;
  sum->landmarks_good += b.landmarks_good;
  sum->vertex_ms_total += b.vertex_ms_total;
  sum->vertex_ms_max = std::max(sum->vertex_ms_max, b.vertex_ms_max);
  sum->finish_ms += b.finish_ms;
}

// The whole of one mission of `map` as a delta (mission, vertices, edges, landmarks in their
// insertion order), to gather the missions of a run into one map.
mapstore::MissionDelta WholeMission(const mapstore::VIMap& map, const mapstore::MissionId& id) {
  mapstore::MissionDelta d;
  d.mission = map.mission(id);
  for (const mapstore::VertexId& v : map.vertex_ids(id)) d.vertices.push_back(map.vertex(v));
  for (const mapstore::EdgeId& e : map.edge_ids(id)) d.edges.push_back(map.edge(e));
  for (const mapstore::LandmarkId& l : map.landmark_ids(id)) d.landmarks.push_back(map.landmark(l));
  return d;
}
}  // namespace

// VILMA_STATUS map counters: the missions that ended (kept ones) plus the current one.
void EstimatorDaemon::Impl::CopyMapCounters() {
  mapping::MapBuilderStats b = map_stats_done;
  if (!map_run_ended) AddBuilderStats(builder->stats(), &b);  // else in map_stats_done
  auto set = [&](Counter c, int64_t v) { counters[c].store(v, std::memory_order_relaxed); };
  set(kMapVertices, b.vertices);
  set(kMapImuEdges, b.imu_edges);
  set(kMapKeypoints, b.keypoints);
  set(kMapLandmarks, b.landmarks);
  set(kMapLandmarksGood, b.landmarks_good);
  set(kMapVertexUsMean, static_cast<int64_t>(b.vertex_ms_mean() * 1e3));
  set(kMapVertexUsMax, static_cast<int64_t>(b.vertex_ms_max * 1e3));
  if (stream_lcm) {
    mapstore::MissionStreamSenderCounters c = stream_counters_done;
    for (const EndingStream& e : ending_streams) AddStreamCounters(e.sender->sender().counters(), &c);
    if (stream) AddStreamCounters(stream->sender().counters(), &c);
    set(kStreamSent, static_cast<int64_t>(c.sent));
    set(kStreamAcked, static_cast<int64_t>(c.acked));
    set(kStreamRetransmitted, static_cast<int64_t>(c.retransmitted));
    set(kStreamWindowFull, static_cast<int64_t>(c.window_full));
    set(kStreamDiskFullAcks, static_cast<int64_t>(c.disk_full_acks));
    set(kStreamErrorAcks, static_cast<int64_t>(c.error_acks));
  }
}

// The map thread: feeds the builder in the filter's order (IMU samples and the states and
// images of the frames it wants), streams its deltas, ends the mission at a break (filter
// reset / restart: a new M frame) and starts the next, and at the end finishes the last
// mission, ends the streams and saves the map. Live mode: never waited for by the filter
// (drops are counted there); --input-log: the filter waits for it, so the map is the same on
// every run.
void EstimatorDaemon::Impl::MapLoop() {
  const MapStreamOptions& so = options.mapping.stream;
  const bool save = !options.mapping.save_dir.empty();
  std::vector<cv::Mat> images(rig.cameras.size());
  std::deque<mapstore::MissionDelta> backlog;  // deltas waiting for window space, in order
  int64_t vertices_at_last_delta = 0;
  int64_t last_delta_ns = SteadyNs();
  const int64_t delta_period_ns = SecondsToNs(so.delta_period_s);
  double finish_ms = 0.0;  // Finish() of every mission

  // Deltas go out once the mission has 2 vertices: a mission dropped for having fewer never
  // reaches mapstored.
  auto take_delta = [&](bool always) {
    mapstore::MissionDelta delta = builder->TakeDelta();
    if (!always && delta.vertices.empty() && delta.edges.empty() && delta.landmarks.empty()) return;
    // The last delta re-sends the whole mission: parts that each fit one LCM message.
    for (mapstore::MissionDelta& part :
         mapstore::SplitMissionDelta(delta, static_cast<std::size_t>(so.max_delta_bytes))) {
      backlog.push_back(std::move(part));
    }
    Count(kMapDeltas);
  };
  auto service_stream = [&](int timeout_ms) {
    // Acks (the senders' handlers run in this thread: each takes the acks of its mission),
    // retransmissions, queued deltas.
    if (stream_lcm->handleTimeout(timeout_ms) > 0) {
      while (stream_lcm->handleTimeout(0) > 0) {
      }
    }
    if (stream) {
      while (!backlog.empty() && stream->sender().Send(backlog.front())) backlog.pop_front();
      stream->sender().Poll();
    }
    std::size_t waiting = backlog.size();
    const int64_t now = SteadyNs();
    for (std::size_t i = 0; i < ending_streams.size();) {
      EndingStream& e = ending_streams[i];
      mapstore::MissionStreamSender& s = e.sender->sender();
      while (!e.backlog.empty() && s.Send(e.backlog.front())) e.backlog.pop_front();
      if (e.backlog.empty()) s.End();  // queued once; retried while the window is full
      s.Poll();
      waiting += e.backlog.size();
      const bool timed_out = now >= e.deadline_ns;
      if (s.finished() || timed_out) {
        if (s.finished()) {
          ++streams_finished;
        } else {
          ++streams_unfinished;
          std::fprintf(stderr,
                       "vilma-estimatord: mapstored did not acknowledge mission %s within "
                       "mapping.stream.end_timeout_s (%.1f s): %s\n",
                       s.mission_id().Hex().c_str(), so.end_timeout_s, s.last_message().c_str());
        }
        AddStreamCounters(s.counters(), &stream_counters_done);
        ending_streams.erase(ending_streams.begin() + static_cast<std::ptrdiff_t>(i));
        continue;
      }
      ++i;
    }
    counters[kStreamBacklog].store(static_cast<int64_t>(waiting), std::memory_order_relaxed);
  };
  // Ends the current mission: landmarks (Finish), then either dropped (fewer than 2 vertices;
  // at the end of a run without any other mission the last one is kept, as before) or kept:
  // the last delta and END go out without waiting, the map is kept for --save-map.
  auto end_mission = [&](bool end_of_run) {
    builder->Finish();
    finish_ms += builder->stats().finish_ms;
    const bool keep = builder->stats().vertices >= 2 || (end_of_run && missions_kept == 0);
    map_run_ended = end_of_run;
    if (!keep) {
      Count(kMapMissionsDropped);
      // Nothing of it was streamed (take_delta waits for 2 vertices): the sender just goes.
      if (stream) {
        AddStreamCounters(stream->sender().counters(), &stream_counters_done);
        stream.reset();
      }
      backlog.clear();
      LogLimited(12, "map: mission %s dropped (%lld vertices)",
                 builder->mission_id().Hex().c_str(),
                 static_cast<long long>(builder->stats().vertices));
      return;
    }
    ++missions_kept;
    AddBuilderStats(builder->stats(), &map_stats_done);
    if (stream) {
      take_delta(true);  // landmarks, changed vertices, complete = true
      EndingStream e;
      e.sender = std::move(stream);
      e.backlog = std::move(backlog);
      backlog.clear();
      e.deadline_ns = SteadyNs() + SecondsToNs(so.end_timeout_s);
      ending_streams.push_back(std::move(e));
    }
    if (save) finished_maps.push_back(builder->ReleaseMap());
  };
  auto start_mission = [&] {
    ++mission_index;
    builder = std::make_unique<mapping::MapBuilder>(rig, map_builder_options,
                                                    MissionSeed(mission_index),
                                                    MissionName(mission_index));
    Count(kMapMissions);
    LogLimited(13, "map: the filter's frame M starts anew (reset / restart): mission %d, %s",
               mission_index, builder->mission_id().Hex().c_str());
    if (stream_lcm) stream = MakeSender(builder->mission_id(), MissionName(mission_index));
    vertices_at_last_delta = 0;
    last_delta_ns = SteadyNs();
  };

  MapItem item;
  while (true) {
    bool any = false;
    while (map_queue->pop(item)) {
      any = true;
      if (item.kind == MapItem::Kind::kImu) {
        builder->AddImu(item.imu);
        continue;
      }
      if (item.kind == MapItem::Kind::kBreak) {
        // The filter's M frame starts anew: a mission is one frame M (docs/daemon.md).
        end_mission(false);
        start_mission();
        CopyMapCounters();
        continue;
      }
      for (std::size_t c = 0; c < images.size() && c < item.images.size(); ++c) {
        images[c] = item.images[c];
        item.images[c].release();
      }
      builder->AddFrame(item.state, images);
      for (cv::Mat& m : images) m.release();  // back to the pool
      map_frames_in_flight.fetch_sub(1);
      CopyMapCounters();
      if (stream && builder->stats().vertices >= 2 &&
          builder->stats().vertices - vertices_at_last_delta >= so.delta_vertices) {
        take_delta(false);
        vertices_at_last_delta = builder->stats().vertices;
        last_delta_ns = SteadyNs();
      }
    }
    if (stream_lcm) {
      const int64_t now = SteadyNs();
      if (stream && builder->stats().vertices >= 2 &&
          builder->stats().vertices > vertices_at_last_delta && now - last_delta_ns >= delta_period_ns) {
        take_delta(false);
        vertices_at_last_delta = builder->stats().vertices;
        last_delta_ns = now;
      }
      service_stream(0);
      CopyMapCounters();
    }
    if (!any) {
      if (filter_done.load() && map_queue->read_available() == 0) break;
      if (stream_lcm) {
        service_stream(10);  // waits on the LCM socket (acks) for up to 10 ms
      } else {
        map_wake.Wait(50 * kMs);
      }
    }
  }

  // End of the run: the last mission ends like the others; then every mission that is still
  // ending gets until its own deadline (at most end_timeout_s from now) for mapstored's acks.
  const auto t0 = std::chrono::steady_clock::now();
  end_mission(true);
  if (stream_lcm) {
    while (!ending_streams.empty()) service_stream(10);
  }
  CopyMapCounters();
  const int missions = mission_index + 1;
  const mapping::MapBuilderStats& st = map_stats_done;
  std::ostringstream report;
  report << "map: ";
  if (missions > 1) {
    report << missions << " missions (" << (missions - missions_kept)
           << " dropped: fewer than 2 vertices), ";
  }
  report << st.vertices << " vertices, " << st.landmarks << " landmarks (" << st.landmarks_good
         << " good), finish " << static_cast<int>(finish_ms) << " ms";
  if (stream_lcm) {
    stream_finished = streams_unfinished == 0 && streams_finished == missions_kept;
    const mapstore::MissionStreamSenderCounters& c = stream_counters_done;
    report << "; stream: " << c.sent << " chunks, " << c.acked << " acked, " << c.retransmitted
           << " retransmitted, ";
    if (missions_kept == 1) {
      report << (stream_finished ? "mission complete in mapstored" : "NOT acknowledged by mapstored");
    } else {
      report << streams_finished << " of " << missions_kept << " missions complete in mapstored";
    }
  }
  if (save) {
    try {
      mapstore::MapSaveSummary saved;
      if (finished_maps.size() == 1) {
        saved = mapstore::SaveMap(finished_maps[0], options.mapping.save_dir);
      } else {
        // The missions of the run in one map, in the order they were made.
        mapstore::VIMap all;
        for (const mapstore::VIMap& m : finished_maps) {
          for (const mapstore::MissionId& id : m.mission_ids()) {
            mapstore::ApplyMissionDelta(WholeMission(m, id), &all);
          }
          // Deltas carry no resources: the images of map_builder.keep_images.
          all.resources().MergeFrom(m.resources());
        }
        saved = mapstore::SaveMap(all, options.mapping.save_dir);
      }
      map_saved = true;
      report << "; saved to " << options.mapping.save_dir << " (" << saved.bytes_written << " B)";
    } catch (const std::exception& e) {
      map_error = std::string("saving the map into ") + options.mapping.save_dir + " failed: " + e.what();
      std::fprintf(stderr, "vilma-estimatord: error: %s\n", map_error.c_str());
    }
  }
  report << "; end of mission took "
         << static_cast<int>(std::chrono::duration<double, std::milli>(
                                 std::chrono::steady_clock::now() - t0)
                                 .count())
         << " ms";
  map_report = report.str();
  map_done.store(true);
  output_wake.Notify();
}

// ---------------------------------------------------------------- publisher

void EstimatorDaemon::Impl::PublishStatus(int state, int64_t now_ns) {
  // CPU load of the whole process over the last period [fraction of one core].
  rusage usage;
  getrusage(RUSAGE_SELF, &usage);
  const int64_t cpu_us = (usage.ru_utime.tv_sec + usage.ru_stime.tv_sec) * 1000000LL +
                         usage.ru_utime.tv_usec + usage.ru_stime.tv_usec;
  if (last_cpu_us >= 0 && now_ns > last_cpu_wall_ns) {
    cpu_load = static_cast<double>(cpu_us - last_cpu_us) * 1000.0 /
               static_cast<double>(now_ns - last_cpu_wall_ns);
  }
  last_cpu_us = cpu_us;
  last_cpu_wall_ns = now_ns;

  status_t msg;
  msg.utime = WallClockUtime();
  msg.node = "vilma-estimatord";
  msg.state = state;
  const int fstate = filter_state.load();
  const char* fname = fstate == pose_t::TRACKING ? "TRACKING"
                      : fstate == pose_t::LOST   ? "LOST"
                                                 : "INITIALIZING";
  int64_t malformed = Get(kMalformedImu) + Get(kMalformedImages) + Get(kImagesWrongSize);
  int64_t drops = 0;
  for (Counter c : kDropCounters) drops += Get(c);
  std::ostringstream text;
  text << fname << ", " << features.load() << " features";
  if (filter_stalled.load()) text << ", FILTER STALLED (fault injection)";
  if (Get(kImuDroppedInputQueue) + Get(kImuDroppedFilterQueue) > 0) text << ", IMU DROPPED";
  msg.message = text.str();
  if (state == status_t::OK && (fstate != pose_t::TRACKING || filter_stalled.load())) {
    msg.state = status_t::DEGRADED;
  }
  for (const CounterInfo& c : kCounters) {
    msg.counter_names.push_back(c.name);
    msg.counter_values.push_back(Get(c.id));
  }
  auto add_counter = [&](const char* name, int64_t value) {
    msg.counter_names.push_back(name);
    msg.counter_values.push_back(value);
  };
  add_counter("malformed_messages", malformed);
  add_counter("drops", drops);
  add_counter("filter_state", fstate);
  add_counter("tracked_features", features.load());
  add_counter("queue_input_depth_max", input_depth_max.exchange(0));
  add_counter("queue_filter_depth_max", filter_depth_max.exchange(0));
  add_counter("queue_output_depth_max", output_depth_max.exchange(0));
  add_counter("image_pool_free", pool->num_free());
  msg.num_counters = static_cast<int32_t>(msg.counter_names.size());
  auto add_metric = [&](const std::string& name, double value) {
    msg.metric_names.push_back(name);
    msg.metric_values.push_back(value);
  };
  add_metric("cpu_load", cpu_load);
  const std::pair<const char*, LatencyWindow*> stages[] = {
      {"latency_receive", &lat_receive},   // utime -> received (wall clock; sensor clock!)
      {"latency_sync", &lat_sync},         // received -> synced
      {"latency_filter_wait", &lat_filter_wait},  // synced -> filter starts
      {"latency_filter", &lat_filter},     // filter update
      {"latency_publish", &lat_publish},   // filtered -> published
      {"latency_total", &lat_total}};      // received -> published
  for (const auto& [name, window] : stages) {
    add_metric(std::string(name) + "_p50_ms", window->Percentile(0.5));
    add_metric(std::string(name) + "_p99_ms", window->Percentile(0.99));
  }
  msg.num_metrics = static_cast<int32_t>(msg.metric_names.size());
  ++status_seq;
  publish_lcm->publish(status_channel, &msg);
}

void EstimatorDaemon::Impl::PublishLoop() {
  pose_t msg;
  msg.parent_frame = "M";
  msg.child_frame = "I";
  int64_t seq = 0;
  pose_t gmsg;  // VILMA_POSE (LOC mode)
  gmsg.parent_frame = "G";
  gmsg.child_frame = "I";
  int64_t gseq = 0;
  localization_t lmsg;  // VILMA_LOC (LOC mode)
  int64_t lseq = 0;
  const int64_t period_ns = SecondsToNs(options.status_period_s);
  int64_t next_status_ns = SteadyNs();
  OutputItem out;
  while (true) {
    bool any = false;
    const int depth = static_cast<int>(output_queue.read_available());
    if (depth > output_depth_max.load()) output_depth_max.store(depth);
    while (output_queue.pop(out)) {
      any = true;
      if (out.kind == OutputItem::Kind::kLoc) {
        const LocRecord& rec = out.loc;
        lmsg.utime = NsToUtime(rec.t_ns);
        lmsg.seq = lseq++;
        lmsg.status = localizer::LocalizationStatusName(rec.status);
        lmsg.decision = LocDecisionName(rec.decision);
        lmsg.num_keypoints = rec.num_keypoints;
        lmsg.num_matches = rec.num_matches;
        lmsg.num_inliers = rec.num_inliers;
        std::copy(rec.position, rec.position + 3, lmsg.position);
        std::copy(rec.orientation, rec.orientation + 4, lmsg.orientation);
        std::copy(rec.covariance, rec.covariance + 36, lmsg.covariance);
        lmsg.stage_ms = rec.stage_ms;
        publish_lcm->publish(loc_channel, &lmsg);
        Count(kLocMessagesPublished);
        continue;
      }
      msg.utime = NsToUtime(out.t_ns);
      msg.seq = seq++;
      std::copy(out.position, out.position + 3, msg.position);
      std::copy(out.orientation, out.orientation + 4, msg.orientation);
      std::copy(out.velocity, out.velocity + 3, msg.velocity);
      std::copy(out.angular_velocity, out.angular_velocity + 3, msg.angular_velocity);
      std::copy(out.covariance, out.covariance + 36, msg.covariance);
      msg.status = out.status;
      publish_lcm->publish(odom_channel, &msg);
      if (out.global) {
        gmsg.utime = msg.utime;
        gmsg.seq = gseq++;
        std::copy(out.g_position, out.g_position + 3, gmsg.position);
        std::copy(out.g_orientation, out.g_orientation + 4, gmsg.orientation);
        std::copy(out.g_velocity, out.g_velocity + 3, gmsg.velocity);
        std::copy(out.angular_velocity, out.angular_velocity + 3, gmsg.angular_velocity);
        std::copy(out.g_covariance, out.g_covariance + 36, gmsg.covariance);
        gmsg.status = pose_t::LOCALIZED;
        publish_lcm->publish(pose_channel, &gmsg);
        Count(kLocPosesPublished);
      }
      const int64_t published = SteadyNs();
      Count(kPosesPublished);
      lat_receive.Add(static_cast<double>(out.recv_latency_us) * 1e-3);
      lat_sync.Add(static_cast<double>(out.synced_steady_ns - out.recv_steady_ns) * 1e-6);
      lat_filter_wait.Add(static_cast<double>(out.filter_start_ns - out.synced_steady_ns) * 1e-6);
      lat_filter.Add(static_cast<double>(out.filtered_steady_ns - out.filter_start_ns) * 1e-6);
      lat_publish.Add(static_cast<double>(published - out.filtered_steady_ns) * 1e-6);
      lat_total.Add(static_cast<double>(published - out.recv_steady_ns) * 1e-6);
    }
    const int64_t now = SteadyNs();
    if (now >= next_status_ns) {
      const int32_t state = status_seq == 0 ? static_cast<int32_t>(status_t::STARTING)
                                             : static_cast<int32_t>(status_t::OK);
      PublishStatus(state, now);
      next_status_ns = std::max(next_status_ns + period_ns, now + period_ns / 2);
    }
    if (!any) {
      if (filter_done.load() && output_queue.read_available() == 0 &&
          (!mapping_enabled || map_done.load())) {
        break;
      }
      output_wake.Wait(std::min<int64_t>(50 * kMs, std::max<int64_t>(kMs, next_status_ns - now)));
    }
  }
  PublishStatus(status_t::STOPPING, SteadyNs());
}

// ---------------------------------------------------------------- EstimatorDaemon

EstimatorDaemon::EstimatorDaemon(const DaemonOptions& options, const SensorRig& rig)
    : impl_(std::make_unique<Impl>(options, rig)) {}

EstimatorDaemon::~EstimatorDaemon() = default;

void EstimatorDaemon::RequestStop() { impl_->stop.store(true); }

DaemonSummary EstimatorDaemon::Run() {
  Impl& d = *impl_;
  std::thread publisher([&] { d.PublishLoop(); });
  std::thread filter([&] { d.FilterLoop(); });
  std::thread sync([&] { d.SyncLoop(); });
  std::thread map_thread;
  if (d.mapping_enabled) map_thread = std::thread([&] { d.MapLoop(); });
  std::thread loc_thread;
  if (d.localization_enabled) loc_thread = std::thread([&] { d.LocLoop(); });
  // Subscribed (constructor) and every stage is up.
  d.notifier.Ready();
  d.notifier.Status(d.log_mode ? "reading " + d.options.input_log : "running");
  std::thread input([&] { d.InputLoop(); });
  input.join();
  if (d.stop.load()) d.notifier.Stopping();
  sync.join();
  filter.join();
  if (map_thread.joinable()) map_thread.join();
  if (loc_thread.joinable()) loc_thread.join();
  publisher.join();
  if (!d.stop.load()) d.notifier.Stopping();
  // Close LCM: a file:// provider flushes its file here (the output of an --input-log run).
  d.publish_lcm = nullptr;
  d.output_lcm.reset();
  d.input_lcm.reset();

  DaemonSummary summary;
  summary.frames_filtered = d.Get(kFramesFiltered);
  summary.poses_published = d.Get(kPosesPublished);
  summary.malformed_messages = d.Get(kMalformedImu) + d.Get(kMalformedImages) + d.Get(kImagesWrongSize);
  for (Counter c : kDropCounters) summary.drops += d.Get(c);
  std::ostringstream report;
  for (const CounterInfo& c : kCounters) report << c.name << " " << d.Get(c.id) << "\n";
  summary.report = report.str();
  summary.mapping = d.mapping_enabled;
  summary.map_saved = d.map_saved;
  summary.map_error = d.map_error;
  summary.map_report = d.map_report;
  summary.stream_finished = d.stream_finished;
  return summary;
}

}  // namespace vilma::daemon
