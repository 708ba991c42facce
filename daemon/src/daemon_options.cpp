#include "vilma/daemon/daemon_options.h"

#include <cmath>
#include <filesystem>
#include <sstream>

#include "vilma/core/error.h"
#include "vilma/core/validate.h"
#include "vilma/estimator/vio_pipeline.h"

namespace vilma::daemon {
namespace {

std::string CheckChannel(const std::string& field, const std::string& name, bool allow_empty) {
  if (name.empty()) return allow_empty ? "" : field + ": expected a channel name";
  const std::string problem = ValidateChannelName(name);
  return problem.empty() ? "" : field + ": " + problem;
}

std::string Resolve(const std::string& config_file, const std::string& path) {
  if (path.empty() || std::filesystem::path(path).is_absolute()) return path;
  const std::filesystem::path dir = std::filesystem::path(config_file).parent_path();
  return dir.empty() ? path : (dir / path).string();
}

}  // namespace

std::string ChannelOptions::Validate() const {
  if (cameras.empty()) return "channels.cameras: expected at least one camera channel";
  for (std::size_t i = 0; i < cameras.size(); ++i) {
    VILMA_RETURN_IF_ERROR(
        CheckChannel("channels.cameras[" + std::to_string(i) + "]", cameras[i], false));
  }
  VILMA_RETURN_IF_ERROR(CheckChannel("channels.imu", imu, false));
  VILMA_RETURN_IF_ERROR(CheckChannel("channels.odometry", odometry, false));
  VILMA_RETURN_IF_ERROR(CheckChannel("channels.pose", pose, false));
  VILMA_RETURN_IF_ERROR(CheckChannel("channels.status", status, false));
  VILMA_RETURN_IF_ERROR(CheckChannel("channels.localization", localization, false));
  return "";
}

std::string QueueOptions::Validate() const {
  if (input_capacity < 16) return "queues.input_capacity: expected >= 16";
  if (filter_capacity < 16) return "queues.filter_capacity: expected >= 16";
  if (output_capacity < 4) return "queues.output_capacity: expected >= 4";
  if (image_pool_slots < 2) return "queues.image_pool_slots: expected >= 2";
  if (max_frames_in_flight < 1) return "queues.max_frames_in_flight: expected >= 1";
  return "";
}

std::string MapStreamOptions::Validate() const {
  VILMA_RETURN_IF_ERROR(CheckChannel("mapping.stream.chunk_channel", chunk_channel, false));
  VILMA_RETURN_IF_ERROR(CheckChannel("mapping.stream.ack_channel", ack_channel, false));
  if (chunk_channel == ack_channel) {
    return "mapping.stream.ack_channel: expected a channel other than chunk_channel";
  }
  if (delta_vertices < 1) return "mapping.stream.delta_vertices: expected >= 1";
  if (max_delta_bytes < 65536 || max_delta_bytes > kMaxDeltaBytes) {
    return "mapping.stream.max_delta_bytes: expected 65536 .. " + std::to_string(kMaxDeltaBytes) +
           " (16 MiB: one LCM message must fit the receive buffer; mapstored rejects chunks "
           "above 64 MiB)";
  }
  if (!(std::isfinite(delta_period_s) && delta_period_s >= 0.01 && delta_period_s <= 3600.0)) {
    return "mapping.stream.delta_period_s: expected 0.01 .. 3600";
  }
  if (!(std::isfinite(end_timeout_s) && end_timeout_s >= 0.0 && end_timeout_s <= 3600.0)) {
    return "mapping.stream.end_timeout_s: expected 0 .. 3600";
  }
  if (!(std::isfinite(retransmit_timeout_s) && retransmit_timeout_s >= 0.001 &&
        retransmit_timeout_s <= 60.0)) {
    return "mapping.stream.retransmit_timeout_s: expected 0.001 .. 60";
  }
  if (max_window_chunks < 1) return "mapping.stream.max_window_chunks: expected >= 1";
  return "";
}

std::string MappingOptions::Validate() const {
  if (queue_capacity < 16) return "mapping.queue_capacity: expected >= 16";
  if (max_frames_in_flight < 1) return "mapping.max_frames_in_flight: expected >= 1";
  if (!save_dir.empty() && !enabled) {
    return "mapping.save_dir: expected mapping.enabled: true (or --save-map)";
  }
  if (stream.enabled && !enabled) {
    return "mapping.stream.enabled: expected mapping.enabled: true";
  }
  const std::string builder_error = map_builder.Validate();
  if (!builder_error.empty()) return "mapping.map_builder." + builder_error;
  VILMA_RETURN_IF_ERROR(stream.Validate());
  return "";
}

std::string LocalizationOptions::Validate() const {
  if (enabled && map.empty()) {
    return "localization.map: expected a localization map file or VI-map folder (or --localization-map)";
  }
  if (!enabled && !map.empty()) return "localization.map: expected localization.enabled: true";
  if (!(std::isfinite(max_rate_hz) && max_rate_hz > 0.0 && max_rate_hz <= 100.0)) {
    return "localization.max_rate_hz: expected 0 < rate <= 100 [Hz]";
  }
  if (min_inliers < 3) return "localization.min_inliers: expected >= 3";
  const std::string global_frame_error = global_frame.Validate();
  if (!global_frame_error.empty()) return "localization." + global_frame_error;
  const std::string features_error = features.Validate();
  if (!features_error.empty()) return "localization.features." + features_error;
  return "";
}

std::string DaemonOptions::Validate() const {
  VILMA_RETURN_IF_ERROR(CheckChannel("channel_suffix", channel_suffix, true));
  if (vio_camera < 0) return "vio_camera: expected >= 0";
  if (vio_camera >= static_cast<int>(channels.cameras.size())) {
    return "vio_camera: expected an index into channels.cameras";
  }
  if (!(std::isfinite(status_period_s) && status_period_s >= 0.05 && status_period_s <= 60.0)) {
    return "status_period_s: expected 0.05 .. 60";
  }
  if (!(std::isfinite(camera_silence_s) && camera_silence_s > 0.0)) {
    return "camera_silence_s: expected > 0";
  }
  {
    estimator::TimeJumpOptions jump;
    jump.resume_max_gap_s = time_jump_resume_max_gap_s;
    const std::string e = jump.Validate();
    if (!e.empty()) return "time_jump_" + e;
  }
  VILMA_RETURN_IF_ERROR(channels.Validate());
  if (StereoEnabled()) {
    const int second = estimator.stereo.camera;
    if (second >= static_cast<int>(channels.cameras.size())) {
      return "estimator.stereo.camera: expected an index into channels.cameras (stereo: the "
             "second camera must be subscribed)";
    }
    if (second == vio_camera) {
      return "estimator.stereo.camera: expected a camera other than vio_camera (stereo)";
    }
  }
  VILMA_RETURN_IF_ERROR(queues.Validate());
  const std::string sync_error = sync.Validate();
  if (!sync_error.empty()) return "sync." + sync_error;
  VILMA_RETURN_IF_ERROR(estimator.Validate());
  VILMA_RETURN_IF_ERROR(mapping.Validate());
  VILMA_RETURN_IF_ERROR(localization.Validate());
  return "";
}

DaemonOptions ReadDaemonOptions(const YamlNode& root) {
  if (!root.IsMap()) root.Fail("", "a map of daemon options");
  DaemonOptions o;
  o.rig = Resolve(root.file(), root.Get<std::string>("rig"));
  o.lcm_url = root.Get<std::string>("lcm_url");
  o.channel_suffix = root.Get<std::string>("channel_suffix");
  o.vio_camera = root.Get<int>("vio_camera");
  o.stereo = root.Get<bool>("stereo");
  o.status_period_s = root.Get<double>("status_period_s");
  o.camera_silence_s = root.Get<double>("camera_silence_s");
  o.time_jump_resume_max_gap_s = root.Get<double>("time_jump_resume_max_gap_s");

  // estimator: a file name ("" = defaults) or the options inline.
  const YAML::Node estimator = root.raw()["estimator"];
  if (estimator.IsDefined() && estimator.IsMap()) {
    o.estimator = estimator::ReadFilterOptions(root.Child("estimator"));
  } else {
    o.estimator_file = Resolve(root.file(), root.Get<std::string>("estimator"));
    if (!o.estimator_file.empty()) o.estimator = estimator::LoadFilterOptions(o.estimator_file);
  }

  const YamlNode channels = root.MapChild("channels");
  const YamlNode cameras = channels.Child("cameras");
  if (!cameras.IsSequence()) channels.Fail("cameras", "a list of channel names");
  o.channels.cameras.clear();
  for (const YAML::Node& c : cameras.raw()) {
    if (!c.IsScalar()) channels.Fail("cameras", "a list of channel names");
    o.channels.cameras.push_back(c.Scalar());
  }
  o.channels.imu = channels.Get<std::string>("imu");
  o.channels.odometry = channels.Get<std::string>("odometry");
  o.channels.pose = channels.Get<std::string>("pose");
  o.channels.status = channels.Get<std::string>("status");
  o.channels.localization = channels.Get<std::string>("localization");
  channels.CheckNoUnknownKeys();

  const YamlNode queues = root.MapChild("queues");
  o.queues.input_capacity = queues.Get<int>("input_capacity");
  o.queues.filter_capacity = queues.Get<int>("filter_capacity");
  o.queues.output_capacity = queues.Get<int>("output_capacity");
  o.queues.image_pool_slots = queues.Get<int>("image_pool_slots");
  o.queues.max_frames_in_flight = queues.Get<int>("max_frames_in_flight");
  queues.CheckNoUnknownKeys();

  const YamlNode sync = root.MapChild("sync");
  o.sync.frame_grouping_tolerance_ns = sync.Get<int64_t>("frame_grouping_tolerance_ns");
  o.sync.incomplete_frame_timeout_ns = sync.Get<int64_t>("incomplete_frame_timeout_ns");
  o.sync.max_imu_wait_ns = sync.Get<int64_t>("max_imu_wait_ns");
  o.sync.imu_gap_threshold_ns = sync.Get<int64_t>("imu_gap_threshold_ns");
  o.sync.time_jump_threshold_ns = sync.Get<int64_t>("time_jump_threshold_ns");
  o.sync.max_pending_frames = sync.Get<int>("max_pending_frames");
  sync.CheckNoUnknownKeys();

  const YamlNode map_node = root.MapChild("mapping");
  o.mapping.enabled = map_node.Get<bool>("enabled");
  // map_builder: a file name ("" = defaults) or the options inline.
  const YAML::Node builder = map_node.raw()["map_builder"];
  if (builder.IsDefined() && builder.IsMap()) {
    o.mapping.map_builder = mapping::ReadMapBuilderOptions(map_node.Child("map_builder"));
  } else {
    o.mapping.map_builder_file = Resolve(root.file(), map_node.Get<std::string>("map_builder"));
    if (!o.mapping.map_builder_file.empty()) {
      o.mapping.map_builder = mapping::LoadMapBuilderOptions(o.mapping.map_builder_file);
    }
  }
  o.mapping.mission_name = map_node.Get<std::string>("mission_name");
  {
    const int64_t seed = map_node.Get<int64_t>("mission_seed");
    if (seed < 0) map_node.Fail("mission_seed", "an integer >= 0");
    o.mapping.mission_seed = static_cast<uint64_t>(seed);
  }
  o.mapping.save_dir = Resolve(root.file(), map_node.Get<std::string>("save_dir"));
  o.mapping.queue_capacity = map_node.Get<int>("queue_capacity");
  o.mapping.max_frames_in_flight = map_node.Get<int>("max_frames_in_flight");
  const YamlNode stream = map_node.MapChild("stream");
  o.mapping.stream.enabled = stream.Get<bool>("enabled");
  o.mapping.stream.lcm_url = stream.Get<std::string>("lcm_url");
  o.mapping.stream.chunk_channel = stream.Get<std::string>("chunk_channel");
  o.mapping.stream.ack_channel = stream.Get<std::string>("ack_channel");
  o.mapping.stream.delta_vertices = stream.Get<int>("delta_vertices");
  o.mapping.stream.delta_period_s = stream.Get<double>("delta_period_s");
  o.mapping.stream.max_delta_bytes = stream.Get<int>("max_delta_bytes");
  o.mapping.stream.end_timeout_s = stream.Get<double>("end_timeout_s");
  o.mapping.stream.retransmit_timeout_s = stream.Get<double>("retransmit_timeout_s");
  o.mapping.stream.max_window_chunks = stream.Get<int>("max_window_chunks");
  stream.CheckNoUnknownKeys();
  map_node.CheckNoUnknownKeys();

  const YamlNode loc = root.MapChild("localization");
  o.localization.enabled = loc.Get<bool>("enabled");
  o.localization.map = Resolve(root.file(), loc.Get<std::string>("map"));
  o.localization.localizer_file = Resolve(root.file(), loc.Get<std::string>("localizer"));
  // features: a file name ("" = the built-in query profile) or the options inline.
  const YAML::Node features = loc.raw()["features"];
  if (features.IsDefined() && features.IsMap()) {
    o.localization.features = localizer::ReadKeyframeFeatureOptions(loc.Child("features"));
  } else {
    o.localization.features_file = Resolve(root.file(), loc.Get<std::string>("features"));
    if (!o.localization.features_file.empty()) {
      o.localization.features = localizer::LoadKeyframeFeatureOptions(o.localization.features_file);
    }
  }
  o.localization.max_rate_hz = loc.Get<double>("max_rate_hz");
  o.localization.min_inliers = loc.Get<int>("min_inliers");
  o.localization.global_frame.max_jump_m = loc.Get<double>("max_jump_m");
  o.localization.global_frame.max_jump_deg = loc.Get<double>("max_jump_deg");
  o.localization.global_frame.max_gravity_misalignment_deg = loc.Get<double>("max_gravity_misalignment_deg");
  o.localization.global_frame.min_consistent_results = loc.Get<int>("min_consistent_results");
  o.localization.global_frame.forgetting_factor = loc.Get<double>("forgetting_factor");
  o.localization.global_frame.max_consecutive_gated = loc.Get<int>("max_consecutive_gated");
  loc.CheckNoUnknownKeys();

  root.CheckNoUnknownKeys();
  ThrowIfInvalid(o.Validate(), root.file());
  return o;
}

DaemonOptions ParseDaemonOptions(const std::string& yaml_text, const std::string& source_name) {
  return ReadDaemonOptions(YamlNode::LoadString(yaml_text, source_name));
}

DaemonOptions LoadDaemonOptions(const std::string& path) {
  return ReadDaemonOptions(YamlNode::LoadFile(path));
}

namespace {
std::string Quote(const std::string& s) { return "\"" + s + "\""; }
std::string Indent(const std::string& text, const std::string& prefix) {
  std::istringstream in(text);
  std::ostringstream out;
  std::string line;
  while (std::getline(in, line)) out << prefix << line << "\n";
  return out.str();
}
}  // namespace

std::string DaemonOptionsToYaml(const DaemonOptions& o) {
  std::ostringstream out;
  out.precision(17);
  out << "rig: " << Quote(o.rig) << "\n"
      << "lcm_url: " << Quote(o.lcm_url) << "\n"
      << "channel_suffix: " << Quote(o.channel_suffix) << "\n"
      << "vio_camera: " << o.vio_camera << "\n"
      << "stereo: " << (o.StereoEnabled() ? "true" : "false") << "\n"
      << "status_period_s: " << o.status_period_s << "\n"
      << "camera_silence_s: " << o.camera_silence_s << "\n"
      << "time_jump_resume_max_gap_s: " << o.time_jump_resume_max_gap_s << "\n"
      << "channels:\n  cameras: [";
  for (std::size_t i = 0; i < o.channels.cameras.size(); ++i) {
    out << (i ? ", " : "") << o.channels.cameras[i];
  }
  out << "]\n"
      << "  imu: " << o.channels.imu << "\n"
      << "  odometry: " << o.channels.odometry << "\n"
      << "  pose: " << o.channels.pose << "\n"
      << "  status: " << o.channels.status << "\n"
      << "  localization: " << o.channels.localization << "\n"
      << "queues:\n"
      << "  input_capacity: " << o.queues.input_capacity << "\n"
      << "  filter_capacity: " << o.queues.filter_capacity << "\n"
      << "  output_capacity: " << o.queues.output_capacity << "\n"
      << "  image_pool_slots: " << o.queues.image_pool_slots << "\n"
      << "  max_frames_in_flight: " << o.queues.max_frames_in_flight << "\n"
      << "sync:\n"
      << "  frame_grouping_tolerance_ns: " << o.sync.frame_grouping_tolerance_ns << "\n"
      << "  incomplete_frame_timeout_ns: " << o.sync.incomplete_frame_timeout_ns << "\n"
      << "  max_imu_wait_ns: " << o.sync.max_imu_wait_ns << "\n"
      << "  imu_gap_threshold_ns: " << o.sync.imu_gap_threshold_ns << "\n"
      << "  time_jump_threshold_ns: " << o.sync.time_jump_threshold_ns << "\n"
      << "  max_pending_frames: " << o.sync.max_pending_frames << "\n"
      << "mapping:\n"
      << "  enabled: " << (o.mapping.enabled ? "true" : "false") << "\n"
      << "  mission_name: " << Quote(o.mapping.mission_name) << "\n"
      << "  mission_seed: " << o.mapping.mission_seed << "\n"
      << "  save_dir: " << Quote(o.mapping.save_dir) << "\n"
      << "  queue_capacity: " << o.mapping.queue_capacity << "\n"
      << "  max_frames_in_flight: " << o.mapping.max_frames_in_flight << "\n"
      << "  stream:\n"
      << "    enabled: " << (o.mapping.stream.enabled ? "true" : "false") << "\n"
      << "    lcm_url: " << Quote(o.mapping.stream.lcm_url) << "\n"
      << "    chunk_channel: " << o.mapping.stream.chunk_channel << "\n"
      << "    ack_channel: " << o.mapping.stream.ack_channel << "\n"
      << "    delta_vertices: " << o.mapping.stream.delta_vertices << "\n"
      << "    delta_period_s: " << o.mapping.stream.delta_period_s << "\n"
      << "    max_delta_bytes: " << o.mapping.stream.max_delta_bytes << "\n"
      << "    end_timeout_s: " << o.mapping.stream.end_timeout_s << "\n"
      << "    retransmit_timeout_s: " << o.mapping.stream.retransmit_timeout_s << "\n"
      << "    max_window_chunks: " << o.mapping.stream.max_window_chunks << "\n"
      << "  # map builder options"
      << (o.mapping.map_builder_file.empty() ? " (built-in defaults)" : " from " + o.mapping.map_builder_file) << "\n"
      << "  map_builder:\n"
      << Indent(mapping::MapBuilderOptionsToYaml(o.mapping.map_builder), "    ")
      << "localization:\n"
      << "  enabled: " << (o.localization.enabled ? "true" : "false") << "\n"
      << "  map: " << Quote(o.localization.map) << "\n"
      << "  localizer: " << Quote(o.localization.localizer_file) << "\n"
      << "  max_rate_hz: " << o.localization.max_rate_hz << "\n"
      << "  min_inliers: " << o.localization.min_inliers << "\n"
      << "  max_jump_m: " << o.localization.global_frame.max_jump_m << "\n"
      << "  max_jump_deg: " << o.localization.global_frame.max_jump_deg << "\n"
      << "  max_gravity_misalignment_deg: " << o.localization.global_frame.max_gravity_misalignment_deg << "\n"
      << "  min_consistent_results: " << o.localization.global_frame.min_consistent_results << "\n"
      << "  forgetting_factor: " << o.localization.global_frame.forgetting_factor << "\n"
      << "  max_consecutive_gated: " << o.localization.global_frame.max_consecutive_gated << "\n"
      << "  # query keyframe features"
      << (o.localization.features_file.empty() ? " (built-in profile)" : " from " + o.localization.features_file) << "\n"
      << "  features:\n"
      << Indent(localizer::KeyframeFeatureOptionsToYaml(o.localization.features), "    ")
      << "# estimator options" << (o.estimator_file.empty() ? " (built-in defaults)" : " from " + o.estimator_file) << "\n"
      << "estimator:\n"
      << Indent(estimator::FilterOptionsToYaml(o.estimator), "  ");
  return out.str();
}

estimator::FilterOptions DaemonOptions::EffectiveEstimatorOptions() const {
  estimator::FilterOptions o = estimator;
  o.stereo.enabled = StereoEnabled();
  return o;
}

int RequiredImagePoolSlots(const DaemonOptions& options, int num_cameras) {
  // Without map building the frames for the filter carry the VIO camera's image, and with
  // stereo the second camera's too; with map building they carry every camera's image (the
  // stereo image is one of them, the same slot).
  const int frame_images = options.StereoEnabled() ? 2 : 1;
  const int frames = options.mapping.enabled
                         ? num_cameras * (options.sync.max_pending_frames + 2 +
                                          options.queues.max_frames_in_flight + 1 +
                                          options.mapping.max_frames_in_flight) +
                               2
                         : num_cameras * (options.sync.max_pending_frames + 2) +
                               frame_images * (options.queues.max_frames_in_flight + 2);
  const int localization = options.localization.enabled ? 2 : 0;
  return frames + localization;
}

std::string ImagePoolRuleText(const DaemonOptions& options, int num_cameras) {
  std::string rule =
      options.mapping.enabled
          ? ">= cameras x (sync.max_pending_frames + max_frames_in_flight + "
            "mapping.max_frames_in_flight + 3) + 2"
          : options.StereoEnabled()
                ? ">= cameras x (sync.max_pending_frames + 2) + 2 x (max_frames_in_flight + 2) "
                  "(stereo: two images per frame)"
                : ">= cameras x (sync.max_pending_frames + 2) + max_frames_in_flight + 2";
  if (options.localization.enabled) rule += " + 2 (localization)";
  return rule + " = " + std::to_string(RequiredImagePoolSlots(options, num_cameras));
}

}  // namespace vilma::daemon
