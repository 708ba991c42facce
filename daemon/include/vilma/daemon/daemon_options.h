// Options of vilma-estimatord (docs/daemon.md). Plain structs with in-class defaults, one
// comment per field, checked by Validate(); loaded strictly from YAML (config/daemon.yaml
// documents every key and equals the defaults): unknown and missing keys are errors.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "vilma/core/sensor_sync.h"
#include "vilma/core/yaml_io.h"
#include "vilma/estimator/filter_options.h"
#include "vilma/estimator/global_frame_estimator.h"
#include "vilma/localizer/feature_options.h"
#include "vilma/mapping/map_builder_options.h"

namespace vilma::daemon {

// LCM channel names (before the suffix). Upper case [A-Z0-9_] (docs/lcm.md).
struct ChannelOptions {
  // Image channel of each rig camera, in rig order. Cameras of the rig beyond this list are
  // not subscribed (list only CAM0 to run a stereo rig monocularly without waiting for CAM1).
  std::vector<std::string> cameras = {"CAM0", "CAM1"};
  std::string imu = "IMU";
  std::string odometry = "VILMA_ODOM";  // pose_t T_M_I, every frame
  std::string pose = "VILMA_POSE";      // pose_t T_G_I (LOC mode, once T_G_M is known)
  std::string localization = "VILMA_LOC";  // localization_t, every LOC-mode attempt
  std::string status = "VILMA_STATUS";  // status_t
  std::string Validate() const;
};

// Sizes of the bounded single-producer single-consumer queues between the stages.
struct QueueOptions {
  // LCM input -> sync [items: IMU samples and images]. 200 Hz IMU: 4096 = 20 s of slack; a
  // full queue drops IMU samples, which is counted and reported as a bug (imu_dropped).
  int input_capacity = 4096;
  int filter_capacity = 4096;  // sync -> filter [items: IMU samples and frames]
  int output_capacity = 256;   // filter -> publisher [poses]
  // Preallocated image buffers [count]. An image that finds no free slot is dropped
  // (images_dropped_pool); the slots are recycled when the filter (or the synchronizer that
  // dropped the frame) releases the image.
  int image_pool_slots = 40;  // RequiredImagePoolSlots: stereo + mapping + LOC needs 34
  // --input-log only: the input waits for a free slot instead of dropping (a replay must be
  // loss-free and deterministic however slow the stages are), and drops the image only when no
  // slot came back for this long [s] -- a guard against a logic error, never hit when the pool
  // has RequiredImagePoolSlots. (A slow map builder on a loaded machine held every slot for
  // more than the 5 s of the fixed guard before this option, 2026-11-27.)
  double log_slot_wait_s = 120.0;
  // Frames queued for the filter at most [count]; beyond, the sync stage thins frames
  // (frames_dropped_busy) instead of building up latency. IMU samples are always forwarded.
  int max_frames_in_flight = 2;
  std::string Validate() const;
};

// Streaming of the mission to vilma-mapstored (docs/mapstore.md, mission_chunk_t /
// mission_ack_t): reliable on top of LCM (sequence numbers, acks, retransmission).
struct MapStreamOptions {
  bool enabled = false;
  std::string lcm_url;  // "" = the daemon's lcm_url (needed when that is a file:// output)
  std::string chunk_channel = "VILMA_MISSION";   // mission_chunk_t (+ channel_suffix)
  std::string ack_channel = "VILMA_MISSION_ACK"; // mission_ack_t (+ channel_suffix)
  int delta_vertices = 10;      // send a delta every this many new vertices ...
  double delta_period_s = 1.0;  // ... or when this long has passed with new data [s]
  // A larger delta (the map builder's last one re-sends the whole mission) goes out in parts
  // of about this size (mapstore/delta_split.h): one LCM message must fit the receiver's UDP
  // buffer (8 MB in mapstored) or it is retransmitted forever [bytes].
  int max_delta_bytes = 1 << 20;
  // Upper bound of max_delta_bytes: 16 MiB, the receive buffer a robot is set up with
  // (net.core.rmem_max, docs/daemon.md "Install on a robot"): a larger LCM message cannot be
  // received at all. It also keeps a part (a single vertex may exceed the target) far below
  // the 64 MiB above which mapstored rejects a chunk as malformed
  // (MapStoreServerOptions::kMaxChunkPayloadBytes).
  static constexpr int kMaxDeltaBytes = 16 << 20;
  // At shutdown: wait this long at most for mapstored to acknowledge the END [s]. What is not
  // acknowledged by then is lost for mapstored (the --save-map copy is still written).
  double end_timeout_s = 5.0;
  double retransmit_timeout_s = 0.25;    // first retransmission without ack progress [s]
  int max_window_chunks = 4096;          // unacknowledged chunks kept in memory
  std::string Validate() const;
};

// The map-builder stage (docs/daemon.md "Map building"): a thread fed by the filter thread.
struct MappingOptions {
  bool enabled = false;
  // Map builder options: a YAML file like config/map_builder.yaml (relative to the daemon
  // config), "" for the built-in defaults, or the options inline as a map.
  std::string map_builder_file;
  mapping::MapBuilderOptions map_builder;
  std::string mission_name;  // name of the mission (mapstored's folder name; "" = the id)
  // Seed of the mission id (and of every id in it). 0: random in live mode, from the log's
  // content with --input-log (deterministic maps; different logs give different ids).
  uint64_t mission_seed = 0;
  // Save the mission into this folder at the end (end of log or SIGTERM); "" = do not save.
  // --save-map DIR sets it (and enabled). The folder must not hold a map yet.
  std::string save_dir;
  // Filter -> map builder queue [items: IMU samples and frame states]. 8192 = 40 s of IMU at
  // 200 Hz; a full queue drops IMU samples (map_imu_dropped: a bug).
  int queue_capacity = 8192;
  // Frames (with their images) queued for the builder at most; beyond, live mode drops the
  // frame (map_frames_dropped), --input-log blocks.
  int max_frames_in_flight = 2;
  MapStreamOptions stream;
  std::string Validate() const;
};

// LOC mode (docs/daemon.md "Localization"): a localizer stage against a prior map; the filter
// thread estimates T_G_M from its results and publishes VILMA_POSE (T_G_I).
struct LocalizationOptions {
  bool enabled = false;
  // A localization map file (SaveLocalizationMap) or a VI-map folder (the localization map is
  // built from it at start). --localization-map sets it (and enabled).
  std::string map;
  // Localizer options: a file like config/localizer.yaml (relative to the daemon config), or
  // "" for the built-in defaults.
  std::string localizer_file;
  // Keyframe features of the query images: a file like config/localization_features.yaml
  // (relative to the daemon config), "" for localizer::LocalizationQueryFeatureOptions(), or the options
  // inline as a map.
  std::string features_file;
  localizer::KeyframeFeatureOptions features = localizer::LocalizationQueryFeatureOptions();
  double max_rate_hz = 2.0;  // localization queries at most this often [Hz]
  int min_inliers = 30;      // results with fewer RANSAC inliers are not used (loc_rejected_inliers)
  // T_G_M fusion (estimator/global_frame_estimator.h); its keys are in this section directly
  // (localization.max_jump_m, ...). VILMA_POSE is published once min_consistent_results agree.
  estimator::GlobalFrameOptions global_frame;
  std::string Validate() const;
};

struct DaemonOptions {
  std::string rig;             // sensor rig YAML ("" = must come from --rig)
  std::string lcm_url;         // "" = $LCM_DEFAULT_URL or udpm://239.255.76.67:7667?ttl=0
  std::string channel_suffix;  // appended to every channel name
  int vio_camera = 0;          // rig camera in which the filter anchors its features
  // Stereo: the filter also uses the second camera (the estimator options' stereo.camera, rig
  // index, subscribed on channels.cameras): sets the estimator's stereo.enabled (which turns it
  // on as well; StereoEnabled() is the effective value). --stereo sets it.
  bool stereo = false;
  double status_period_s = 1.0;  // VILMA_STATUS period [s]
  // A camera with no image for this long [s of IMU time] while the IMU runs is reported
  // as silent (camera_silences), once per silence.
  double camera_silence_s = 0.5;
  // A timestamp jump whose stamps come back onto the pre-jump timeline within this long [s]
  // of its last IMU sample resumes the pre-jump filter instead of restarting (0: never;
  // docs/daemon.md "Clock jumps"). estimator::TimeJumpOptions::resume_max_gap_s.
  double time_jump_resume_max_gap_s = 2.0;
  // Filter options: a YAML file like config/estimator.yaml (relative paths are relative to
  // the daemon config file), "" for the built-in defaults, or the options inline as a map.
  std::string estimator_file;
  estimator::FilterOptions estimator;
  SensorSyncOptions sync;
  ChannelOptions channels;
  QueueOptions queues;
  MappingOptions mapping;
  LocalizationOptions localization;

