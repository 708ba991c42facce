#include "vilma/localizer/feature_options.h"

#include <catch2/catch.hpp>
#include <fstream>
#include <sstream>
#include <string>

#include "vilma/core/error.h"
#include "test_yaml_keys.h"

namespace vilma::localizer {
namespace {

std::string Replace(std::string text, const std::string& from, const std::string& to) {
  const std::size_t pos = text.find(from);
  REQUIRE(pos != std::string::npos);
  return text.replace(pos, from.size(), to);
}

std::string ErrorOf(const std::string& yaml) {
  try {
    ParseKeyframeFeatureOptions(yaml, "features.yaml");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST_CASE("keyframe feature options: defaults are valid and round-trip through YAML",
          "[features]") {
  const KeyframeFeatureOptions defaults;
  CHECK(defaults.Validate().empty());
  KeyframeFeatureOptions changed;
  changed.detector.type = "fast";
  changed.detector.max_keypoints = 321;
  changed.descriptor.keypoint_size_px = 9.5;
  changed.matcher.window_radius_px = 17.25;
  changed.matcher.mutual = false;
  changed.ransac.method = "none";
  changed.ransac.seed = 7;
  const std::string yaml = KeyframeFeatureOptionsToYaml(changed);
  const KeyframeFeatureOptions back = ParseKeyframeFeatureOptions(yaml, "x.yaml");
  CHECK(back.detector.type == "fast");
  CHECK(back.detector.max_keypoints == 321);
  CHECK(back.descriptor.keypoint_size_px == 9.5);
  CHECK(back.matcher.window_radius_px == 17.25);
  CHECK_FALSE(back.matcher.mutual);
  CHECK(back.ransac.method == "none");
  CHECK(back.ransac.seed == 7);
  CHECK(KeyframeFeatureOptionsToYaml(back) == yaml);
}

TEST_CASE("keyframe feature options: strict YAML names file, key and expectation",
          "[features]") {
  const std::string yaml = KeyframeFeatureOptionsToYaml(KeyframeFeatureOptions());
  // Unknown key.
  std::string e = ErrorOf(Replace(yaml, "  ratio:", "  ratoi: 0.8\n  ratio:"));
  CHECK(e.find("features.yaml") != std::string::npos);
  CHECK(e.find("ratoi") != std::string::npos);
  // An absent key or section keeps its default (a features file of an older vilma still loads);
  // what is there is read.
  const KeyframeFeatureOptions defaults;
  const KeyframeFeatureOptions partial = ParseKeyframeFeatureOptions(
      Replace(Replace(yaml, "  border_px: 24\n", ""), "max_keypoints: 600", "max_keypoints: 300"),
      "features.yaml");
  CHECK(partial.detector.border_px == defaults.detector.border_px);
  CHECK(partial.detector.max_keypoints == 300);
  const KeyframeFeatureOptions no_ransac =
      ParseKeyframeFeatureOptions(yaml.substr(0, yaml.find("ransac:")), "features.yaml");
  CHECK(KeyframeFeatureOptionsToYaml(no_ransac) == yaml);
  // Wrong type.
  e = ErrorOf(Replace(yaml, "max_keypoints: 600", "max_keypoints: many"));
  CHECK(e.find("max_keypoints") != std::string::npos);
  // Validate() failures become InputErrors with the field's path.
  e = ErrorOf(Replace(yaml, "type: \"orb\"", "type: \"sift\""));
  CHECK(e.find("detector.type") != std::string::npos);
  e = ErrorOf(Replace(yaml, "type: \"brisk\"", "type: \"freak\""));
  CHECK(e.find("descriptor.type") != std::string::npos);
  e = ErrorOf(Replace(yaml, "ratio: 0.85", "ratio: 1.5"));
  CHECK(e.find("matcher.ratio") != std::string::npos);
  e = ErrorOf(Replace(yaml, "threshold_px: 2", "threshold_px: -1"));
  CHECK(e.find("ransac.threshold_px") != std::string::npos);
}

TEST_CASE("keyframe feature options: Validate rejects each bad field", "[features]") {
  KeyframeFeatureOptions o;
  o.detector.grid_cols = 0;
  CHECK(o.Validate().rfind("detector.grid_cols", 0) == 0);
  o = KeyframeFeatureOptions();
  o.detector.scale_factor = 1.0;
  CHECK(o.Validate().rfind("detector.scale_factor", 0) == 0);
  o = KeyframeFeatureOptions();
  o.matcher.window_radius_px = 0.0;
  CHECK(o.Validate().rfind("matcher.window_radius_px", 0) == 0);
  o = KeyframeFeatureOptions();
  o.matcher.max_hamming_distance = 513;
  CHECK(o.Validate().rfind("matcher.max_hamming_distance", 0) == 0);
  o = KeyframeFeatureOptions();
  o.ransac.confidence = 1.0;
  CHECK(o.Validate().rfind("ransac.confidence", 0) == 0);
  o = KeyframeFeatureOptions();
  o.ransac.method = "eight_point";
  CHECK(o.Validate().rfind("ransac.method", 0) == 0);
  o = KeyframeFeatureOptions();
  o.detector.subpixel = "quadratic";
  CHECK(o.Validate().rfind("detector.subpixel", 0) == 0);
  o = KeyframeFeatureOptions();
  o.detector.subpixel_window_px = 0;
  CHECK(o.Validate().rfind("detector.subpixel_window_px", 0) == 0);
  o = KeyframeFeatureOptions();
  o.detector.subpixel_max_shift_px = 0.0;
  CHECK(o.Validate().rfind("detector.subpixel_max_shift_px", 0) == 0);
  o = KeyframeFeatureOptions();
  o.detector.fill_levels = -1;
  CHECK(o.Validate().rfind("detector.fill_levels", 0) == 0);
  o = KeyframeFeatureOptions();
  o.detector.num_levels = 8;
  o.detector.fill_levels = 5;
  CHECK(o.Validate().rfind("detector.fill_levels", 0) == 0);
  o = KeyframeFeatureOptions();
  o.detector.type = "fast";
  o.detector.fill_levels = 2;
  CHECK(o.Validate().rfind("detector.fill_levels", 0) == 0);
  o.detector.type = "orb";
  CHECK(o.Validate().empty());
  o.detector.fill_below_keypoints = -1;
  CHECK(o.Validate().rfind("detector.fill_below_keypoints", 0) == 0);
}

}  // namespace
}  // namespace vilma::localizer

namespace vilma::localizer {
namespace {

TEST_CASE("keyframe feature options: config/keyframe_features.yaml holds the defaults",
          "[features]") {
  const KeyframeFeatureOptions o =
      LoadKeyframeFeatureOptions(std::string(VILMA_SOURCE_DIR) + "/config/keyframe_features.yaml");
  CHECK(KeyframeFeatureOptionsToYaml(o) == KeyframeFeatureOptionsToYaml(KeyframeFeatureOptions()));
  // ... and lists every key (absent keys would keep their defaults unnoticed).
  std::ifstream in(std::string(VILMA_SOURCE_DIR) + "/config/keyframe_features.yaml");
  std::stringstream text;
  text << in.rdbuf();
  CHECK(vilma::testing::YamlKeyPaths(text.str()) ==
        vilma::testing::YamlKeyPaths(KeyframeFeatureOptionsToYaml(KeyframeFeatureOptions())));
}

}  // namespace
}  // namespace vilma::localizer
