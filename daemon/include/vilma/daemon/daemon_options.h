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

namespace vilma::daemon {

// LCM channel names (before the suffix). Upper case [A-Z0-9_] (docs/lcm.md).
struct ChannelOptions {
  // Image channel of each rig camera, in rig order. Cameras of the rig beyond this list are
  // not subscribed (list only CAM0 to run a stereo rig monocularly without waiting for CAM1).
  std::vector<std::string> cameras = {"CAM0", "CAM1"};
  std::string imu = "IMU";
  std::string odometry = "VILMA_ODOM";  // pose_t T_M_I, every frame
  std::string pose = "VILMA_POSE";      // pose_t T_G_I (localization; not published yet)
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
  int image_pool_slots = 32;
  // Frames queued for the filter at most [count]; beyond, the sync stage thins frames
  // (frames_dropped_busy) instead of building up latency. IMU samples are always forwarded.
  int max_frames_in_flight = 2;
  std::string Validate() const;
};

struct DaemonOptions {
  std::string rig;             // sensor rig YAML ("" = must come from --rig)
  std::string lcm_url;         // "" = $LCM_DEFAULT_URL or udpm://239.255.76.67:7667?ttl=0
  std::string channel_suffix;  // appended to every channel name
  int vio_camera = 0;          // rig camera used by the monocular filter
  double status_period_s = 1.0;  // VILMA_STATUS period [s]
  // A camera with no image for this long [s of IMU time] while the IMU runs is reported
  // as silent (camera_silences), once per silence.
  double camera_silence_s = 0.5;
  // Filter options: a YAML file like config/estimator.yaml (relative paths are relative to
  // the daemon config file), "" for the built-in defaults, or the options inline as a map.
  std::string estimator_file;
  estimator::FilterOptions estimator;
  SensorSyncOptions sync;
  ChannelOptions channels;
  QueueOptions queues;

  // Command line only (not in YAML).
  std::string input_log;  // read this lcm-logger file instead of subscribing (deterministic)
  int64_t fault_stall_filter_after = -1;  // test: the filter thread stalls after N frames

  std::string Validate() const;  // empty if valid, else "field: expectation"
};

// Strict loading; throws InputError naming file, key and expectation.
DaemonOptions LoadDaemonOptions(const std::string& path);
DaemonOptions ParseDaemonOptions(const std::string& yaml_text, const std::string& source_name);
DaemonOptions ReadDaemonOptions(const YamlNode& root);
// The effective options (YAML, same layout as config/daemon.yaml with the estimator inline).
std::string DaemonOptionsToYaml(const DaemonOptions& options);

}  // namespace vilma::daemon
