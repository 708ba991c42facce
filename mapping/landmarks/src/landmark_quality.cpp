#include "vilma/mapping/landmarks/landmark_quality.h"

#include <chrono>
#include <cmath>
#include <sstream>
#include <stdexcept>

namespace vilma::mapping {

using mapstore::LandmarkId;
using mapstore::LandmarkQuality;
using mapstore::MissionId;
using mapstore::VIMap;

std::vector<TriangulationObservation> ObservationsInG(const VIMap& map, const LandmarkId& id) {
  std::vector<TriangulationObservation> rays;
  const mapstore::Landmark& landmark = map.landmark(id);
  rays.reserve(landmark.observations.size());
  for (const mapstore::LandmarkObservation& o : landmark.observations) {
    const mapstore::Vertex& v = map.vertex(o.vertex_id);
    const mapstore::Mission& mission = map.mission(v.mission_id);
    if (o.camera >= mission.rig.cameras.size()) {
      throw std::invalid_argument("landmark " + id.Hex() + ": observation by camera " +
                                  std::to_string(o.camera) + " of a rig with " +
                                  std::to_string(mission.rig.cameras.size()) + " cameras");
    }
    const CameraConfig& camera = mission.rig.cameras[o.camera];
    TriangulationObservation ray;
    ray.T_M_C = mission.T_G_M * v.T_M_I * camera.T_I_C;  // T_G_C
    ray.camera = &camera.camera;
    ray.uv = v.frames.at(o.camera).keypoints.at(o.keypoint).uv;
    ray.sigma_px = v.frames.at(o.camera).keypoints.at(o.keypoint).sigma_px;
    rays.push_back(ray);
  }
  return rays;
}

TriangulationResult JudgePosition(const std::vector<TriangulationObservation>& observations,
                                  const Eigen::Vector3d& p_G) {
  TriangulationResult result;
  result.p_M = p_G;
  if (observations.empty()) {
    result.status = TriangulationStatus::kTooFewObservations;
    return result;
  }
  double sum_sq = 0.0;
  for (const TriangulationObservation& o : observations) {
    const Eigen::Vector3d p_C = o.T_M_C.inverse() * p_G;
    Eigen::Vector2d uv;
    const Camera::ProjectionResult r = o.camera->Project(p_C, &uv);
    // Outside the image is fine (a keypoint near the border, a slightly wrong position): the
    // reprojection rule judges it. Behind the camera or not finite is not a position.
    if (r == Camera::ProjectionResult::kBehindCamera ||
        r == Camera::ProjectionResult::kNotFinite || !uv.allFinite()) {
      result.status = TriangulationStatus::kBehindCamera;
      return result;
    }
    sum_sq += (uv - o.uv).squaredNorm();
  }
  result.status = TriangulationStatus::kOk;
  result.rms_reprojection_error_px = std::sqrt(sum_sq / static_cast<double>(observations.size()));
  return result;
}

std::string LandmarkQualitySummary::BriefReport() const {
  std::ostringstream out;
  out << command << ": " << landmarks << " landmarks; good " << good_before << " -> " << good_after
      << ", bad " << bad_before << " -> " << bad_after << ", unknown " << unknown_before << " -> "
      << unknown_after << "; " << seconds << " s";
  return out.str();
}

std::string LandmarkQualitySummary::FullReport() const {
  std::ostringstream out;
  out << BriefReport() << "\n  verdicts:";
  for (int v = 0; v < kNumLandmarkVerdicts; ++v) {
    out << " " << LandmarkVerdictName(static_cast<LandmarkVerdict>(v)) << " " << verdicts[v]
        << (v + 1 < kNumLandmarkVerdicts ? "," : "\n");
  }
  return out.str();
}

std::vector<LandmarkId> LandmarksOf(const VIMap& map, const std::vector<MissionId>& missions) {
  std::vector<LandmarkId> ids;
  for (const MissionId& m : missions.empty() ? map.mission_ids() : missions) {
    const auto& mission_ids = map.landmark_ids(m);
    ids.insert(ids.end(), mission_ids.begin(), mission_ids.end());
  }
  return ids;
}

namespace {

void Count(LandmarkQuality q, std::size_t* good, std::size_t* bad, std::size_t* unknown) {
  ++(q == LandmarkQuality::kGood ? *good : q == LandmarkQuality::kBad ? *bad : *unknown);
}

}  // namespace

LandmarkQualitySummary EvaluateLandmarkQualities(const LandmarkQualityOptions& options,
                                                 VIMap* map,
                                                 const std::vector<MissionId>& missions,
                                                 ProgressObserver* progress) {
  const auto start = std::chrono::steady_clock::now();
  const std::string problem = options.Validate();
  if (!problem.empty()) throw std::invalid_argument("landmark quality options: " + problem);
  const std::vector<LandmarkId> ids = LandmarksOf(*map, missions);
  LandmarkQualitySummary s;
  s.command = "elq";
  // Verdicts first, written after the last safe point: a cancel leaves every quality as it was.
  std::vector<LandmarkVerdict> verdicts(ids.size());
  BeginProgress(progress, "elq", ids.size());
  for (std::size_t i = 0; i < ids.size(); ++i) {
    const std::vector<TriangulationObservation> rays = ObservationsInG(*map, ids[i]);
    const TriangulationResult judged = JudgePosition(rays, map->LandmarkPosition_G(ids[i]));
    verdicts[i] = EvaluateLandmarkQuality(rays, judged, options);
    if (i % 4096 == 4095) ReportProgress(progress, i + 1);
  }
  ReportProgress(progress, ids.size());
  ApplyVerdicts(ids, verdicts, map, &s);
  s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return s;
}

void ApplyVerdicts(const std::vector<LandmarkId>& ids, const std::vector<LandmarkVerdict>& verdicts,
                   VIMap* map, LandmarkQualitySummary* s) {
  s->landmarks += ids.size();
  for (std::size_t i = 0; i < ids.size(); ++i) {
    mapstore::Landmark& l = map->landmark(ids[i]);
    Count(l.quality, &s->good_before, &s->bad_before, &s->unknown_before);
    l.quality = verdicts[i] == LandmarkVerdict::kGood ? LandmarkQuality::kGood
                                                      : LandmarkQuality::kBad;
    Count(l.quality, &s->good_after, &s->bad_after, &s->unknown_after);
    ++s->verdicts[static_cast<int>(verdicts[i])];
  }
}

std::size_t ResetLandmarkQuality(VIMap* map, const std::vector<MissionId>& missions) {
  const std::vector<LandmarkId> ids = LandmarksOf(*map, missions);
  for (const LandmarkId& id : ids) map->landmark(id).quality = LandmarkQuality::kUnknown;
  return ids.size();
}

std::size_t RemoveBadLandmarks(VIMap* map, const std::vector<MissionId>& missions) {
  VIMap::IdSet bad;
  for (const LandmarkId& id : LandmarksOf(*map, missions)) {
    if (map->landmark(id).quality == LandmarkQuality::kBad) bad.insert(id);
  }
  map->RemoveLandmarks(bad);
  return bad.size();
}

}  // namespace vilma::mapping
