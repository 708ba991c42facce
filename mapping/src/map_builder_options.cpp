#include "vilma/mapping/map_builder_options.h"

#include <cmath>
#include <sstream>

#include "vilma/core/error.h"
#include "vilma/core/options_fields.h"

namespace vilma::mapping {
namespace {

std::string Check(bool ok, const std::string& field, const std::string& expectation) {
  return ok ? std::string() : field + ": expected " + expectation;
}
bool Finite(double v) { return std::isfinite(v); }

// One list of the fields (core/options_fields.h) but `features`, which has its own reader.
template <typename Options, typename Visitor>
void VisitMapBuilderFields(Options& o, Visitor&& v) {
  v("", "vertex_rate_hz", o.vertex_rate_hz);
  v("", "cameras", o.cameras);
  v("", "compact", o.compact);
  v("", "keep_images", o.keep_images);
  v("", "max_track_vertices", o.max_track_vertices);
  v("", "max_track_duration_s", o.max_track_duration_s);
  v("track_refinement", "method", o.track_refinement.method);
  v("track_refinement", "patch_half_size_px", o.track_refinement.patch_half_size_px);
  v("track_refinement", "max_iterations", o.track_refinement.max_iterations);
  v("track_refinement", "convergence_px", o.track_refinement.convergence_px);
  v("track_refinement", "max_shift_px", o.track_refinement.max_shift_px);
  v("track_refinement", "max_offset_px", o.track_refinement.max_offset_px);
  v("track_refinement", "max_error_grey", o.track_refinement.max_error_grey);
  v("track_refinement", "max_warp_scale", o.track_refinement.max_warp_scale);
  v("track_refinement", "keypoint_sigma_px", o.track_refinement.keypoint_sigma_px);
  v("track_refinement", "on_failure", o.track_refinement.on_failure);
  v("triangulation", "max_iterations", o.triangulation.max_iterations);
  v("triangulation", "convergence_step_m", o.triangulation.convergence_step_m);
  v("triangulation", "keypoint_sigma_px", o.triangulation.keypoint_sigma_px);
  v("landmark_quality", "min_observers", o.landmark_quality.min_observers);
  v("landmark_quality", "min_observation_angle_deg", o.landmark_quality.min_observation_angle_deg);
  v("landmark_quality", "min_distance_m", o.landmark_quality.min_distance_m);
  v("landmark_quality", "max_distance_m", o.landmark_quality.max_distance_m);
  v("landmark_quality", "max_reprojection_error_px", o.landmark_quality.max_reprojection_error_px);
}

}  // namespace

std::string TriangulationOptions::Validate() const {
  std::string e;
  if (!(e = Check(max_iterations >= 0, "max_iterations", ">= 0")).empty()) return e;
  if (!(e = Check(Finite(convergence_step_m) && convergence_step_m > 0, "convergence_step_m",
                  "> 0"))
           .empty())
    return e;
  return Check(Finite(keypoint_sigma_px) && keypoint_sigma_px > 0, "keypoint_sigma_px", "> 0");
}

std::string LandmarkQualityOptions::Validate() const {
  std::string e;
  if (!(e = Check(min_observers >= 2, "min_observers", ">= 2")).empty()) return e;
  if (!(e = Check(Finite(min_observation_angle_deg) && min_observation_angle_deg >= 0 &&
                      min_observation_angle_deg < 180,
                  "min_observation_angle_deg", "in [0, 180)"))
           .empty())
    return e;
  if (!(e = Check(Finite(min_distance_m) && min_distance_m >= 0, "min_distance_m", ">= 0")).empty())
    return e;
  if (!(e = Check(Finite(max_distance_m) && max_distance_m > min_distance_m, "max_distance_m",
                  "> min_distance_m"))
           .empty())
    return e;
  return Check(Finite(max_reprojection_error_px) && max_reprojection_error_px > 0,
               "max_reprojection_error_px", "> 0");
}

std::string MapBuilderOptions::Validate() const {
  std::string e;
  if (!(e = Check(Finite(vertex_rate_hz) && vertex_rate_hz >= 0, "vertex_rate_hz",
                  ">= 0 (0: a vertex per frame)"))
           .empty())
    return e;
  for (std::size_t i = 0; i < cameras.size(); ++i) {
    if (cameras[i] < 0) return "cameras: expected camera indices >= 0";
    for (std::size_t j = 0; j < i; ++j) {
      if (cameras[j] == cameras[i]) return "cameras: expected distinct camera indices";
    }
  }
  if (!(e = features.Validate()).empty()) return "features." + e;
  if (!(e = track_refinement.Validate()).empty()) return "track_refinement." + e;
  if (!(e = triangulation.Validate()).empty()) return "triangulation." + e;
  if (!(e = landmark_quality.Validate()).empty()) return "landmark_quality." + e;
  if (compact != "none" && compact != "tracks" && compact != "good") {
    return "compact: expected \"none\", \"tracks\" or \"good\", got \"" + compact + "\"";
  }
  if (!(e = Check(max_track_vertices == 0 ||
                      max_track_vertices >= landmark_quality.min_observers,
                  "max_track_vertices",
                  "0 (no limit) or >= landmark_quality.min_observers (" +
                      std::to_string(landmark_quality.min_observers) + ")"))
           .empty())
    return e;
  return Check(Finite(max_track_duration_s) && max_track_duration_s >= 0, "max_track_duration_s",
               ">= 0 [s] (0: no limit)");
}

bool MapBuilderOptions::TrackSegmentFull(std::size_t observations, int64_t t_first_ns,
                                         int64_t t_last_ns) const {
  if (max_track_vertices > 0 && observations >= static_cast<std::size_t>(max_track_vertices)) {
    return true;
  }
  return max_track_duration_s > 0.0 &&
         static_cast<double>(t_last_ns - t_first_ns) >= max_track_duration_s * 1e9;
}

MapBuilderOptions ReadMapBuilderOptions(const YamlNode& root, const MapBuilderOptions& base) {
  if (!root.IsMap()) root.Fail("", "a map of map builder options");
  MapBuilderOptions o = base;
  // The features section has its own reader (and writer); the other fields are the list. An
  // absent key or section keeps its default (docs/design.md "Options files").
  if (root.Has("features")) {
    o.features = localizer::ReadKeyframeFeatureOptions(root.Child("features"), base.features);
  }
  ReadOptionFields(root, MissingKey::kKeepDefault, &o,
                   [](auto& options, auto&& v) { VisitMapBuilderFields(options, v); });
  root.CheckValid(o.Validate());
  return o;
}

MapBuilderOptions ParseMapBuilderOptions(const std::string& yaml_text,
                                         const std::string& source_name) {
  return ReadMapBuilderOptions(YamlNode::LoadString(yaml_text, source_name));
}

MapBuilderOptions LoadMapBuilderOptions(const std::string& path, const MapBuilderOptions& base) {
  return ReadMapBuilderOptions(YamlNode::LoadFile(path), base);
}

std::string MapBuilderOptionsToYaml(const MapBuilderOptions& o) {
  std::ostringstream out;
  out << OptionFieldsToYaml(o, [](auto& options, auto&& v) { VisitMapBuilderFields(options, v); });
  out << "features:\n";
  std::istringstream features(localizer::KeyframeFeatureOptionsToYaml(o.features));
  for (std::string line; std::getline(features, line);) out << "  " << line << "\n";
  return out.str();
}

}  // namespace vilma::mapping
