#include "vilma/estimator/filter_options.h"

#include <catch2/catch.hpp>
#include <fstream>
#include <regex>
#include <sstream>

#include "test_yaml_keys.h"

namespace vilma::estimator {
namespace {

std::string ReadConfig() {
  std::ifstream in(std::string(VILMA_SOURCE_DIR) + "/config/estimator.yaml");
  REQUIRE(in);
  std::stringstream s;
  s << in.rdbuf();
  return s.str();
}

TEST_CASE("config/estimator.yaml loads and equals the built-in defaults") {
  const FilterOptions loaded =
      LoadFilterOptions(std::string(VILMA_SOURCE_DIR) + "/config/estimator.yaml");
  CHECK(FilterOptionsToYaml(loaded) == FilterOptionsToYaml(FilterOptions()));
  // ... and lists every key (absent keys would keep their defaults unnoticed); so does the
  // euroc profile's file.
  CHECK(vilma::testing::YamlKeyPaths(ReadConfig()) ==
        vilma::testing::YamlKeyPaths(FilterOptionsToYaml(FilterOptions())));
  std::ifstream euroc(std::string(VILMA_SOURCE_DIR) + "/config/estimator_euroc.yaml");
  std::stringstream euroc_text;
  euroc_text << euroc.rdbuf();
  CHECK(vilma::testing::YamlKeyPaths(euroc_text.str()) ==
        vilma::testing::YamlKeyPaths(FilterOptionsToYaml(FilterOptions())));
  CHECK(FilterOptions().Validate().empty());
}

TEST_CASE("the built-in profiles equal their config files, an unknown profile is an error") {
  CHECK(FilterOptionsToYaml(FilterOptionsProfile("default")) ==
        FilterOptionsToYaml(LoadFilterOptions(std::string(VILMA_SOURCE_DIR) + "/config/estimator.yaml")));
  const FilterOptions euroc = FilterOptionsProfile("euroc");
  CHECK(FilterOptionsToYaml(euroc) ==
        FilterOptionsToYaml(
            LoadFilterOptions(std::string(VILMA_SOURCE_DIR) + "/config/estimator_euroc.yaml")));
  CHECK(euroc.Validate().empty());
  CHECK(euroc.noise.bearing == 0.005);
  CHECK(euroc.features.max_features == 40);
  CHECK_THROWS_WITH(FilterOptionsProfile("kitti"),
                    Catch::Contains("kitti") && Catch::Contains("default, euroc"));
}

TEST_CASE("the YAML writer round-trips") {
  FilterOptions o;
  o.features.max_features = 40;
  o.update.intensity_sigma = 3.25;
  o.estimate_extrinsics = true;
  o.features.photometric.compensate_illumination = false;
  const FilterOptions back = ParseFilterOptions(FilterOptionsToYaml(o), "written");
  CHECK(FilterOptionsToYaml(back) == FilterOptionsToYaml(o));
  CHECK(back.features.max_features == 40);
}

TEST_CASE("bad filter configs are rejected naming file, key and expectation") {
  const std::string good = ReadConfig();
  auto replace = [&](const std::string& from, const std::string& to) {
    const std::size_t at = good.find(from);
    REQUIRE(at != std::string::npos);
    std::string text = good;
    text.replace(at, from.size(), to);
    return text;
  };
  CHECK_THROWS_WITH(ParseFilterOptions(replace("max_features: 25", "max_features: 0"), "f.yaml"),
                    "f.yaml: features.max_features: expected >= 1");
  CHECK_THROWS_WITH(
      ParseFilterOptions(replace("max_features: 25", "max_features: many"), "f.yaml"),
      Catch::Contains("f.yaml: features.max_features") && Catch::Contains("integer"));
  CHECK_THROWS_WITH(
      ParseFilterOptions(replace("  max_features: 25", "  max_feature: 25"), "f.yaml"),
      Catch::Contains("f.yaml: features.max_feature"));  // a misspelt key is unknown
  // An absent key keeps its default (an options file of an older vilma still loads).
  const std::string written = FilterOptionsToYaml(FilterOptions());
  const std::string max_features_line = "  max_features: 25\n";
  REQUIRE(written.find(max_features_line) != std::string::npos);
  std::string without_line = written;
  without_line.erase(written.find(max_features_line), max_features_line.size());
  CHECK(ParseFilterOptions(without_line, "f.yaml").features.max_features ==
        FilterOptions().features.max_features);
  FilterOptions forty;
  forty.features.max_features = 40;
  CHECK(FilterOptionsToYaml(ParseFilterOptions("features:\n  max_features: 40\n", "f.yaml")) ==
        FilterOptionsToYaml(forty));
  CHECK_THROWS_WITH(
      ParseFilterOptions(replace("  max_speed: 30.0", "  max_speed: 30.0\n  color: red"),
                         "f.yaml"),
      Catch::Contains("f.yaml") && Catch::Contains("color"));  // unknown key
  CHECK_THROWS_WITH(
      ParseFilterOptions(replace("intensity_sigma: 6.0", "intensity_sigma: -1"), "f.yaml"),
      "f.yaml: update.intensity_sigma: expected > 0");
  CHECK_THROWS_WITH(
      ParseFilterOptions(replace("    max_level: 3", "    max_level: 4"), "f.yaml"),
      Catch::Contains("photometric.max_level: expected < patch.num_levels"));
  CHECK_THROWS_WITH(ParseFilterOptions(replace("detect_below: 20", "detect_below: 30"), "f.yaml"),
                    "f.yaml: features.detect_below: expected <= max_features");
  CHECK_THROWS_WITH(
      ParseFilterOptions(replace("min_uniqueness_ratio: 0.0", "min_uniqueness_ratio: 0.5"),
                         "f.yaml"),
      "f.yaml: stereo.min_uniqueness_ratio: expected 0 (off) or a ratio >= 1");
  CHECK(ParseFilterOptions(replace("min_uniqueness_ratio: 0.0", "min_uniqueness_ratio: 1.3"),
                           "f.yaml")
            .stereo.min_uniqueness_ratio == 1.3);
  CHECK_THROWS_WITH(ParseFilterOptions(replace("model_error_correlation: 0.9",
                                               "model_error_correlation: 1.5"),
                                       "f.yaml"),
                    "f.yaml: stereo.model_error_correlation: expected a value in [0, 1]");
  CHECK_THROWS_WITH(ParseFilterOptions(replace("max_disagreements: 0", "max_disagreements: -1"),
                                       "f.yaml"),
                    "f.yaml: stereo.max_disagreements: expected >= 0 (0: off)");
  CHECK_THROWS_WITH(
      ParseFilterOptions(replace("candidates_per_slot: 0", "candidates_per_slot: -1"), "f.yaml"),
      "f.yaml: stereo.candidates_per_slot: expected 0 (off) .. 100");
  CHECK_THROWS_WITH(ParseFilterOptions(replace("median_depth_max_ratio: 0.3",
                                               "median_depth_max_ratio: 0"),
                                       "f.yaml"),
                    Catch::Contains("f.yaml: features.median_depth_max_ratio: expected > 0"));
  CHECK_THROWS_WITH(ParseFilterOptions(replace("median_depth_min_features: 3",
                                               "median_depth_min_features: 0"),
                                       "f.yaml"),
                    "f.yaml: features.median_depth_min_features: expected >= 1");
  CHECK_THROWS_WITH(ParseFilterOptions(replace("deferred_match_frames: 10",
                                               "deferred_match_frames: -2"),
                                       "f.yaml"),
                    "f.yaml: stereo.deferred_match_frames: expected >= 0 (0: off)");
  CHECK_THROWS_WITH(
      ParseFilterOptions(replace("match_candidates: 3", "match_candidates: 0"), "f.yaml"),
      "f.yaml: stereo.match_candidates: expected 1..100");
  CHECK_THROWS_WITH(ParseFilterOptions(replace("persistent_pixel_sigma: 0.0",
                                               "persistent_pixel_sigma: -0.1"),
                                       "f.yaml"),
                    "f.yaml: update.persistent_pixel_sigma: expected >= 0");
  CHECK_THROWS_WITH(ParseFilterOptions(replace("refresh_patch_every: 0", "refresh_patch_every: -1"),
                                       "f.yaml"),
                    "f.yaml: features.refresh_patch_every: expected >= 0");
  CHECK_THROWS_WITH(ParseFilterOptions(replace("probation_frames: 0", "probation_frames: -2"),
                                       "f.yaml"),
                    "f.yaml: stereo.probation_frames: expected >= 0 (0: off)");
  CHECK_THROWS_WITH(ParseFilterOptions(replace("probation_max_mean_nis: 4.0",
                                               "probation_max_mean_nis: 0"),
                                       "f.yaml"),
                    "f.yaml: stereo.probation_max_mean_nis: expected > 0");
  CHECK_THROWS_WITH(ParseFilterOptions("[1, 2]", "f.yaml"), Catch::Contains("f.yaml"));
  CHECK_THROWS_WITH(LoadFilterOptions("/nonexistent/estimator.yaml"),
                    Catch::Contains("/nonexistent/estimator.yaml"));
}

}  // namespace
}  // namespace vilma::estimator
