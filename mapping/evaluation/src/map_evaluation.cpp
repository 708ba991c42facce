#include "vilma/mapping/evaluation/map_evaluation.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <map>
#include <sstream>
#include <stdexcept>

#include "vilma/core/error.h"
#include "vilma/core/json.h"
#include "vilma/core/yaml_io.h"
#include "vilma/mapping/landmarks/landmark_quality.h"

namespace vilma::mapping {

using mapstore::LandmarkId;
using mapstore::VertexId;
using mapstore::VIMap;

std::string MapEvaluationOptions::Validate() const {
  if (alignment == AlignmentType::kFirst || alignment == AlignmentType::kFixed) {
    return "alignment: expected posyaw, se3, sim3 or none";
  }
  const std::string problem = association.Validate();
  return problem.empty() ? "" : "association." + problem;
}

namespace {

// The ground-truth state nearest in time to t_ns (the states are time ordered).
const GroundTruthState& Nearest(const std::vector<GroundTruthState>& gt, int64_t t_ns) {
  auto it = std::lower_bound(gt.begin(), gt.end(), t_ns,
                             [](const GroundTruthState& s, int64_t t) { return s.t_ns < t; });
  if (it == gt.end()) return gt.back();
  if (it != gt.begin() && (t_ns - std::prev(it)->t_ns) < (it->t_ns - t_ns)) return *std::prev(it);
  return *it;
}

std::string Stats(const ErrorStats& s, double scale, int precision) {
  std::ostringstream out;
  out << std::fixed << std::setprecision(precision) << "median " << s.median * scale << ", rmse "
      << s.rmse * scale << ", max " << s.max * scale;
  return out.str();
}

std::string JsonStats(const ErrorStats& s) {
  std::ostringstream out;
  out << std::setprecision(10) << "{\"count\": " << s.count << ", \"rmse\": " << s.rmse
      << ", \"median\": " << s.median << ", \"mean\": " << s.mean << ", \"max\": " << s.max
      << "}";
  return out.str();
}

}  // namespace

MapEvaluation EvaluateMap(const VIMap& map, const mapstore::MissionId& mission,
                          const std::vector<GroundTruthState>& ground_truth,
                          const sim::World* world, const MapEvaluationOptions& options) {
  const std::string problem = options.Validate();
  if (!problem.empty()) throw std::invalid_argument("map evaluation options: " + problem);
  if (ground_truth.empty()) throw InputError("map evaluation: the ground truth is empty");
  MapEvaluation e;
  e.mission = mission;
  e.mission_name = map.mission(mission).name;

  Trajectory gt, est;
  for (const GroundTruthState& s : ground_truth) gt.Add(s.t_ns, Transformation(s.q_W_I, s.p_W_I));
  const std::vector<VertexId> chain = map.VertexChain(mission);
  e.vertices = chain.size();
  for (const VertexId& id : chain) est.Add(map.vertex(id).t_ns, map.T_G_I(id));
  EvalOptions eval;
  eval.alignment = options.alignment;
  eval.association = options.association;
  eval.segment_lengths_m = {1.0};
  e.trajectory = EvaluateTrajectory(gt, est, eval);

  // Velocities and biases at the matched vertices; v in G rotated into W by the alignment
  // (v_W = R_W_G R_G_M v_M; the scale of a sim3 alignment applies too).
  const Alignment& S = e.trajectory.alignment;
  const Eigen::Matrix3d R_W_G = S.T_G_E.rotation().toRotationMatrix();
  std::vector<double> dv, dbg, dba;
  for (std::size_t k = 0; k < e.trajectory.association.size(); ++k) {
    const mapstore::Vertex& v = map.vertex(chain[e.trajectory.association.est_index[k]]);
    const GroundTruthState& g = Nearest(ground_truth, v.t_ns);
    const Eigen::Matrix3d R_G_M = map.mission(mission).T_G_M.rotation().toRotationMatrix();
    dv.push_back((S.scale * R_W_G * R_G_M * v.v_M - g.v_W).norm());
    dbg.push_back((v.gyro_bias - g.b_g).norm());
    dba.push_back((v.accel_bias - g.b_a).norm());
  }
  e.velocity_error_mps = ComputeErrorStats(dv);
  e.gyro_bias_error = ComputeErrorStats(dbg);
  e.accel_bias_error = ComputeErrorStats(dba);

  // Good landmarks: reprojection error per observation, distance to the world's surfaces.
  std::vector<double> pixels, distances;
  std::map<double, std::vector<double>> pixels_by_sigma;  // sigma rounded to 1e-4 px
  for (const LandmarkId& id : map.landmark_ids(mission)) {
    if (map.landmark(id).quality != mapstore::LandmarkQuality::kGood) continue;
    ++e.good_landmarks;
    const Eigen::Vector3d p_G = map.LandmarkPosition_G(id);
    for (const TriangulationObservation& o : ObservationsInG(map, id)) {
      Eigen::Vector2d uv;
      const Camera::ProjectionResult r = o.camera->Project(o.T_M_C.inverse() * p_G, &uv);
      if (r == Camera::ProjectionResult::kValid || r == Camera::ProjectionResult::kOutsideImage) {
        pixels.push_back((uv - o.uv).norm());
        pixels_by_sigma[std::round(o.sigma_px * 1e4) / 1e4].push_back(pixels.back());
      }
    }
    if (world != nullptr) {
      const Eigen::Vector3d p_W = S.scale * (S.T_G_E.rotation() * p_G) + S.T_G_E.translation();
      distances.push_back(sim::DistanceToWorld(*world, p_W));
    }
  }
  e.reprojection_px = ComputeErrorStats(pixels);
  for (const auto& [sigma, values] : pixels_by_sigma) {
    e.reprojection_by_sigma.push_back({sigma, ComputeErrorStats(values)});
  }
  e.has_world = world != nullptr;
  e.surface_distance_m = ComputeErrorStats(distances);
  return e;
}

std::string MapEvaluation::BriefReport() const {
  const std::string full = FullReport();
  return full.substr(0, full.find('\n'));
}

std::string MapEvaluation::FullReport() const {
  std::ostringstream out;
  const ErrorStats& t = trajectory.ate.translation_m;
  out << "mission " << mission.Hex().substr(0, 8) << (mission_name.empty() ? "" : " " + mission_name)
      << ": " << vertices << " vertices, " << t.count << " matched, alignment "
      << AlignmentTypeName(trajectory.alignment.type) << "\n"
      << "  ATE translation [m]: " << Stats(t, 1.0, 4) << "\n"
      << "  ATE rotation [deg]:  " << Stats(trajectory.ate.rotation_deg, 1.0, 3) << "\n"
      << "  velocity [m/s]:      " << Stats(velocity_error_mps, 1.0, 4) << "\n"
      << "  gyro bias [rad/s]:   " << Stats(gyro_bias_error, 1.0, 5) << "\n"
      << "  accel bias [m/s^2]:  " << Stats(accel_bias_error, 1.0, 4) << "\n"
      << "  good landmarks " << good_landmarks << ", reprojection [px]: "
      << Stats(reprojection_px, 1.0, 3) << "\n";
  if (reprojection_by_sigma.size() > 1) {
    for (const SigmaClass& c : reprojection_by_sigma) {
      out << "    keypoints at sigma " << c.sigma_px << " px (" << c.reprojection_px.count
          << "): " << Stats(c.reprojection_px, 1.0, 3) << "\n";
    }
  }
  if (has_world) {
    out << "  good landmarks to the true surfaces [cm]: "
        << Stats(surface_distance_m, 100.0, 2) << "\n";
  }
  return out.str();
}

std::string MapEvaluation::ToJson() const {
  std::ostringstream out;
  out << std::setprecision(10) << "{\"mission\": " << JsonString(mission.Hex())
      << ", \"mission_name\": " << JsonString(mission_name) << ", \"vertices\": " << vertices
      << ", \"alignment\": " << JsonString(AlignmentTypeName(trajectory.alignment.type))
      << ", \"ate_translation_m\": " << JsonStats(trajectory.ate.translation_m)
      << ", \"ate_rotation_deg\": " << JsonStats(trajectory.ate.rotation_deg)
      << ", \"velocity_error_mps\": " << JsonStats(velocity_error_mps)
      << ", \"gyro_bias_error\": " << JsonStats(gyro_bias_error)
      << ", \"accel_bias_error\": " << JsonStats(accel_bias_error)
      << ", \"good_landmarks\": " << good_landmarks
      << ", \"reprojection_px\": " << JsonStats(reprojection_px)
      << ", \"reprojection_by_sigma\": [";
  for (std::size_t k = 0; k < reprojection_by_sigma.size(); ++k) {
    out << (k == 0 ? "" : ", ") << "{\"sigma_px\": " << reprojection_by_sigma[k].sigma_px
        << ", \"reprojection_px\": " << JsonStats(reprojection_by_sigma[k].reprojection_px)
        << "}";
  }
  out << "]";
  if (has_world) out << ", \"surface_distance_m\": " << JsonStats(surface_distance_m);
  out << "}";
  return out.str();
}

bool LoadDatasetWorld(const std::string& dataset_dir, sim::World* world) {
  std::filesystem::path path = std::filesystem::path(dataset_dir) / "sim.yaml";
  if (!std::filesystem::exists(path)) {
    // `dataset_dir` may be the mav0 folder itself.
    path = std::filesystem::path(dataset_dir).parent_path() / "sim.yaml";
    if (std::filesystem::path(dataset_dir).filename() != "mav0" ||
        !std::filesystem::exists(path)) {
      return false;
    }
  }
  const YamlNode sim = YamlNode::LoadFile(path.string());
  const std::string name = sim.Get<std::string>("world");
  const auto seed = static_cast<uint64_t>(sim.Get<int64_t>("seed"));
  if (sim::IsPresetName(name)) {
    *world = sim::MakePresetWorld(name, seed);
  } else {
    // A world file: as vilma-sim was given it, else beside the dataset.
    std::filesystem::path file(name);
    if (!std::filesystem::exists(file)) file = path.parent_path() / file.filename();
    *world = sim::LoadWorldYaml(file.string(), seed);
  }
  return true;
}

}  // namespace vilma::mapping