  // Command line only (not in YAML).
  std::string input_log;  // read this lcm-logger file instead of subscribing (deterministic)
  int64_t fault_stall_filter_after = -1;  // test: the filter thread stalls after N frames
  int64_t fault_reset_filter_at = -1;     // test: the filter resets at frame N (0-based count
                                          // of frames given to the filter; a new mission)

  std::string Validate() const;  // empty if valid, else "field: expectation"
  bool StereoEnabled() const { return stereo || estimator.stereo.enabled; }
  // The estimator options the filter runs with (stereo.enabled = StereoEnabled()).
  estimator::FilterOptions EffectiveEstimatorOptions() const;
};

// Strict loading; throws InputError naming file, key and expectation.
DaemonOptions LoadDaemonOptions(const std::string& path);
DaemonOptions ParseDaemonOptions(const std::string& yaml_text, const std::string& source_name);
DaemonOptions ReadDaemonOptions(const YamlNode& root);
// The effective options (YAML, same layout as config/daemon.yaml with the estimator inline).
std::string DaemonOptionsToYaml(const DaemonOptions& options);

// Image pool slots the pipeline can hold at once with `num_cameras` cameras: the
// synchronizer's pending frames and the frames queued for the filter (one image each, two with
// stereo); with map building the frames the filter holds and those queued for the builder hold
// every camera's image (the stereo image among them); in LOC mode one image in the localizer
// (one query in flight) and one held by the filter while it decides. With fewer slots, the log mode's blocking input could wait for a slot that only
// newer input would free.
int RequiredImagePoolSlots(const DaemonOptions& options, int num_cameras);
// ">= <rule> = N": the expectation of the queues.image_pool_slots error.
std::string ImagePoolRuleText(const DaemonOptions& options, int num_cameras);

}  // namespace vilma::daemon
