#include "vilma/daemon/daemon_options.h"

#include <cmath>
#include <filesystem>

#include "vilma/core/error.h"
#include "vilma/core/options_fields.h"
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
  if (!(log_slot_wait_s > 0.0)) return "queues.log_slot_wait_s: expected > 0 [s]";
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

namespace {

// A path in the file: relative to the file's folder when read, as given when written.
// (Path = std::string or const std::string: the reader is only called on the first.)
template <typename Path>
auto ResolvedPath(Path& path) {
  return WithCodec(
      path,
      [](const YamlNode& node, const char* key, std::string* value) {
        *value = Resolve(node.file(), node.Get<std::string>(key));
      },
      [](const std::string& value) { return FormatYamlScalar(value); });
}

// A section that is either the name of an options file ("" = built-in defaults) or the options
// inline (a map): *file gets the resolved name ("" when inline), *options what the file or the
// map holds.
template <typename Options, typename Read, typename Load>
void ReadFileOrInline(const YamlNode& node, const char* key, std::string* file, Options* options,
                      Read read, Load load) {
  if (node.Has(key) && node.raw()[key].IsMap()) {
    *options = read(node.Child(key), *options);  // absent keys keep the built-in section's
    file->clear();
    return;
  }
  *file = Resolve(node.file(), node.Get<std::string>(key));
  if (!file->empty()) *options = load(*file, *options);
}

// Such a section is written inline (a block), after a comment saying where the options came
// from: the effective config then reads back to the same options without the file.
std::string WriteFileOrInline(const char* what, const std::string& file, const std::string& yaml) {
  return "\n# " + std::string(what) + (file.empty() ? " (built-in defaults)" : " from " + file) +
         "\n" + yaml;
}

// The field list (core/options_fields.h): reader, --print-config's writer; an absent key keeps
// its default (config/daemon.yaml lists them all; docs/design.md "Options files"). Options = DaemonOptions or const DaemonOptions; the
// codecs' readers take the struct that holds the members one key sets.
template <typename Options, typename Visitor>
void VisitDaemonFields(Options& o, Visitor&& v) {
  v("", "rig", ResolvedPath(o.rig));
  v("", "lcm_url", o.lcm_url);
  v("", "channel_suffix", o.channel_suffix);
  v("", "vio_camera", o.vio_camera);
  // Written as the effective value: the estimator options' own stereo.enabled turns it on too.
  v("", "stereo", WithCodec(o, [](const YamlNode& node, const char* key, DaemonOptions* d) {
                              d->stereo = node.Get<bool>(key);
                            },
                            [](const DaemonOptions& d) {
                              return FormatYamlScalar(d.StereoEnabled());
                            }));
  v("", "status_period_s", o.status_period_s);
  v("", "camera_silence_s", o.camera_silence_s);
  v("", "time_jump_resume_max_gap_s", o.time_jump_resume_max_gap_s);
  v("channels", "cameras", o.channels.cameras);
  v("channels", "imu", o.channels.imu);
  v("channels", "odometry", o.channels.odometry);
  v("channels", "pose", o.channels.pose);
  v("channels", "status", o.channels.status);
  v("channels", "localization", o.channels.localization);
  v("queues", "input_capacity", o.queues.input_capacity);
  v("queues", "filter_capacity", o.queues.filter_capacity);
  v("queues", "output_capacity", o.queues.output_capacity);
  v("queues", "image_pool_slots", o.queues.image_pool_slots);
  v("queues", "max_frames_in_flight", o.queues.max_frames_in_flight);
  v("queues", "log_slot_wait_s", o.queues.log_slot_wait_s);
  v("sync", "frame_grouping_tolerance_ns", o.sync.frame_grouping_tolerance_ns);
  v("sync", "incomplete_frame_timeout_ns", o.sync.incomplete_frame_timeout_ns);
  v("sync", "max_imu_wait_ns", o.sync.max_imu_wait_ns);
  v("sync", "imu_gap_threshold_ns", o.sync.imu_gap_threshold_ns);
  v("sync", "time_jump_threshold_ns", o.sync.time_jump_threshold_ns);
  v("sync", "max_pending_frames", o.sync.max_pending_frames);
  v("mapping", "enabled", o.mapping.enabled);
  v("mapping", "mission_name", o.mapping.mission_name);
  v("mapping", "mission_seed", o.mapping.mission_seed);
  v("mapping", "save_dir", ResolvedPath(o.mapping.save_dir));
  v("mapping", "queue_capacity", o.mapping.queue_capacity);
  v("mapping", "max_frames_in_flight", o.mapping.max_frames_in_flight);
  v("mapping.stream", "enabled", o.mapping.stream.enabled);
  v("mapping.stream", "lcm_url", o.mapping.stream.lcm_url);
  v("mapping.stream", "chunk_channel", o.mapping.stream.chunk_channel);
  v("mapping.stream", "ack_channel", o.mapping.stream.ack_channel);
  v("mapping.stream", "delta_vertices", o.mapping.stream.delta_vertices);
  v("mapping.stream", "delta_period_s", o.mapping.stream.delta_period_s);
  v("mapping.stream", "max_delta_bytes", o.mapping.stream.max_delta_bytes);
  v("mapping.stream", "end_timeout_s", o.mapping.stream.end_timeout_s);
  v("mapping.stream", "retransmit_timeout_s", o.mapping.stream.retransmit_timeout_s);
  v("mapping.stream", "max_window_chunks", o.mapping.stream.max_window_chunks);
  v("mapping", "map_builder",
    WithCodec(o.mapping,
              [](const YamlNode& node, const char* key, MappingOptions* m) {
                ReadFileOrInline(node, key, &m->map_builder_file, &m->map_builder,
                                 mapping::ReadMapBuilderOptions, mapping::LoadMapBuilderOptions);
              },
              [](const MappingOptions& m) {
                return WriteFileOrInline("map builder options", m.map_builder_file,
                                         mapping::MapBuilderOptionsToYaml(m.map_builder));
              }));
  v("localization", "enabled", o.localization.enabled);
  v("localization", "map", ResolvedPath(o.localization.map));
  v("localization", "localizer", ResolvedPath(o.localization.localizer_file));
  v("localization", "max_rate_hz", o.localization.max_rate_hz);
  v("localization", "min_inliers", o.localization.min_inliers);
  v("localization", "max_jump_m", o.localization.global_frame.max_jump_m);
  v("localization", "max_jump_deg", o.localization.global_frame.max_jump_deg);
  v("localization", "max_gravity_misalignment_deg",
    o.localization.global_frame.max_gravity_misalignment_deg);
  v("localization", "min_consistent_results", o.localization.global_frame.min_consistent_results);
  v("localization", "forgetting_factor", o.localization.global_frame.forgetting_factor);
  v("localization", "max_consecutive_gated", o.localization.global_frame.max_consecutive_gated);
  v("localization", "drift_position_m_per_sqrt_s",
    o.localization.global_frame.drift_position_m_per_sqrt_s);
  v("localization", "drift_yaw_deg_per_sqrt_s",
    o.localization.global_frame.drift_yaw_deg_per_sqrt_s);
  v("localization", "min_sigma_position_m", o.localization.global_frame.min_sigma_position_m);
  v("localization", "min_sigma_yaw_deg", o.localization.global_frame.min_sigma_yaw_deg);
  v("localization", "noise_scale_window", o.localization.global_frame.noise_scale_window);
  v("localization", "noise_scale_prior", o.localization.global_frame.noise_scale_prior);
  v("localization", "noise_scale_prior_weight",
    o.localization.global_frame.noise_scale_prior_weight);
  v("localization", "features",
    WithCodec(o.localization,
              [](const YamlNode& node, const char* key, LocalizationOptions* l) {
                ReadFileOrInline(node, key, &l->features_file, &l->features,
                                 localizer::ReadKeyframeFeatureOptions,
                                 localizer::LoadKeyframeFeatureOptions);
              },
              [](const LocalizationOptions& l) {
                // "" is the built-in query profile, not the struct's defaults.
                return "\n# query keyframe features" +
                       (l.features_file.empty() ? std::string(" (built-in profile)")
                                                : " from " + l.features_file) +
                       "\n" + localizer::KeyframeFeatureOptionsToYaml(l.features);
              }));
  v("", "estimator",
    WithCodec(o,
              [](const YamlNode& node, const char* key, DaemonOptions* d) {
                ReadFileOrInline(node, key, &d->estimator_file, &d->estimator,
                                 estimator::ReadFilterOptions, estimator::LoadFilterOptions);
              },
              [](const DaemonOptions& d) {
                return WriteFileOrInline("estimator options", d.estimator_file,
                                         estimator::FilterOptionsToYaml(d.estimator));
              }));
}

}  // namespace

DaemonOptions ReadDaemonOptions(const YamlNode& root) {
  if (!root.IsMap()) root.Fail("", "a map of daemon options");
  DaemonOptions o;
  // An absent key keeps its default (docs/design.md "Options files").
  ReadOptionFields(root, MissingKey::kKeepDefault, &o,
                   [](auto& options, auto&& v) { VisitDaemonFields(options, v); });
  ThrowIfInvalid(o.Validate(), root.file());
  return o;
}

DaemonOptions ParseDaemonOptions(const std::string& yaml_text, const std::string& source_name) {
  return ReadDaemonOptions(YamlNode::LoadString(yaml_text, source_name));
}

DaemonOptions LoadDaemonOptions(const std::string& path) {
  return ReadDaemonOptions(YamlNode::LoadFile(path));
}

std::string DaemonOptionsToYaml(const DaemonOptions& o) {
  return OptionFieldsToYaml(o, [](auto& options, auto&& v) { VisitDaemonFields(options, v); });
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
