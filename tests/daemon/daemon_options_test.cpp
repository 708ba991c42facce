#include "vilma/daemon/daemon_options.h"

#include <catch2/catch.hpp>
#include <fstream>
#include <iterator>
#include <set>
#include <sstream>

#include "vilma/core/error.h"
#include "test_yaml_keys.h"

namespace vilma::daemon {
namespace {

std::string DefaultConfigText() {
  std::ifstream in(std::string(VILMA_SOURCE_DIR) + "/config/daemon.yaml");
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string Replace(std::string text, const std::string& from, const std::string& to) {
  const std::size_t at = text.find(from);
  REQUIRE(at != std::string::npos);
  return text.replace(at, from.size(), to);
}

std::string ErrorOf(const std::string& text) {
  try {
    ParseDaemonOptions(text, "daemon.yaml");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST_CASE("config/daemon.yaml equals the built-in defaults") {
  const DaemonOptions loaded = ParseDaemonOptions(DefaultConfigText(), "daemon.yaml");
  CHECK(DaemonOptionsToYaml(loaded) == DaemonOptionsToYaml(DaemonOptions()));
  // ... and lists every key (absent keys would keep their defaults unnoticed).
  // The sections that may name a file are written inline; the file names them ("" = built-in).
  std::set<std::string> written = testing::YamlKeyPaths(DaemonOptionsToYaml(DaemonOptions()));
  for (const std::string file_section : {"estimator.", "mapping.map_builder.",
                                         "localization.features."}) {
    for (auto it = written.begin(); it != written.end();) {
      it = it->rfind(file_section, 0) == 0 ? written.erase(it) : std::next(it);
    }
  }
  CHECK(testing::YamlKeyPaths(DefaultConfigText()) == written);
  CHECK(DaemonOptions().Validate().empty());
}

TEST_CASE("the effective config reads back to the same options") {
  DaemonOptions o;
  o.channels.cameras = {"CAM0"};
  o.queues.image_pool_slots = 40;
  o.sync.max_pending_frames = 5;
  o.estimator.features.max_features = 30;
  const DaemonOptions back = ParseDaemonOptions(DaemonOptionsToYaml(o), "effective.yaml");
  CHECK(DaemonOptionsToYaml(back) == DaemonOptionsToYaml(o));
  CHECK(back.estimator.features.max_features == 30);
}

TEST_CASE("bad daemon configs are rejected naming the key") {
  const std::string good = DefaultConfigText();
  CHECK(ErrorOf(good).empty());
  CHECK_THAT(ErrorOf(Replace(good, "vio_camera: 0", "vio_camera: 2")),
             Catch::Contains("daemon.yaml") && Catch::Contains("vio_camera"));
  CHECK_THAT(ErrorOf(Replace(good, "imu: IMU", "imu: imu.*")), Catch::Contains("channels.imu"));
  CHECK_THAT(ErrorOf(Replace(good, "input_capacity: 4096", "input_capacity: 3")),
             Catch::Contains("queues.input_capacity"));
  CHECK_THAT(ErrorOf(Replace(good, "log_slot_wait_s: 120", "log_slot_wait_s: 0")),
             Catch::Contains("queues.log_slot_wait_s"));
  CHECK_THAT(ErrorOf(Replace(good, "max_pending_frames: 8", "max_pending_frames: 8\n  bogus: 1")),
             Catch::Contains("bogus"));
  CHECK(ParseDaemonOptions(Replace(good, "status_period_s: 1.0", ""), "daemon.yaml").status_period_s ==
        DaemonOptions().status_period_s);  // absent: the default
  CHECK_THAT(ErrorOf(Replace(good, "estimator: \"\"", "estimator: {max_features: 3}")),
             Catch::Contains("estimator"));
  CHECK_THAT(ErrorOf(Replace(good, "estimator: \"\"", "estimator: no-such-file.yaml")),
             Catch::Contains("no-such-file.yaml"));
}

TEST_CASE("stereo: the daemon key turns on the estimator's stereo, validated, read back") {
  const std::string good = DefaultConfigText();
  const DaemonOptions mono = ParseDaemonOptions(good, "daemon.yaml");
  CHECK_FALSE(mono.StereoEnabled());
  CHECK_FALSE(mono.EffectiveEstimatorOptions().stereo.enabled);
  const DaemonOptions stereo =
      ParseDaemonOptions(Replace(good, "stereo: false", "stereo: true"), "daemon.yaml");
  CHECK(stereo.StereoEnabled());
  CHECK(stereo.EffectiveEstimatorOptions().stereo.enabled);
  CHECK(stereo.EffectiveEstimatorOptions().stereo.camera == 1);
  // The effective config says stereo: true and reads back to the same options.
  CHECK_THAT(DaemonOptionsToYaml(stereo), Catch::Contains("\nstereo: true\n"));
  CHECK(DaemonOptionsToYaml(ParseDaemonOptions(DaemonOptionsToYaml(stereo), "effective.yaml")) ==
        DaemonOptionsToYaml(stereo));
  // The estimator options' own stereo.enabled turns it on as well.
  DaemonOptions via_estimator;
  via_estimator.estimator.stereo.enabled = true;
  CHECK(via_estimator.StereoEnabled());
  CHECK_THAT(DaemonOptionsToYaml(via_estimator), Catch::Contains("\nstereo: true\n"));
  // The second camera must be subscribed and differ from the VIO camera.
  CHECK_THAT(ErrorOf(Replace(Replace(good, "stereo: false", "stereo: true"), "cameras: [CAM0, CAM1]",
                             "cameras: [CAM0]")),
             Catch::Contains("daemon.yaml") && Catch::Contains("estimator.stereo.camera"));
  CHECK_THAT(ErrorOf(Replace(Replace(good, "stereo: false", "stereo: true"), "vio_camera: 0",
                             "vio_camera: 1")),
             Catch::Contains("estimator.stereo.camera") && Catch::Contains("vio_camera"));
  // Mono with one subscribed camera stays valid.
  CHECK(ErrorOf(Replace(good, "cameras: [CAM0, CAM1]", "cameras: [CAM0]")).empty());
  CHECK_THAT(ErrorOf(Replace(good, "stereo: false", "stereo: 1.5")), Catch::Contains("stereo"));
  CHECK_FALSE(ParseDaemonOptions(Replace(good, "stereo: false", ""), "daemon.yaml").stereo);  // absent
}

TEST_CASE("the estimator options can be given inline") {
  std::ifstream in(std::string(VILMA_SOURCE_DIR) + "/config/estimator.yaml");
  std::stringstream ss;
  ss << in.rdbuf();
  std::string inline_options;
  std::string line;
  while (std::getline(ss, line)) inline_options += "  " + line + "\n";
  inline_options = Replace(inline_options, "max_features: 25", "max_features: 30");
  const std::string text =
      Replace(DefaultConfigText(), "estimator: \"\"", "estimator:\n" + inline_options);
  const DaemonOptions o = ParseDaemonOptions(text, "daemon.yaml");
  CHECK(o.estimator.features.max_features == 30);
}


TEST_CASE("map building options: strict, validated, read back", "[daemon][mapping]") {
  const std::string good = DefaultConfigText();
  const std::string on = Replace(good, "enabled: false          # run", "enabled: true          # run");
  const DaemonOptions o = ParseDaemonOptions(on, "daemon.yaml");
  CHECK(o.mapping.enabled);
  CHECK_FALSE(o.mapping.stream.enabled);
  CHECK(o.mapping.map_builder.vertex_rate_hz == 10.0);
  // Streaming or saving without the stage.
  CHECK_THAT(ErrorOf(Replace(good, "    enabled: false\n    lcm_url", "    enabled: true\n    lcm_url")),
             Catch::Contains("mapping.stream.enabled"));
  CHECK_THAT(ErrorOf(Replace(good, "save_dir: \"\"", "save_dir: maps")),
             Catch::Contains("mapping.save_dir"));
  CHECK_THAT(ErrorOf(Replace(good, "chunk_channel: VILMA_MISSION ", "chunk_channel: mission ")),
             Catch::Contains("mapping.stream.chunk_channel"));
  CHECK_THAT(ErrorOf(Replace(good, "chunk_channel: VILMA_MISSION ", "chunk_channel: VILMA_MISSION_ACK ")),
             Catch::Contains("mapping.stream.ack_channel"));
  CHECK_THAT(ErrorOf(Replace(good, "delta_vertices: 10", "delta_vertices: 0")),
             Catch::Contains("mapping.stream.delta_vertices"));
  CHECK_THAT(ErrorOf(Replace(good, "end_timeout_s: 5.0", "end_timeout_s: -1")),
             Catch::Contains("mapping.stream.end_timeout_s"));
  // max_delta_bytes: 64 KiB .. 16 MiB (DaemonOptions' kMaxDeltaBytes), both ends named.
  CHECK_THAT(ErrorOf(Replace(good, "max_delta_bytes: 1048576", "max_delta_bytes: 65535")),
             Catch::Contains("mapping.stream.max_delta_bytes: expected 65536 .. 16777216"));
  CHECK_THAT(ErrorOf(Replace(good, "max_delta_bytes: 1048576", "max_delta_bytes: 16777217")),
             Catch::Contains("mapping.stream.max_delta_bytes: expected 65536 .. 16777216"));
  CHECK(ErrorOf(Replace(good, "max_delta_bytes: 1048576", "max_delta_bytes: 16777216")).empty());
  CHECK_THAT(ErrorOf(Replace(good, "max_frames_in_flight: 2 # frames with", "max_frames_in_flight: 0 #")),
             Catch::Contains("mapping.max_frames_in_flight"));
  CHECK_THAT(ErrorOf(Replace(good, "mission_seed: 0", "mission_seed: -3")),
             Catch::Contains("mission_seed"));
  CHECK_THAT(ErrorOf(Replace(good, "mission_seed: 0", "mission_seed: 0\n  bogus_key: 1")),
             Catch::Contains("bogus_key"));
  // An inline builder section lists only what differs from the defaults.
  CHECK_THAT(ErrorOf(Replace(good, "map_builder: \"\"", "map_builder: {vertex_rate_hz: -1}")),
             Catch::Contains("vertex_rate_hz"));
  {
    const DaemonOptions partial_builder = ParseDaemonOptions(
        Replace(good, "map_builder: \"\"", "map_builder: {vertex_rate_hz: 4}"), "daemon.yaml");
    CHECK(partial_builder.mapping.map_builder.vertex_rate_hz == 4);
    CHECK(partial_builder.mapping.map_builder.landmark_quality.min_observers ==
          mapping::MapBuilderOptions().landmark_quality.min_observers);
  }
  CHECK_THAT(ErrorOf(Replace(good, "map_builder: \"\"", "map_builder: no-such-builder.yaml")),
             Catch::Contains("no-such-builder.yaml"));

  // The effective YAML (builder options inline) reads back.
  DaemonOptions m = o;
  m.mapping.stream.enabled = true;
  m.mapping.mission_name = "lab";
  m.mapping.mission_seed = 42;
  m.mapping.map_builder.vertex_rate_hz = 5.0;
  const DaemonOptions back = ParseDaemonOptions(DaemonOptionsToYaml(m), "effective.yaml");
  CHECK(DaemonOptionsToYaml(back) == DaemonOptionsToYaml(m));
  CHECK(back.mapping.map_builder.vertex_rate_hz == 5.0);
  CHECK(back.mapping.mission_seed == 42);
}

}  // namespace
}  // namespace vilma::daemon

namespace vilma::daemon {
namespace {

TEST_CASE("localization options: strict, validated, read back", "[daemon][localization]") {
  const std::string good = DefaultConfigText();
  const DaemonOptions d = ParseDaemonOptions(good, "daemon.yaml");
  CHECK_FALSE(d.localization.enabled);
  CHECK(d.localization.max_rate_hz == 2.0);
  // Enabled without a map, a map without enabled, bad values, unknown keys: each named.
  CHECK_THAT(ErrorOf(Replace(good, "enabled: false          # run the localizer",
                             "enabled: true          # run the localizer")),
             Catch::Contains("localization.map"));
  CHECK_THAT(ErrorOf(Replace(good, "map: \"\"", "map: room.vlocmap")), Catch::Contains("localization.map"));
  CHECK_THAT(ErrorOf(Replace(good, "max_rate_hz: 2.0", "max_rate_hz: 0")),
             Catch::Contains("localization.max_rate_hz"));
  CHECK_THAT(ErrorOf(Replace(good, "min_inliers: 30", "min_inliers: 2")),
             Catch::Contains("localization.min_inliers"));
  CHECK_THAT(ErrorOf(Replace(good, "max_jump_m: 0.5", "max_jump_m: -1")),
             Catch::Contains("localization.max_jump_m"));
  CHECK_THAT(ErrorOf(Replace(good, "max_gravity_misalignment_deg: 3.0", "max_gravity_misalignment_deg: 0")),
             Catch::Contains("localization.max_gravity_misalignment_deg"));
  CHECK_THAT(ErrorOf(Replace(good, "forgetting_factor: 0.8", "forgetting_factor: 1.5")),
             Catch::Contains("localization.forgetting_factor"));
  // The random walk (the default) needs both drifts; both 0 is the forgetting factor.
  CHECK_THAT(ErrorOf(Replace(good, "drift_position_m_per_sqrt_s: 0.01", "drift_position_m_per_sqrt_s: 0.0")),
             Catch::Contains("localization.drift_yaw_deg_per_sqrt_s"));
  const std::string forgetting =
      Replace(Replace(good, "drift_position_m_per_sqrt_s: 0.01", "drift_position_m_per_sqrt_s: 0.0"),
              "drift_yaw_deg_per_sqrt_s: 0.3", "drift_yaw_deg_per_sqrt_s: 0.0");
  CHECK_FALSE(ParseDaemonOptions(forgetting, "daemon.yaml").localization.global_frame.random_walk());
  CHECK(ParseDaemonOptions(good, "daemon.yaml").localization.global_frame.random_walk());
  CHECK_THAT(ErrorOf(Replace(good, "min_sigma_position_m: 0.01", "min_sigma_position_m: 0")),
             Catch::Contains("localization.min_sigma_position_m"));
  // Adaptive measurement noise: only with the random walk; its prior scale is >= 1.
  CHECK_THAT(ErrorOf(Replace(forgetting, "noise_scale_window: 0", "noise_scale_window: 20")),
             Catch::Contains("localization.noise_scale_window"));
  CHECK(ErrorOf(Replace(good, "noise_scale_window: 0", "noise_scale_window: 20")).empty());
  CHECK_THAT(ErrorOf(Replace(good, "noise_scale_prior: 4.0", "noise_scale_prior: 0.5")),
             Catch::Contains("localization.noise_scale_prior"));
  CHECK_THAT(ErrorOf(Replace(good, "noise_scale_prior_weight: 5.0", "noise_scale_prior_weight: -1")),
             Catch::Contains("localization.noise_scale_prior_weight"));
  CHECK_THAT(ErrorOf(Replace(good, "max_consecutive_gated: 5", "max_consecutive_gated: 5\n  bogus: 1")),
             Catch::Contains("bogus"));
  // An absent key keeps its default (a daemon.yaml of an older vilma still loads).
  CHECK(ParseDaemonOptions(Replace(Replace(good, "min_consistent_results: 2", ""),
                                   "forgetting_factor: 0.8", "forgetting_factor: 0.5"),
                           "daemon.yaml")
            .localization.global_frame.min_consistent_results == DaemonOptions().localization.global_frame.min_consistent_results);
  CHECK(ParseDaemonOptions(Replace(good, "forgetting_factor: 0.8", "forgetting_factor: 0.5"),
                           "daemon.yaml")
            .localization.global_frame.forgetting_factor == 0.5);
  // Read back (the map path is absolute after the round trip).
  DaemonOptions o;
  o.localization.enabled = true;
  o.localization.map = "/maps/room.vlocmap";
  o.localization.max_rate_hz = 5.0;
  o.localization.global_frame.max_jump_deg = 7.5;
  const DaemonOptions back = ParseDaemonOptions(DaemonOptionsToYaml(o), "effective.yaml");
  CHECK(DaemonOptionsToYaml(back) == DaemonOptionsToYaml(o));
  CHECK(back.localization.map == "/maps/room.vlocmap");
  CHECK(back.localization.max_rate_hz == 5.0);
}

}  // namespace
}  // namespace vilma::daemon

namespace vilma::daemon {
namespace {

TEST_CASE("localization query features: built-in profile, file, inline, config file equals the default",
          "[daemon][localization]") {
  // The built-in profile: the map builder's features with a scale pyramid for the query.
  const localizer::KeyframeFeatureOptions def = localizer::LocalizationQueryFeatureOptions();
  CHECK(def.detector.num_levels == 3);
  CHECK(def.descriptor.scale_with_level);
  CHECK(def.detector.fill_levels == 3);  // coarser levels for close-ups (below 150 keypoints)
  CHECK(mapping::MapBuilderOptions().features.detector.fill_levels == 0);
  localizer::KeyframeFeatureOptions expected = mapping::MapBuilderOptions().features;
  expected.detector.num_levels = 3;
  expected.descriptor.scale_with_level = true;
  expected.detector.fill_levels = 3;
  CHECK(localizer::KeyframeFeatureOptionsToYaml(def) == localizer::KeyframeFeatureOptionsToYaml(expected));
  CHECK(localizer::KeyframeFeatureOptionsToYaml(LocalizationOptions().features) ==
        localizer::KeyframeFeatureOptionsToYaml(def));
  // config/localization_features.yaml holds it.
  const std::string file = std::string(VILMA_SOURCE_DIR) + "/config/localization_features.yaml";
  CHECK(localizer::KeyframeFeatureOptionsToYaml(localizer::LoadKeyframeFeatureOptions(file)) ==
        localizer::KeyframeFeatureOptionsToYaml(def));

  const std::string good = DefaultConfigText();
  CHECK(ParseDaemonOptions(good, "daemon.yaml").localization.features_file.empty());
  // A file (relative to the daemon config) ...
  const DaemonOptions from_file = ParseDaemonOptions(
      Replace(good, "features: \"\"", "features: " + file), "daemon.yaml");
  CHECK(from_file.localization.features_file == file);
  CHECK(from_file.localization.features.detector.num_levels == 3);
  CHECK_THAT(ErrorOf(Replace(good, "features: \"\"", "features: no-such-features.yaml")),
             Catch::Contains("no-such-features.yaml"));
  // ... or inline, strict (every key; a bad value names the field).
  DaemonOptions o;
  o.localization.features.detector.num_levels = 2;
  o.localization.features.detector.max_keypoints = 900;
  const std::string effective = DaemonOptionsToYaml(o);
  const DaemonOptions back = ParseDaemonOptions(effective, "effective.yaml");
  CHECK(DaemonOptionsToYaml(back) == effective);
  CHECK(back.localization.features.detector.num_levels == 2);
  CHECK(back.localization.features.detector.max_keypoints == 900);
  CHECK_THAT(ErrorOf(Replace(effective, "max_keypoints: 900", "max_keypoints: -1")),
             Catch::Contains("max_keypoints"));
  // An absent key of an inline section keeps the built-in section's value (the localization
  // profile's, not the keyframe defaults').
  const DaemonOptions without_num_levels =
      ParseDaemonOptions(Replace(effective, "num_levels: 2", ""), "effective.yaml");
  CHECK(localizer::LocalizationQueryFeatureOptions().detector.num_levels == 3);
  CHECK(localizer::KeyframeFeatureOptions().detector.num_levels == 1);
  CHECK(without_num_levels.localization.features.detector.num_levels == 3);
  CHECK(without_num_levels.localization.features.detector.max_keypoints == 900);
}

TEST_CASE("the VILMA_LOC channel is configurable and validated", "[daemon][localization]") {
  const std::string good = DefaultConfigText();
  CHECK(ParseDaemonOptions(good, "daemon.yaml").channels.localization == "VILMA_LOC");
  CHECK(DaemonOptions().channels.localization == "VILMA_LOC");
  CHECK_THAT(ErrorOf(Replace(good, "localization: VILMA_LOC", "localization: vilma.loc")),
             Catch::Contains("channels.localization"));
  CHECK_THAT(ErrorOf(Replace(good, "localization: VILMA_LOC", "localization: \"\"")),
             Catch::Contains("channels.localization"));
  CHECK(ParseDaemonOptions(Replace(good, "  localization: VILMA_LOC", ""), "daemon.yaml")
            .channels.localization == "VILMA_LOC");  // absent: the default
  CHECK_THAT(ErrorOf(Replace(good, "  localization: VILMA_LOC", "  localisation: VILMA_LOC")),
             Catch::Contains("localization"));
  DaemonOptions o;
  o.channels.localization = "LOC2";
  CHECK(ParseDaemonOptions(DaemonOptionsToYaml(o), "effective.yaml").channels.localization == "LOC2");
}

}  // namespace
}  // namespace vilma::daemon

TEST_CASE("image pool slots: mapping, localization and cameras add up (the LOC slots count)") {
  vilma::daemon::DaemonOptions o;
  o.sync.max_pending_frames = 8;
  o.queues.max_frames_in_flight = 2;
  o.mapping.max_frames_in_flight = 2;
  o.mapping.enabled = false;
  o.localization.enabled = false;
  CHECK(vilma::daemon::RequiredImagePoolSlots(o, 1) == 1 * (8 + 2) + 2 + 2);
  o.localization.enabled = true;  // LOC alone: the VIO rule + 2 (was: the mapping rule)
  CHECK(vilma::daemon::RequiredImagePoolSlots(o, 1) == 14 + 2);
  o.mapping.enabled = true;
  CHECK(vilma::daemon::RequiredImagePoolSlots(o, 1) == 1 * (8 + 2 + 2 + 1 + 2) + 2 + 2);
  CHECK(vilma::daemon::RequiredImagePoolSlots(o, 2) == 2 * 15 + 2 + 2);
  o.localization.enabled = false;
  CHECK(vilma::daemon::RequiredImagePoolSlots(o, 2) == 32);
  CHECK_THAT(vilma::daemon::ImagePoolRuleText(o, 2), Catch::EndsWith(" = 32"));
  // Stereo: with map building the frames already carry every camera's image (the stereo image
  // is one of them): unchanged. Without, each frame for the filter holds two images.
  o.stereo = true;
  CHECK(vilma::daemon::RequiredImagePoolSlots(o, 2) == 32);
  o.localization.enabled = true;
  CHECK(vilma::daemon::RequiredImagePoolSlots(o, 2) == 34);
  o.mapping.enabled = false;
  o.localization.enabled = false;
  CHECK(vilma::daemon::RequiredImagePoolSlots(o, 2) == 2 * (8 + 2) + 2 * (2 + 2));
  CHECK_THAT(vilma::daemon::ImagePoolRuleText(o, 2),
             Catch::Contains("stereo") && Catch::EndsWith(" = 28"));
  o.localization.enabled = true;
  CHECK(vilma::daemon::RequiredImagePoolSlots(o, 2) == 28 + 2);
  o.stereo = false;
  o.estimator.stereo.enabled = true;  // the estimator's own switch counts the same
  CHECK(vilma::daemon::RequiredImagePoolSlots(o, 2) == 30);
  o.estimator.stereo.enabled = false;
  CHECK(vilma::daemon::RequiredImagePoolSlots(o, 2) == 2 * 10 + 2 + 2 + 2);
  // The defaults hold stereo with mapping and LOC, and stereo with LOC alone.
  vilma::daemon::DaemonOptions defaults;
  defaults.stereo = true;
  defaults.mapping.enabled = true;
  defaults.localization.enabled = true;
  CHECK(defaults.queues.image_pool_slots >= vilma::daemon::RequiredImagePoolSlots(defaults, 2));
  defaults.mapping.enabled = false;
  CHECK(defaults.queues.image_pool_slots >= vilma::daemon::RequiredImagePoolSlots(defaults, 2));
}
