#include "vilma/core/clock_sync_yaml.h"

namespace vilma {

ClockSyncOptions ReadClockSyncOptions(const YamlNode& node, ClockSyncOptions o) {
  o.window_s = node.GetOr("window_s", o.window_s);
  o.max_window_observations = node.GetOr("max_window_observations", o.max_window_observations);
  o.min_observations = node.GetOr("min_observations", o.min_observations);
  o.min_skew_span_s = node.GetOr("min_skew_span_s", o.min_skew_span_s);
  o.max_skew_ppm = node.GetOr("max_skew_ppm", o.max_skew_ppm);
  o.outlier_threshold_ms = node.GetOr("outlier_threshold_ms", o.outlier_threshold_ms);
  o.jump_below_threshold_ms = node.GetOr("jump_below_threshold_ms", o.jump_below_threshold_ms);
  o.jump_confirm_s = node.GetOr("jump_confirm_s", o.jump_confirm_s);
  node.CheckNoUnknownKeys();
  node.CheckValid(o.Validate());
  return o;
}

void EmitClockSyncOptions(YAML::Emitter& out, const char* key, const ClockSyncOptions& o) {
  const auto kv = [&out](const char* name, const auto& value) {
    out << YAML::Key << name << YAML::Value << value;
  };
  out << YAML::Key << key << YAML::Value << YAML::BeginMap;
  kv("window_s", o.window_s);
  kv("max_window_observations", o.max_window_observations);
  kv("min_observations", o.min_observations);
  kv("min_skew_span_s", o.min_skew_span_s);
  kv("max_skew_ppm", o.max_skew_ppm);
  kv("outlier_threshold_ms", o.outlier_threshold_ms);
  kv("jump_below_threshold_ms", o.jump_below_threshold_ms);
  kv("jump_confirm_s", o.jump_confirm_s);
  out << YAML::EndMap;
}

}  // namespace vilma
