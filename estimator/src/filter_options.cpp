#include "vilma/estimator/filter_options.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <type_traits>
#include <utility>
#include <vector>

#include "vilma/core/error.h"
#include "vilma/core/options_fields.h"
#include "vilma/core/validate.h"

namespace vilma::estimator {
namespace {

// One list of every option: the reader, the writer and the documentation stay in sync. `v` is
// called as v(section, key, field&).
template <typename Visitor, typename Options>
void VisitOptions(Options& o, Visitor&& v) {
  v("", "estimate_extrinsics", o.estimate_extrinsics);
  v("", "estimate_time_offset", o.estimate_time_offset);
  v("", "yaw_observability_constraint", o.yaw_observability_constraint);
  v("init", "window_s", o.init.window_s);
  v("init", "max_static_accel_std", o.init.max_static_accel_std);
  v("init", "max_static_gyro_std", o.init.max_static_gyro_std);
  v("init", "max_gravity_error", o.init.max_gravity_error);
  v("init", "sigma_velocity_static", o.init.sigma_velocity_static);
  v("init", "sigma_velocity_moving", o.init.sigma_velocity_moving);
  v("init", "sigma_roll_pitch", o.init.sigma_roll_pitch);
  v("init", "sigma_yaw", o.init.sigma_yaw);
  v("init", "sigma_gyro_bias", o.init.sigma_gyro_bias);
  v("init", "sigma_accel_bias", o.init.sigma_accel_bias);
  v("init", "sigma_extrinsic_rotation", o.init.sigma_extrinsic_rotation);
  v("init", "sigma_extrinsic_translation", o.init.sigma_extrinsic_translation);
  v("init", "sigma_time_offset", o.init.sigma_time_offset);
  v("init.dynamic", "enabled", o.init.dynamic.enabled);
  v("init.dynamic", "window_s", o.init.dynamic.window_s);
  v("init.dynamic", "max_corners", o.init.dynamic.max_corners);
  v("init.dynamic", "min_corner_distance_px", o.init.dynamic.min_corner_distance_px);
  v("init.dynamic", "max_klt_error_px", o.init.dynamic.max_klt_error_px);
  v("init.dynamic", "min_features", o.init.dynamic.min_features);
  v("init.dynamic", "min_parallax_px", o.init.dynamic.min_parallax_px);
  v("init.dynamic", "pixel_sigma", o.init.dynamic.pixel_sigma);
  v("init.dynamic", "max_rms_px", o.init.dynamic.max_rms_px);
  v("init.dynamic", "min_inlier_ratio", o.init.dynamic.min_inlier_ratio);
  v("init.dynamic", "max_gravity_error", o.init.dynamic.max_gravity_error);
  v("init.dynamic", "max_roll_pitch_sigma", o.init.dynamic.max_roll_pitch_sigma);
  v("init.dynamic", "gyro_bias_sigma", o.init.dynamic.gyro_bias_sigma);
  v("init.dynamic", "timeout_s", o.init.dynamic.timeout_s);
  v("noise", "bearing", o.noise.bearing);
  v("noise", "inverse_depth", o.noise.inverse_depth);
  v("noise", "extrinsic_rotation", o.noise.extrinsic_rotation);
  v("noise", "extrinsic_translation", o.noise.extrinsic_translation);
  v("noise", "time_offset", o.noise.time_offset);
  v("noise", "imu_noise_scale", o.noise.imu_noise_scale);
  v("update", "max_iterations", o.update.max_iterations);
  v("update", "convergence_px", o.update.convergence_px);
  v("update", "intensity_sigma", o.update.intensity_sigma);
  v("update", "pixel_sigma", o.update.pixel_sigma);
  v("update", "huber_threshold", o.update.huber_threshold);
  v("update", "mahalanobis_threshold", o.update.mahalanobis_threshold);
  v("update", "max_mean_abs_error", o.update.max_mean_abs_error);
  v("update", "align_iterations", o.update.align_iterations);
  v("update", "persistent_pixel_sigma", o.update.persistent_pixel_sigma);
  v("features", "max_features", o.features.max_features);
  v("features", "init_inverse_depth", o.features.init_inverse_depth);
  v("features", "init_inverse_depth_sigma", o.features.init_inverse_depth_sigma);
  v("features", "median_depth_init", o.features.median_depth_init);
  v("features", "median_depth_max_ratio", o.features.median_depth_max_ratio);
  v("features", "median_depth_min_features", o.features.median_depth_min_features);
  v("features", "init_bearing_sigma_px", o.features.init_bearing_sigma_px);
  v("features", "max_failures", o.features.max_failures);
  v("features", "min_shi_tomasi", o.features.min_shi_tomasi);
  v("features", "detect_below", o.features.detect_below);
  v("features", "min_inverse_depth", o.features.min_inverse_depth);
  v("features", "refresh_patch_every", o.features.refresh_patch_every);
  v("features", "refresh_min_relative_score", o.features.refresh_min_relative_score);
  v("features.patch", "patch_size", o.features.patch.patch_size);
  v("features.patch", "num_levels", o.features.patch.num_levels);
  v("features.detector", "fast_threshold", o.features.detector.fast_threshold);
  v("features.detector", "min_level", o.features.detector.min_level);
  v("features.detector", "max_level", o.features.detector.max_level);
  v("features.detector", "grid_cols", o.features.detector.grid_cols);
  v("features.detector", "grid_rows", o.features.detector.grid_rows);
  v("features.detector", "min_distance_px", o.features.detector.min_distance_px);
  v("features.detector", "min_shi_tomasi_score", o.features.detector.min_shi_tomasi_score);
  v("features.detector", "border_px", o.features.detector.border_px);
  v("features.detector", "max_candidates_per_bucket",
    o.features.detector.max_candidates_per_bucket);
  v("features.photometric", "min_level", o.features.photometric.min_level);
  v("features.photometric", "max_level", o.features.photometric.max_level);
  v("features.photometric", "compensate_illumination",
    o.features.photometric.compensate_illumination);
  v("health", "max_speed", o.health.max_speed);
  v("health", "max_position_sigma", o.health.max_position_sigma);
  v("health", "max_frames_without_features", o.health.max_frames_without_features);
  v("stereo", "enabled", o.stereo.enabled);
  v("stereo", "camera", o.stereo.camera);
  v("stereo", "update", o.stereo.update);
  v("stereo", "init_depth", o.stereo.init_depth);
  v("stereo", "max_inverse_depth", o.stereo.max_inverse_depth);
  v("stereo", "search_step_px", o.stereo.search_step_px);
  v("stereo", "max_match_error", o.stereo.max_match_error);
  v("stereo", "max_epipolar_px", o.stereo.max_epipolar_px);
  v("stereo", "match_pixel_sigma", o.stereo.match_pixel_sigma);
  v("stereo", "min_inverse_depth_sigma", o.stereo.min_inverse_depth_sigma);
  v("stereo", "min_uniqueness_ratio", o.stereo.min_uniqueness_ratio);
  v("stereo", "joint_update", o.stereo.joint_update);
  v("stereo", "model_error_correlation", o.stereo.model_error_correlation);
  v("stereo", "max_disagreements", o.stereo.max_disagreements);
  v("stereo", "probation_frames", o.stereo.probation_frames);
  v("stereo", "probation_max_mean_nis", o.stereo.probation_max_mean_nis);
  v("stereo", "persistent_disparity_sigma", o.stereo.persistent_disparity_sigma);
  v("stereo", "max_features", o.stereo.max_features);
  v("stereo", "detect_below", o.stereo.detect_below);
  v("stereo", "candidates_per_slot", o.stereo.candidates_per_slot);
  v("stereo", "deferred_match_frames", o.stereo.deferred_match_frames);
  v("stereo", "match_candidates", o.stereo.match_candidates);
  v("stereo", "match_align_iterations", o.stereo.match_align_iterations);
}

}  // namespace

std::string InitOptions::Validate() const {
  VILMA_RETURN_IF_ERROR(ValidatePositive("window_s", window_s));
  VILMA_RETURN_IF_ERROR(ValidatePositive("max_static_accel_std", max_static_accel_std));
  VILMA_RETURN_IF_ERROR(ValidatePositive("max_static_gyro_std", max_static_gyro_std));
  VILMA_RETURN_IF_ERROR(ValidatePositive("max_gravity_error", max_gravity_error));
  VILMA_RETURN_IF_ERROR(ValidatePositive("sigma_velocity_static", sigma_velocity_static));
  VILMA_RETURN_IF_ERROR(ValidatePositive("sigma_velocity_moving", sigma_velocity_moving));
  VILMA_RETURN_IF_ERROR(ValidatePositive("sigma_roll_pitch", sigma_roll_pitch));
  VILMA_RETURN_IF_ERROR(ValidatePositive("sigma_yaw", sigma_yaw));
  VILMA_RETURN_IF_ERROR(ValidatePositive("sigma_gyro_bias", sigma_gyro_bias));
  VILMA_RETURN_IF_ERROR(ValidatePositive("sigma_accel_bias", sigma_accel_bias));
  VILMA_RETURN_IF_ERROR(ValidateNonNegative("sigma_extrinsic_rotation", sigma_extrinsic_rotation));
  VILMA_RETURN_IF_ERROR(
      ValidateNonNegative("sigma_extrinsic_translation", sigma_extrinsic_translation));
  VILMA_RETURN_IF_ERROR(ValidateNonNegative("sigma_time_offset", sigma_time_offset));
  const std::string e = dynamic.Validate();
  if (!e.empty()) return "dynamic." + e;
  return "";
}

std::string DynamicInitOptions::Validate() const {
  VILMA_RETURN_IF_ERROR(ValidatePositive("window_s", window_s));
  VILMA_RETURN_IF_ERROR(ValidateAtLeast("max_corners", max_corners, 3));
  VILMA_RETURN_IF_ERROR(ValidatePositive("min_corner_distance_px", min_corner_distance_px));
  VILMA_RETURN_IF_ERROR(ValidatePositive("max_klt_error_px", max_klt_error_px));
  VILMA_RETURN_IF_ERROR(ValidateAtLeast("min_features", min_features, 3));
  if (min_features > max_corners) return "min_features: expected <= max_corners";
  VILMA_RETURN_IF_ERROR(ValidateNonNegative("min_parallax_px", min_parallax_px));
  VILMA_RETURN_IF_ERROR(ValidatePositive("pixel_sigma", pixel_sigma));
  VILMA_RETURN_IF_ERROR(ValidatePositive("max_rms_px", max_rms_px));
  if (!(min_inlier_ratio >= 0.0 && min_inlier_ratio <= 1.0)) {
    return "min_inlier_ratio: expected in [0, 1]";
  }
  VILMA_RETURN_IF_ERROR(ValidatePositive("max_gravity_error", max_gravity_error));
  VILMA_RETURN_IF_ERROR(ValidatePositive("max_roll_pitch_sigma", max_roll_pitch_sigma));
  VILMA_RETURN_IF_ERROR(ValidatePositive("gyro_bias_sigma", gyro_bias_sigma));
  VILMA_RETURN_IF_ERROR(ValidatePositive("timeout_s", timeout_s));
  if (timeout_s < window_s) return "timeout_s: expected >= window_s";
  return "";
}

std::string ProcessNoiseOptions::Validate() const {
  VILMA_RETURN_IF_ERROR(ValidateNonNegative("bearing", bearing));
  VILMA_RETURN_IF_ERROR(ValidateNonNegative("inverse_depth", inverse_depth));
  VILMA_RETURN_IF_ERROR(ValidateNonNegative("extrinsic_rotation", extrinsic_rotation));
  VILMA_RETURN_IF_ERROR(ValidateNonNegative("extrinsic_translation", extrinsic_translation));
  VILMA_RETURN_IF_ERROR(ValidateNonNegative("time_offset", time_offset));
  VILMA_RETURN_IF_ERROR(ValidatePositive("imu_noise_scale", imu_noise_scale));
  return "";
}

std::string UpdateOptions::Validate() const {
  VILMA_RETURN_IF_ERROR(ValidateAtLeast("max_iterations", max_iterations, 1));
  VILMA_RETURN_IF_ERROR(ValidatePositive("convergence_px", convergence_px));
  VILMA_RETURN_IF_ERROR(ValidatePositive("intensity_sigma", intensity_sigma));
  VILMA_RETURN_IF_ERROR(ValidateNonNegative("pixel_sigma", pixel_sigma));
  VILMA_RETURN_IF_ERROR(ValidatePositive("huber_threshold", huber_threshold));
  VILMA_RETURN_IF_ERROR(ValidatePositive("mahalanobis_threshold", mahalanobis_threshold));
  VILMA_RETURN_IF_ERROR(ValidatePositive("max_mean_abs_error", max_mean_abs_error));
  VILMA_RETURN_IF_ERROR(ValidateAtLeast("align_iterations", align_iterations, 1));
  VILMA_RETURN_IF_ERROR(ValidateNonNegative("persistent_pixel_sigma", persistent_pixel_sigma));
  return "";
}

std::string FeatureOptions::Validate() const {
  VILMA_RETURN_IF_ERROR(ValidateAtLeast("max_features", max_features, 1));
  if (max_features > 1000) return "max_features: expected <= 1000";
  VILMA_RETURN_IF_ERROR(ValidatePositive("init_inverse_depth", init_inverse_depth));
  VILMA_RETURN_IF_ERROR(ValidatePositive("init_inverse_depth_sigma", init_inverse_depth_sigma));
  VILMA_RETURN_IF_ERROR(ValidatePositive("init_bearing_sigma_px", init_bearing_sigma_px));
  VILMA_RETURN_IF_ERROR(ValidatePositive("median_depth_max_ratio", median_depth_max_ratio));
  VILMA_RETURN_IF_ERROR(
      ValidateAtLeast("median_depth_min_features", median_depth_min_features, 1));
  VILMA_RETURN_IF_ERROR(ValidateAtLeast("max_failures", max_failures, 1));
  VILMA_RETURN_IF_ERROR(ValidateNonNegative("min_shi_tomasi", min_shi_tomasi));
  VILMA_RETURN_IF_ERROR(ValidateAtLeast("detect_below", detect_below, 0));
  if (detect_below > max_features) return "detect_below: expected <= max_features";
  VILMA_RETURN_IF_ERROR(ValidateNonNegative("min_inverse_depth", min_inverse_depth));
  VILMA_RETURN_IF_ERROR(ValidateAtLeast("refresh_patch_every", refresh_patch_every, 0));
  VILMA_RETURN_IF_ERROR(
      ValidateNonNegative("refresh_min_relative_score", refresh_min_relative_score));
  if (patch.patch_size < 2) return "patch.patch_size: expected >= 2";
  if (patch.num_levels < 1) return "patch.num_levels: expected >= 1";
  if (photometric.min_level < 0 || photometric.min_level > photometric.max_level) {
    return "photometric.min_level: expected 0 <= min_level <= max_level";
  }
  if (photometric.max_level >= patch.num_levels) {
    return "photometric.max_level: expected < patch.num_levels";
  }
  if (detector.max_level >= patch.num_levels || detector.min_level < 0 ||
      detector.min_level > detector.max_level) {
    return "detector.max_level: expected 0 <= min_level <= max_level < patch.num_levels";
  }
  if (detector.grid_cols < 1 || detector.grid_rows < 1) {
    return "detector.grid_cols/grid_rows: expected >= 1";
  }
  if (!(detector.min_distance_px >= 0.0)) return "detector.min_distance_px: expected >= 0";
  if (detector.border_px < 0) return "detector.border_px: expected >= 0";
  if (detector.fast_threshold < 1) return "detector.fast_threshold: expected >= 1";
  if (detector.max_candidates_per_bucket < 0) {
    return "detector.max_candidates_per_bucket: expected >= 0";
  }
  return "";
}

std::string HealthOptions::Validate() const {
  VILMA_RETURN_IF_ERROR(ValidatePositive("max_speed", max_speed));
  VILMA_RETURN_IF_ERROR(ValidatePositive("max_position_sigma", max_position_sigma));
  VILMA_RETURN_IF_ERROR(ValidateAtLeast("max_frames_without_features", max_frames_without_features, 1));
  return "";
}

std::string StereoOptions::Validate() const {
  VILMA_RETURN_IF_ERROR(ValidateAtLeast("camera", camera, 0));
  VILMA_RETURN_IF_ERROR(ValidatePositive("max_inverse_depth", max_inverse_depth));
  VILMA_RETURN_IF_ERROR(ValidatePositive("search_step_px", search_step_px));
  VILMA_RETURN_IF_ERROR(ValidatePositive("max_match_error", max_match_error));
  VILMA_RETURN_IF_ERROR(ValidatePositive("max_epipolar_px", max_epipolar_px));
  VILMA_RETURN_IF_ERROR(ValidatePositive("match_pixel_sigma", match_pixel_sigma));
  VILMA_RETURN_IF_ERROR(ValidatePositive("min_inverse_depth_sigma", min_inverse_depth_sigma));
  if (!(min_uniqueness_ratio == 0.0 ||
        (std::isfinite(min_uniqueness_ratio) && min_uniqueness_ratio >= 1.0))) {
    return "min_uniqueness_ratio: expected 0 (off) or a ratio >= 1";
  }
  if (!(model_error_correlation >= 0.0 && model_error_correlation <= 1.0)) {
    return "model_error_correlation: expected a value in [0, 1]";
  }
  if (max_disagreements < 0) return "max_disagreements: expected >= 0 (0: off)";
  if (probation_frames < 0) return "probation_frames: expected >= 0 (0: off)";
  VILMA_RETURN_IF_ERROR(ValidatePositive("probation_max_mean_nis", probation_max_mean_nis));
  VILMA_RETURN_IF_ERROR(
      ValidateNonNegative("persistent_disparity_sigma", persistent_disparity_sigma));
  if (max_features < 0 || max_features > 1000) {
    return "max_features: expected 0 (features.max_features) or 1..1000";
  }
  VILMA_RETURN_IF_ERROR(ValidateAtLeast("detect_below", detect_below, 0));
  if (candidates_per_slot < 0 || candidates_per_slot > 100) {
    return "candidates_per_slot: expected 0 (off) .. 100";
  }
  if (deferred_match_frames < 0) return "deferred_match_frames: expected >= 0 (0: off)";
  if (match_candidates < 1 || match_candidates > 100) return "match_candidates: expected 1..100";
  if (match_align_iterations < 0 || match_align_iterations > 1000) {
    return "match_align_iterations: expected 0 (update.align_iterations) .. 1000";
  }
  return "";
}

std::string FilterOptions::Validate() const {
  std::string e;
  if (!(e = init.Validate()).empty()) return "init." + e;
  if (!(e = noise.Validate()).empty()) return "noise." + e;
  if (!(e = update.Validate()).empty()) return "update." + e;
  if (!(e = features.Validate()).empty()) return "features." + e;
  if (!(e = health.Validate()).empty()) return "health." + e;
  if (!(e = stereo.Validate()).empty()) return "stereo." + e;
  if (stereo.enabled) {  // the effective counts with stereo (StereoOptions::max_features)
    const int slots = stereo.max_features > 0 ? stereo.max_features : features.max_features;
    const int below = stereo.detect_below > 0 ? stereo.detect_below : features.detect_below;
    if (below > slots) return "stereo.detect_below: expected <= the stereo feature slots";
  }
  if (estimate_extrinsics && (init.sigma_extrinsic_rotation <= 0.0 ||
                              init.sigma_extrinsic_translation <= 0.0)) {
    return "init.sigma_extrinsic_rotation: expected > 0 when estimate_extrinsics is true";
  }
  if (estimate_time_offset && init.sigma_time_offset <= 0.0) {
    return "init.sigma_time_offset: expected > 0 when estimate_time_offset is true";
  }
  return "";
}

FilterOptions ReadFilterOptions(const YamlNode& root, const FilterOptions& base) {
  FilterOptions options = base;
  // An absent key keeps its default, so an options file written for an older vilma still
  // loads; unknown keys and wrong types stay errors (docs/design.md "Options files").
  ReadOptionFields(root, MissingKey::kKeepDefault, &options,
                   [](auto& o, auto&& v) { VisitOptions(o, v); });
  ThrowIfInvalid(options.Validate(), root.file());
  return options;
}

FilterOptions ParseFilterOptions(const std::string& yaml_text, const std::string& source_name) {
  return ReadFilterOptions(YamlNode::LoadString(yaml_text, source_name));
}

FilterOptions LoadFilterOptions(const std::string& path, const FilterOptions& base) {
  return ReadFilterOptions(YamlNode::LoadFile(path), base);
}

std::string FilterOptionsToYaml(const FilterOptions& options) {
  return OptionFieldsToYaml(options, [](auto& o, auto&& v) { VisitOptions(o, v); });
}

FilterOptions FilterOptionsProfile(const std::string& name) {
  FilterOptions o;
  if (name == "default") return o;
  if (name == "euroc") {
    // Real images: a feature's bearing wanders more than in our renders (patch appearance
    // changes with viewpoint and exposure, non-planar patches, calibration error). With the
    // simulator's 0.001 rad/sqrt(s) (0.1 px per 50 ms frame at f = 458 px) the filter trusts
    // the tracks too much and they pull roll/pitch (1.3 deg on the EuRoC moving slice); 0.005
    // (0.5 px per frame) and more features meet issue 17's targets there (docs/estimator.md).
    o.noise.bearing = 0.005;
    o.features.max_features = 40;
    o.stereo.max_features = 0;  // stereo with the same 40 slots (not measured with 60)
    o.stereo.detect_below = 0;
    return o;
  }
  throw InputError(FormatInputError("estimator options profile", name,
                                    "one of " + FilterOptionsProfileNames()));
}

std::string FilterOptionsProfileNames() { return "default, euroc"; }

}  // namespace vilma::estimator
