#include "vilma/localizer/feature_options.h"

#include <cmath>
#include <sstream>
#include <type_traits>

#include "vilma/core/error.h"
#include "vilma/core/options_fields.h"
#include "vilma/core/validate.h"

namespace vilma::localizer {
namespace {

// One list of every option: reader and writer stay in sync. v(section, key, field&).
template <typename Options, typename Visitor>
void VisitOptions(Options& o, Visitor&& v) {
  v("detector", "type", o.detector.type);
  v("detector", "fast_threshold", o.detector.fast_threshold);
  v("detector", "num_levels", o.detector.num_levels);
  v("detector", "scale_factor", o.detector.scale_factor);
  v("detector", "fill_levels", o.detector.fill_levels);
  v("detector", "fill_below_keypoints", o.detector.fill_below_keypoints);
  v("detector", "grid_cols", o.detector.grid_cols);
  v("detector", "grid_rows", o.detector.grid_rows);
  v("detector", "max_per_cell", o.detector.max_per_cell);
  v("detector", "max_keypoints", o.detector.max_keypoints);
  v("detector", "min_distance_px", o.detector.min_distance_px);
  v("detector", "border_px", o.detector.border_px);
  v("detector", "subpixel", o.detector.subpixel);
  v("detector", "subpixel_window_px", o.detector.subpixel_window_px);
  v("detector", "subpixel_max_shift_px", o.detector.subpixel_max_shift_px);
  v("descriptor", "type", o.descriptor.type);
  v("descriptor", "keypoint_size_px", o.descriptor.keypoint_size_px);
  v("descriptor", "scale_with_level", o.descriptor.scale_with_level);
  v("matcher", "window_radius_px", o.matcher.window_radius_px);
  v("matcher", "max_hamming_distance", o.matcher.max_hamming_distance);
  v("matcher", "ratio", o.matcher.ratio);
  v("matcher", "mutual", o.matcher.mutual);
  v("ransac", "method", o.ransac.method);
  v("ransac", "threshold_px", o.ransac.threshold_px);
  v("ransac", "max_iterations", o.ransac.max_iterations);
  v("ransac", "confidence", o.ransac.confidence);
  v("ransac", "min_matches", o.ransac.min_matches);
  v("ransac", "rotation_only_margin", o.ransac.rotation_only_margin);
  v("ransac", "min_translation_support", o.ransac.min_translation_support);
  v("ransac", "seed", o.ransac.seed);
}

}  // namespace

std::string DetectorOptions::Validate() const {
  if (type != "fast" && type != "orb") return "type: expected \"fast\" or \"orb\"";
  if (fast_threshold < 1 || fast_threshold > 254) {
    return "fast_threshold: expected 1..254";
  }
  if (num_levels < 1 || num_levels > 8) return "num_levels: expected 1..8";
  if (!(std::isfinite(scale_factor) && scale_factor > 1.0 && scale_factor <= 2.0)) {
    return "scale_factor: expected in (1, 2]";
  }
  if (fill_levels < 0 || num_levels + fill_levels > 12) {
    return "fill_levels: expected >= 0 and num_levels + fill_levels <= 12";
  }
  if (fill_levels > 0 && type != "orb") return "fill_levels: expected 0 for type \"fast\"";
  VILMA_RETURN_IF_ERROR(ValidateAtLeast("fill_below_keypoints", fill_below_keypoints, 0));
  VILMA_RETURN_IF_ERROR(ValidateAtLeast("grid_cols", grid_cols, 1));
  VILMA_RETURN_IF_ERROR(ValidateAtLeast("grid_rows", grid_rows, 1));
  VILMA_RETURN_IF_ERROR(ValidateAtLeast("max_per_cell", max_per_cell, 1));
  VILMA_RETURN_IF_ERROR(ValidateAtLeast("max_keypoints", max_keypoints, 1));
  VILMA_RETURN_IF_ERROR(ValidateAtLeast("min_distance_px", min_distance_px, 0.0));
  if (min_distance_px > 100.0) return "min_distance_px: expected <= 100";
  VILMA_RETURN_IF_ERROR(ValidateAtLeast("border_px", border_px, 0));
  if (subpixel != "none" && subpixel != "corner_subpix") {
    return "subpixel: expected \"none\" or \"corner_subpix\"";
  }
  if (subpixel_window_px < 1 || subpixel_window_px > 10) {
    return "subpixel_window_px: expected 1..10";
  }
  if (!(std::isfinite(subpixel_max_shift_px) && subpixel_max_shift_px > 0.0 &&
        subpixel_max_shift_px <= 10.0)) {
    return "subpixel_max_shift_px: expected in (0, 10]";
  }
  return "";
}

std::string DescriptorOptions::Validate() const {
  if (type != "brisk") return "type: expected \"brisk\" (the only type available)";
  if (!(std::isfinite(keypoint_size_px) && keypoint_size_px >= 4.0 &&
        keypoint_size_px <= 64.0)) {
    return "keypoint_size_px: expected in [4, 64]";
  }
  return "";
}

std::string MatcherOptions::Validate() const {
  VILMA_RETURN_IF_ERROR(ValidatePositive("window_radius_px", window_radius_px));
  if (window_radius_px > 500.0) return "window_radius_px: expected <= 500";
  if (max_hamming_distance < 0 || max_hamming_distance > 512) {
    return "max_hamming_distance: expected 0..512";
  }
  if (!(std::isfinite(ratio) && ratio > 0.0 && ratio <= 1.0)) return "ratio: expected in (0, 1]";
  return "";
}

std::string RansacOptions::Validate() const {
  if (method != "two_point" && method != "none") {
    return "method: expected \"two_point\" or \"none\"";
  }
  VILMA_RETURN_IF_ERROR(ValidatePositive("threshold_px", threshold_px));
  VILMA_RETURN_IF_ERROR(ValidateAtLeast("max_iterations", max_iterations, 1));
  if (!(std::isfinite(confidence) && confidence > 0.0 && confidence < 1.0)) {
    return "confidence: expected in (0, 1)";
  }
  VILMA_RETURN_IF_ERROR(ValidateAtLeast("min_matches", min_matches, 2));
  if (!(std::isfinite(rotation_only_margin) && rotation_only_margin >= 0.0 &&
        rotation_only_margin < 1.0)) {
    return "rotation_only_margin: expected in [0, 1)";
  }
  if (!(std::isfinite(min_translation_support) && min_translation_support >= 0.0 &&
        min_translation_support <= 1.0)) {
    return "min_translation_support: expected in [0, 1]";
  }
  VILMA_RETURN_IF_ERROR(ValidateAtLeast("seed", seed, 0));
  return "";
}

std::string KeyframeFeatureOptions::Validate() const {
  std::string e;
  if (!(e = detector.Validate()).empty()) return "detector." + e;
  if (!(e = descriptor.Validate()).empty()) return "descriptor." + e;
  if (!(e = matcher.Validate()).empty()) return "matcher." + e;
  if (!(e = ransac.Validate()).empty()) return "ransac." + e;
  return "";
}

KeyframeFeatureOptions ReadKeyframeFeatureOptions(const YamlNode& root,
                                                  const KeyframeFeatureOptions& base) {
  if (!root.IsMap()) root.Fail("", "a map of keyframe feature options");
  KeyframeFeatureOptions options = base;
  // An absent key keeps its default (docs/design.md "Options files").
  ReadOptionFields(root, MissingKey::kKeepDefault, &options,
                   [](auto& o, auto&& v) { VisitOptions(o, v); });
  root.CheckValid(options.Validate());
  return options;
}

KeyframeFeatureOptions ParseKeyframeFeatureOptions(const std::string& yaml_text,
                                                   const std::string& source_name) {
  return ReadKeyframeFeatureOptions(YamlNode::LoadString(yaml_text, source_name));
}

KeyframeFeatureOptions LoadKeyframeFeatureOptions(const std::string& path,
                                                  const KeyframeFeatureOptions& base) {
  return ReadKeyframeFeatureOptions(YamlNode::LoadFile(path), base);
}

std::string KeyframeFeatureOptionsToYaml(const KeyframeFeatureOptions& options) {
  return OptionFieldsToYaml(options, [](auto& o, auto&& v) { VisitOptions(o, v); });
}

KeyframeFeatureOptions LocalizationQueryFeatureOptions() {
  KeyframeFeatureOptions f;
  f.detector.num_levels = 3;             // scales 1, 1.2, 1.44
  f.descriptor.scale_with_level = true;  // BRISK pattern follows the level: scale invariant
  f.detector.fill_levels = 3;            // close-ups: scales 1.73, 2.07, 2.49 below 150 keypoints
  return f;
}

}  // namespace vilma::localizer
