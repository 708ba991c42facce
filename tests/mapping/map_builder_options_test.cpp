#include "vilma/mapping/map_builder_options.h"

#include <catch2/catch.hpp>
#include <fstream>
#include <sstream>
#include <string>

#include "vilma/core/error.h"
#include "test_yaml_keys.h"

using vilma::InputError;
using namespace vilma::mapping;

namespace {

std::string Replace(std::string text, const std::string& from, const std::string& to) {
  const std::size_t at = text.find(from);
  REQUIRE(at != std::string::npos);
  return text.replace(at, from.size(), to);
}

}  // namespace

TEST_CASE("map builder options: defaults are valid and config/map_builder.yaml holds them",
          "[mapping]") {
  const MapBuilderOptions defaults;
  CHECK(defaults.Validate().empty());
  const MapBuilderOptions file =
      LoadMapBuilderOptions(std::string(VILMA_SOURCE_DIR) + "/config/map_builder.yaml");
  CHECK(MapBuilderOptionsToYaml(file) == MapBuilderOptionsToYaml(defaults));
  // ... and lists every key (absent keys would keep their defaults unnoticed).
  std::ifstream in(std::string(VILMA_SOURCE_DIR) + "/config/map_builder.yaml");
  std::stringstream text;
  text << in.rdbuf();
  CHECK(vilma::testing::YamlKeyPaths(text.str()) ==
        vilma::testing::YamlKeyPaths(MapBuilderOptionsToYaml(defaults)));
}

TEST_CASE("map builder options: YAML round trip", "[mapping]") {
  MapBuilderOptions o;
  o.vertex_rate_hz = 7.5;
  o.cameras = {1, 0};
  o.features.detector.max_keypoints = 321;
  o.triangulation.max_iterations = 3;
  o.landmark_quality.min_observers = 6;
  o.landmark_quality.max_reprojection_error_px = 1.25;
  o.keep_images = true;
  o.max_track_vertices = 40;
  o.max_track_duration_s = 2.5;
  o.track_refinement.method = "affine";
  o.track_refinement.max_offset_px = 0.75;
  o.track_refinement.max_error_grey = 5.5;
  o.track_refinement.on_failure = "reanchor";
  const MapBuilderOptions back = ParseMapBuilderOptions(MapBuilderOptionsToYaml(o), "t.yaml");
  CHECK(back.vertex_rate_hz == 7.5);
  CHECK(back.cameras == std::vector<int>{1, 0});
  CHECK(back.features.detector.max_keypoints == 321);
  CHECK(back.triangulation.max_iterations == 3);
  CHECK(back.landmark_quality.min_observers == 6);
  CHECK(back.landmark_quality.max_reprojection_error_px == 1.25);
  CHECK(back.keep_images);
  CHECK(back.max_track_vertices == 40);
  CHECK(back.max_track_duration_s == 2.5);
  CHECK(back.track_refinement.method == "affine");
  CHECK(back.track_refinement.max_offset_px == 0.75);
  CHECK(back.track_refinement.max_error_grey == 5.5);
  CHECK(back.track_refinement.on_failure == "reanchor");
  CHECK(MapBuilderOptionsToYaml(back) == MapBuilderOptionsToYaml(o));
}

TEST_CASE("map builder options: strict reading names file and key", "[mapping]") {
  const std::string good = MapBuilderOptionsToYaml(MapBuilderOptions());
  // Unknown key.
  CHECK_THROWS_WITH(ParseMapBuilderOptions(good + "extra: 1\n", "m.yaml"),
                    Catch::Contains("m.yaml") && Catch::Contains("extra"));
  CHECK_THROWS_WITH(
      ParseMapBuilderOptions(
          Replace(good, "  min_observers: 4\n", "  min_observers: 4\n  bogus: 2\n"), "m.yaml"),
      Catch::Contains("bogus"));
  // An absent key keeps its default (an options file of an older vilma still loads), the keys
  // that are there are read; an absent section keeps all of its defaults.
  const MapBuilderOptions defaults;
  const MapBuilderOptions partial = ParseMapBuilderOptions(
      Replace(Replace(good, "  min_distance_m: 0.05\n", ""), "min_observers: 4", "min_observers: 6"),
      "m.yaml");
  CHECK(partial.landmark_quality.min_distance_m == defaults.landmark_quality.min_distance_m);
  CHECK(partial.landmark_quality.min_observers == 6);
  const MapBuilderOptions only_rate = ParseMapBuilderOptions("vertex_rate_hz: 4\n", "m.yaml");
  CHECK(only_rate.vertex_rate_hz == 4);
  CHECK(MapBuilderOptionsToYaml(only_rate) ==
        Replace(good, "vertex_rate_hz: 10", "vertex_rate_hz: 4"));
  // Validate failures name the field path.
  CHECK_THROWS_WITH(
      ParseMapBuilderOptions(Replace(good, "vertex_rate_hz: 10", "vertex_rate_hz: -1"), "m.yaml"),
      Catch::Contains("vertex_rate_hz"));
  CHECK_THROWS_WITH(ParseMapBuilderOptions(
                        Replace(good, "  max_distance_m: 40", "  max_distance_m: 0.01"), "m.yaml"),
                    Catch::Contains("landmark_quality.max_distance_m"));
  // Track length limits: 0 or at least min_observers; a duration >= 0.
  CHECK_THROWS_WITH(ParseMapBuilderOptions(Replace(good, "max_track_vertices: 100",
                                                   "max_track_vertices: 3"),
                                           "m.yaml"),
                    Catch::Contains("m.yaml") && Catch::Contains("max_track_vertices") &&
                        Catch::Contains("min_observers (4)"));
  CHECK(ParseMapBuilderOptions(Replace(good, "max_track_vertices: 100", "max_track_vertices: 0"),
                               "m.yaml")
            .max_track_vertices == 0);
  CHECK_THROWS_WITH(ParseMapBuilderOptions(Replace(good, "max_track_duration_s: 0",
                                                   "max_track_duration_s: -1"),
                                           "m.yaml"),
                    Catch::Contains("max_track_duration_s"));
  CHECK(ParseMapBuilderOptions(Replace(good, "max_track_vertices: 100\n", ""), "m.yaml")
            .max_track_vertices == defaults.max_track_vertices);
  CHECK_THROWS_WITH(ParseMapBuilderOptions(Replace(good, "method: \"affine\"", "method: \"klt\""),
                                           "m.yaml"),
                    Catch::Contains("track_refinement.method"));
  CHECK_THROWS_WITH(ParseMapBuilderOptions(Replace(good, "on_failure: \"keep\"",
                                                   "on_failure: \"drop\""),
                                           "m.yaml"),
                    Catch::Contains("track_refinement.on_failure"));
  CHECK(ParseMapBuilderOptions(Replace(good, "  on_failure: \"keep\"\n", ""), "m.yaml")
            .track_refinement.on_failure == defaults.track_refinement.on_failure);
  CHECK_THROWS_AS(ParseMapBuilderOptions(Replace(good, "cameras: []", "cameras: [0, 0]"), "m"),
                  InputError);
  CHECK_THROWS_AS(ParseMapBuilderOptions(Replace(good, "cameras: []", "cameras: 3"), "m"),
                  InputError);
  CHECK_THROWS_WITH(
      ParseMapBuilderOptions(Replace(good, "    max_keypoints: 600", "    max_keypoints: 0"), "m"),
      Catch::Contains("features.detector.max_keypoints"));
}
