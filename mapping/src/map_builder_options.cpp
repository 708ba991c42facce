#include "vilma/mapping/map_builder_options.h"

#include <charconv>
#include <cmath>
#include <sstream>

#include "vilma/core/error.h"

namespace vilma::mapping {
namespace {

std::string Check(bool ok, const std::string& field, const std::string& expectation) {
  return ok ? std::string() : field + ": expected " + expectation;
}
bool Finite(double v) { return std::isfinite(v); }

std::string Num(double v) {
  // Shortest text that reads back to the same double.
  char buffer[64];
  const auto r = std::to_chars(buffer, buffer + sizeof(buffer), v);
  return std::string(buffer, r.ptr);
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
  if (!(e = triangulation.Validate()).empty()) return "triangulation." + e;
  if (!(e = landmark_quality.Validate()).empty()) return "landmark_quality." + e;
  if (compact != "none" && compact != "tracks" && compact != "good") {
    return "compact: expected \"none\", \"tracks\" or \"good\", got \"" + compact + "\"";
  }
  return "";
}

MapBuilderOptions ReadMapBuilderOptions(const YamlNode& root) {
  if (!root.IsMap()) root.Fail("", "a map of map builder options");
  MapBuilderOptions o;
  o.vertex_rate_hz = root.Get<double>("vertex_rate_hz");
  const YamlNode cameras = root.Child("cameras");
  if (!cameras.IsSequence()) root.Fail("cameras", "a list of camera indices ([] for all)");
  for (const YamlNode& c : cameras.Elements()) {
    try {
      o.cameras.push_back(c.raw().as<int>());
    } catch (const std::exception&) {
      root.Fail("cameras", "a list of integer camera indices");
    }
  }
  o.features = localizer::ReadKeyframeFeatureOptions(root.Child("features"));
  const YamlNode t = root.MapChild("triangulation");
  o.triangulation.max_iterations = t.Get<int>("max_iterations");
  o.triangulation.convergence_step_m = t.Get<double>("convergence_step_m");
  o.triangulation.keypoint_sigma_px = t.Get<double>("keypoint_sigma_px");
  t.CheckNoUnknownKeys();
  const YamlNode q = root.MapChild("landmark_quality");
  o.landmark_quality.min_observers = q.Get<int>("min_observers");
  o.landmark_quality.min_observation_angle_deg = q.Get<double>("min_observation_angle_deg");
  o.landmark_quality.min_distance_m = q.Get<double>("min_distance_m");
  o.landmark_quality.max_distance_m = q.Get<double>("max_distance_m");
  o.landmark_quality.max_reprojection_error_px = q.Get<double>("max_reprojection_error_px");
  q.CheckNoUnknownKeys();
  o.compact = root.Get<std::string>("compact");
  o.keep_images = root.Get<bool>("keep_images");
  root.CheckNoUnknownKeys();
  root.CheckValid(o.Validate());
  return o;
}

MapBuilderOptions ParseMapBuilderOptions(const std::string& yaml_text,
                                         const std::string& source_name) {
  return ReadMapBuilderOptions(YamlNode::LoadString(yaml_text, source_name));
}

MapBuilderOptions LoadMapBuilderOptions(const std::string& path) {
  return ReadMapBuilderOptions(YamlNode::LoadFile(path));
}

std::string MapBuilderOptionsToYaml(const MapBuilderOptions& o) {
  std::ostringstream out;
  out << "vertex_rate_hz: " << Num(o.vertex_rate_hz) << "\n";
  out << "cameras: [";
  for (std::size_t i = 0; i < o.cameras.size(); ++i) out << (i ? ", " : "") << o.cameras[i];
  out << "]\n";
  out << "features:\n";
  std::istringstream features(localizer::KeyframeFeatureOptionsToYaml(o.features));
  for (std::string line; std::getline(features, line);) out << "  " << line << "\n";
  out << "triangulation:\n"
      << "  max_iterations: " << o.triangulation.max_iterations << "\n"
      << "  convergence_step_m: " << Num(o.triangulation.convergence_step_m) << "\n"
      << "  keypoint_sigma_px: " << Num(o.triangulation.keypoint_sigma_px) << "\n";
  out << "landmark_quality:\n"
      << "  min_observers: " << o.landmark_quality.min_observers << "\n"
      << "  min_observation_angle_deg: " << Num(o.landmark_quality.min_observation_angle_deg)
      << "\n"
      << "  min_distance_m: " << Num(o.landmark_quality.min_distance_m) << "\n"
      << "  max_distance_m: " << Num(o.landmark_quality.max_distance_m) << "\n"
      << "  max_reprojection_error_px: " << Num(o.landmark_quality.max_reprojection_error_px)
      << "\n";
  out << "compact: \"" << o.compact << "\"\n";
  out << "keep_images: " << (o.keep_images ? "true" : "false") << "\n";
  return out.str();
}

}  // namespace vilma::mapping
