#include "vilma/mapping/landmarks/retriangulation.h"

#include <algorithm>
#include <chrono>
#include <map>
#include <sstream>
#include <stdexcept>
#include <unordered_map>

namespace vilma::mapping {

using mapstore::LandmarkId;
using mapstore::LandmarkObservation;
using mapstore::LandmarkQuality;
using mapstore::MissionId;
using mapstore::VertexId;
using mapstore::VIMap;

namespace {

double SecondsSince(std::chrono::steady_clock::time_point start) {
  return std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
}

// Stores p_G and its covariance in the landmark's store vertex frame.
void StorePosition(VIMap* map, const LandmarkId& id, const Eigen::Vector3d& p_G,
                   const Eigen::Matrix3d& covariance_G) {
  mapstore::Landmark& l = map->landmark(id);
  const Transformation T_G_I = map->T_G_I(l.store_vertex_id);
  l.p_I = T_G_I.inverse() * p_G;
  const Eigen::Matrix3d R_I_G = T_G_I.rotation().toRotationMatrix().transpose();
  l.covariance = R_I_G * covariance_G * R_I_G.transpose();
}

}  // namespace

std::string RetriangulationOptions::Validate() const {
  std::string problem = triangulation.Validate();
  if (!problem.empty()) return "triangulation." + problem;
  problem = quality.Validate();
  return problem.empty() ? "" : "quality." + problem;
}

std::string TrackLandmarkOptions::Validate() const {
  if (min_track_length < 2) return "min_track_length: expected >= 2 (two rays make a point)";
  RetriangulationOptions r;
  r.triangulation = triangulation;
  r.quality = quality;
  return r.Validate();
}

std::string RetriangulationSummary::BriefReport() const {
  std::ostringstream out;
  out << "rtl: " << landmarks << " landmarks, " << triangulated << " triangulated, " << failed
      << " failed (kept, marked bad); shift in G median " << median_shift_m << " m, max "
      << max_shift_m << " m; " << seconds << " s";
  return out.str();
}

std::string RetriangulationSummary::FullReport() const {
  return BriefReport() + "\n" + (quality.landmarks > 0 ? quality.FullReport() : std::string());
}

std::string TrackLandmarkSummary::BriefReport() const {
  std::ostringstream out;
  out << "itl: " << tracks_free << " tracks without a landmark: " << landmarks_created
      << " landmarks created (" << landmarks_created_good << " good, " << observations_created
      << " observations), " << too_short << " too short, " << triangulation_failed
      << " not triangulated; " << observations_attached
      << " keypoints added to their track's landmark; " << seconds << " s";
  return out.str();
}

std::string TrackLandmarkSummary::FullReport() const { return BriefReport() + "\n"; }

RetriangulationSummary RetriangulateLandmarks(const RetriangulationOptions& options, VIMap* map,
                                              const std::vector<MissionId>& missions,
                                              ProgressObserver* progress) {
  const auto start = std::chrono::steady_clock::now();
  const std::string problem = options.Validate();
  if (!problem.empty()) throw std::invalid_argument("rtl options: " + problem);
  const std::vector<LandmarkId> ids = LandmarksOf(*map, missions);
  std::vector<TriangulationResult> results(ids.size());
  std::vector<LandmarkVerdict> verdicts(ids.size());
  BeginProgress(progress, "rtl", ids.size());
  for (std::size_t i = 0; i < ids.size(); ++i) {
    const std::vector<TriangulationObservation> rays = ObservationsInG(*map, ids[i]);
    results[i] = Triangulate(rays, options.triangulation);
    // A landmark that cannot be triangulated is bad whatever its old position looks like.
    verdicts[i] = EvaluateLandmarkQuality(rays, results[i], options.quality);
    if (i % 1024 == 1023) ReportProgress(progress, i + 1);
  }
  ReportProgress(progress, ids.size());

  // No safe point below: the map changes in one go.
  RetriangulationSummary s;
  s.landmarks = ids.size();
  std::vector<double> shifts;
  for (std::size_t i = 0; i < ids.size(); ++i) {
    if (!results[i].ok()) {
      ++s.failed;
      continue;
    }
    shifts.push_back((results[i].p_M - map->LandmarkPosition_G(ids[i])).norm());
    StorePosition(map, ids[i], results[i].p_M, results[i].covariance_M);
    ++s.triangulated;
  }
  if (!shifts.empty()) {
    std::sort(shifts.begin(), shifts.end());
    s.median_shift_m = shifts[shifts.size() / 2];
    s.max_shift_m = shifts.back();
  }
  s.quality.command = "rtl";
  if (options.evaluate_quality) {
    ApplyVerdicts(ids, verdicts, map, &s.quality);
  } else {
    for (std::size_t i = 0; i < ids.size(); ++i) {
      if (!results[i].ok()) map->landmark(ids[i]).quality = LandmarkQuality::kBad;
    }
  }
  s.seconds = SecondsSince(start);
  s.quality.seconds = s.seconds;
  return s;
}

namespace {

// An id generator for new landmarks of `mission`: seeded by the mission id and its landmark
// count (FNV-1a over their bytes), so the same map gives the same ids.
mapstore::IdGenerator NewLandmarkIds(const VIMap& map, const MissionId& mission) {
  uint64_t h = 1469598103934665603ULL;
  auto mix = [&h](uint64_t word) {
    for (int b = 0; b < 8; ++b) {
      h ^= (word >> (8 * b)) & 0xffu;
      h *= 1099511628211ULL;
    }
  };
  mix(mission.hi);
  mix(mission.lo);
  mix(map.landmark_ids(mission).size());
  mix(0x69746c);  // "itl"
  return mapstore::IdGenerator(h);
}

struct TrackKeypoints {
  std::vector<LandmarkObservation> free;  // no landmark, in chain order
  std::map<LandmarkId, int> landmarks;    // landmark -> keypoints of the track that see it
};

}  // namespace

TrackLandmarkSummary InitializeTrackLandmarks(const TrackLandmarkOptions& options, VIMap* map,
                                              const std::vector<MissionId>& missions,
                                              ProgressObserver* progress) {
  const auto start = std::chrono::steady_clock::now();
  const std::string problem = options.Validate();
  if (!problem.empty()) throw std::invalid_argument("itl options: " + problem);
  TrackLandmarkSummary s;

  // Everything is decided first (safe points in between), then the map changes in one go.
  struct NewLandmark {
    MissionId mission;
    std::vector<LandmarkObservation> observations;
    TriangulationResult result;
    LandmarkVerdict verdict;
  };
  std::vector<NewLandmark> created;
  std::vector<std::pair<LandmarkId, LandmarkObservation>> attached;
  const std::vector<MissionId> selected = missions.empty() ? map->mission_ids() : missions;
  std::size_t total = 0;
  for (const MissionId& m : selected) total += map->vertex_ids(m).size();
  BeginProgress(progress, "itl", total);
  std::size_t done = 0;
  for (const MissionId& m : selected) {
    // std::map: tracks in id order, keypoints in chain order (deterministic).
    std::map<int64_t, TrackKeypoints> tracks;
    for (const VertexId& vid : map->VertexChain(m)) {
      const mapstore::Vertex& v = map->vertex(vid);
      for (std::size_t c = 0; c < v.frames.size(); ++c) {
        const mapstore::VisualFrame& f = v.frames[c];
        for (std::size_t k = 0; k < f.track_ids.size() && k < f.landmark_ids.size(); ++k) {
          if (f.track_ids[k] < 0) continue;
          TrackKeypoints& t = tracks[f.track_ids[k]];
          if (f.landmark_ids[k].IsValid()) {
            ++t.landmarks[f.landmark_ids[k]];
          } else {
            t.free.push_back({vid, static_cast<uint32_t>(c), static_cast<uint32_t>(k)});
          }
        }
      }
      ReportProgress(progress, ++done);
    }
    for (auto& [track_id, t] : tracks) {
      (void)track_id;
      if (t.free.empty()) continue;
      if (!t.landmarks.empty()) {
        // The landmark most keypoints of the track see (ties: the smaller id).
        LandmarkId best = t.landmarks.begin()->first;
        for (const auto& [id, n] : t.landmarks) {
          if (n > t.landmarks.at(best)) best = id;
        }
        for (const LandmarkObservation& o : t.free) attached.emplace_back(best, o);
        continue;
      }
      ++s.tracks_free;
      if (static_cast<int>(t.free.size()) < options.min_track_length) {
        ++s.too_short;
        continue;
      }
      std::vector<TriangulationObservation> rays;
      for (const LandmarkObservation& o : t.free) {
        const mapstore::Vertex& v = map->vertex(o.vertex_id);
        const mapstore::Mission& mission = map->mission(v.mission_id);
        const CameraConfig& camera = mission.rig.cameras.at(o.camera);
        const mapstore::Keypoint& keypoint = v.frames[o.camera].keypoints.at(o.keypoint);
        rays.push_back({mission.T_G_M * v.T_M_I * camera.T_I_C, &camera.camera, keypoint.uv,
                        keypoint.sigma_px});
      }
      NewLandmark n;
      n.mission = m;
      n.result = Triangulate(rays, options.triangulation);
      if (!n.result.ok()) {
        ++s.triangulation_failed;
        continue;
      }
      n.verdict = EvaluateLandmarkQuality(rays, n.result, options.quality);
      n.observations = std::move(t.free);
      created.push_back(std::move(n));
    }
  }

  for (const auto& [landmark_id, o] : attached) {
    // One keypoint per frame and landmark: skip a frame that already sees it.
    bool seen = false;
    for (const LandmarkObservation& e : map->landmark(landmark_id).observations) {
      seen = seen || (e.vertex_id == o.vertex_id && e.camera == o.camera);
    }
    if (seen) continue;
    map->AddObservation(landmark_id, o);
    ++s.observations_attached;
  }
  std::unordered_map<MissionId, mapstore::IdGenerator, mapstore::IdHash> generators;
  for (NewLandmark& n : created) {
    auto it = generators.find(n.mission);
    if (it == generators.end()) it = generators.emplace(n.mission, NewLandmarkIds(*map, n.mission)).first;
    mapstore::Landmark l;
    do {
      l.id = it->second.Next();
    } while (map->HasLandmark(l.id) || map->HasVertex(l.id) || map->HasEdge(l.id) ||
             map->HasMission(l.id));
    l.store_vertex_id = n.observations.front().vertex_id;
    l.quality = n.verdict == LandmarkVerdict::kGood ? LandmarkQuality::kGood : LandmarkQuality::kBad;
    const LandmarkId id = l.id;
    map->AddLandmark(std::move(l));
    StorePosition(map, id, n.result.p_M, n.result.covariance_M);
    for (const LandmarkObservation& o : n.observations) map->AddObservation(id, o);
    ++s.landmarks_created;
    s.landmarks_created_good += n.verdict == LandmarkVerdict::kGood;
    s.observations_created += n.observations.size();
  }
  s.seconds = SecondsSince(start);
  return s;
}

}  // namespace vilma::mapping
