#include "vilma/mapping/keyframing/keyframe_heuristic.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <set>
#include <sstream>
#include <stdexcept>
#include <unordered_map>
#include <unordered_set>

namespace vilma::mapping {

using mapstore::Edge;
using mapstore::EdgeId;
using mapstore::EdgeType;
using mapstore::IdHash;
using mapstore::LandmarkId;
using mapstore::MissionId;
using mapstore::VertexId;
using mapstore::VIMap;

std::string KeyframingOptions::Validate() const {
  if (!(kf_distance_threshold_m > 0.0)) return "kf_distance_threshold_m: expected > 0";
  if (!(kf_rotation_threshold_deg > 0.0)) return "kf_rotation_threshold_deg: expected > 0";
  if (kf_every_nth_vertex < 1) return "kf_every_nth_vertex: expected >= 1";
  if (kf_min_shared_landmarks_obs < 0) return "kf_min_shared_landmarks_obs: expected >= 0";
  return "";
}

std::size_t KeyframingSummary::vertices_before() const {
  std::size_t n = 0;
  for (const auto& m : missions) n += m.vertices_before;
  return n;
}

std::size_t KeyframingSummary::vertices_after() const {
  std::size_t n = 0;
  for (const auto& m : missions) n += m.vertices_after;
  return n;
}

std::string KeyframingSummary::BriefReport() const {
  std::size_t landmarks_removed = 0, samples_before = 0, samples_after = 0;
  for (const auto& m : missions) {
    landmarks_removed += m.landmarks_removed;
    samples_before += m.imu_samples_before;
    samples_after += m.imu_samples_after;
  }
  std::ostringstream out;
  out << "kfh: " << vertices_before() << " -> " << vertices_after() << " vertices in "
      << missions.size() << " missions, " << landmarks_removed << " landmarks removed, IMU samples "
      << samples_before << " -> " << samples_after << ", " << seconds << " s";
  return out.str();
}

std::string KeyframingSummary::FullReport() const {
  std::ostringstream out;
  out << BriefReport() << "\n";
  for (const auto& m : missions) {
    out << "  mission " << m.mission.Hex().substr(0, 8) << ": vertices " << m.vertices_before
        << " -> " << m.vertices_after << " (kept by distance " << m.kept_by_distance
        << ", rotation " << m.kept_by_rotation << ", every n-th " << m.kept_by_every_nth
        << ", shared landmarks " << m.kept_by_shared_landmarks << ", first/last 2)\n"
        << "    IMU edges merged " << m.imu_edges_merged << ", samples " << m.imu_samples_before
        << " -> " << m.imu_samples_after << "; landmarks moved " << m.landmarks_moved
        << ", removed " << m.landmarks_removed << "; observations removed "
        << m.observations_removed << "; edges re-attached " << m.edges_reattached
        << ", removed " << m.edges_removed << "\n";
  }
  return out.str();
}

std::size_t DistinctImuSamples(const VIMap& map, const MissionId& mission) {
  std::set<int64_t> times;
  for (const EdgeId& id : map.edge_ids(mission)) {
    const Edge& e = map.edge(id);
    if (e.type != EdgeType::kImu) continue;
    for (const ImuSample& s : e.imu_samples) times.insert(s.t_ns);
  }
  return times.size();
}

namespace {

std::unordered_set<LandmarkId, IdHash> ObservedLandmarks(const mapstore::Vertex& v) {
  std::unordered_set<LandmarkId, IdHash> ids;
  for (const mapstore::VisualFrame& f : v.frames) {
    for (const LandmarkId& id : f.landmark_ids) {
      if (id.IsValid()) ids.insert(id);
    }
  }
  return ids;
}

double AngleDeg(const Transformation& a, const Transformation& b) {
  return Eigen::AngleAxisd(a.rotation().inverse() * b.rotation()).angle() * 180.0 / M_PI;
}

}  // namespace

std::vector<std::size_t> SelectKeyframes(const KeyframingOptions& options, const VIMap& map,
                                         const std::vector<VertexId>& chain,
                                         MissionKeyframingSummary* reasons) {
  std::vector<std::size_t> kept;
  if (chain.empty()) return kept;
  kept.push_back(0);
  std::size_t last = 0;
  std::unordered_set<LandmarkId, IdHash> last_landmarks = ObservedLandmarks(map.vertex(chain[0]));
  for (std::size_t i = 1; i + 1 < chain.size(); ++i) {
    const mapstore::Vertex& v = map.vertex(chain[i]);
    const mapstore::Vertex& k = map.vertex(chain[last]);
    // The reasons in maplab's order; the first that holds is counted.
    int reason = -1;
    if ((v.T_M_I.translation() - k.T_M_I.translation()).norm() >= options.kf_distance_threshold_m) {
      reason = 0;
    } else if (AngleDeg(k.T_M_I, v.T_M_I) >= options.kf_rotation_threshold_deg) {
      reason = 1;
    } else if (static_cast<int>(i - last) >= options.kf_every_nth_vertex) {
      reason = 2;
    } else if (options.kf_min_shared_landmarks_obs > 0) {
      int shared = 0;
      for (const LandmarkId& id : ObservedLandmarks(v)) shared += last_landmarks.count(id) > 0;
      if (shared < options.kf_min_shared_landmarks_obs) reason = 3;
    }
    if (reason < 0) continue;
    if (reasons != nullptr) {
      ++(reason == 0   ? reasons->kept_by_distance
         : reason == 1 ? reasons->kept_by_rotation
         : reason == 2 ? reasons->kept_by_every_nth
                       : reasons->kept_by_shared_landmarks);
    }
    kept.push_back(i);
    last = i;
    last_landmarks = ObservedLandmarks(v);
  }
  if (chain.size() > 1) kept.push_back(chain.size() - 1);
  return kept;
}

namespace {

void KeyframeMission(const KeyframingOptions& options, const MissionId& mission, VIMap* map,
                     MissionKeyframingSummary* s, ProgressObserver* progress,
                     std::size_t* progress_done) {
  const std::vector<VertexId> chain = map->VertexChain(mission);
  s->mission = mission;
  s->vertices_before = map->vertex_ids(mission).size();
  s->imu_samples_before = DistinctImuSamples(*map, mission);
  const std::vector<std::size_t> kept = SelectKeyframes(options, *map, chain, s);
  // Which keyframe each chain vertex merges into (the last keyframe at or before it).
  std::unordered_map<VertexId, VertexId, IdHash> merged_into;
  std::unordered_set<VertexId, IdHash> removed;
  std::unordered_map<VertexId, std::size_t, IdHash> chain_index;
  {
    std::size_t k = 0;
    for (std::size_t i = 0; i < chain.size(); ++i) {
      if (k + 1 < kept.size() && kept[k + 1] == i) ++k;
      merged_into[chain[i]] = chain[kept[k]];
      chain_index[chain[i]] = i;
      if (kept[k] != i) removed.insert(chain[i]);
    }
  }
  if (removed.empty()) {
    s->vertices_after = s->vertices_before;
    s->imu_samples_after = s->imu_samples_before;
    return;
  }

  // IMU edges: one per pair of consecutive keyframes, the first edge of the run reused.
  std::unordered_map<VertexId, EdgeId, IdHash> outgoing_imu;
  for (const EdgeId& id : map->edge_ids(mission)) {
    const Edge& e = map->edge(id);
    if (e.type == EdgeType::kImu) outgoing_imu.emplace(e.from, id);
  }
  mapstore::VIMap::IdSet edges_to_remove;
  for (std::size_t k = 0; k + 1 < kept.size(); ++k) {
    const EdgeId first = outgoing_imu.at(chain[kept[k]]);
    Edge& merged = map->edge(first);
    for (std::size_t i = kept[k] + 1; i < kept[k + 1]; ++i) {
      const EdgeId next_id = outgoing_imu.at(chain[i]);
      const Edge& next = map->edge(next_id);
      for (const ImuSample& sample : next.imu_samples) {
        // The joint sample (interpolated at the removed vertex's time) ends one edge and starts
        // the next: keep it once.
        if (!merged.imu_samples.empty() && sample.t_ns <= merged.imu_samples.back().t_ns) continue;
        merged.imu_samples.push_back(sample);
      }
      merged.to = next.to;
      edges_to_remove.insert(next_id);
      ++s->imu_edges_merged;
    }
  }
  map->RemoveEdges(edges_to_remove);

  // Other edges touching removed vertices (any mission's): re-attach or remove.
  mapstore::VIMap::IdSet other_edges_to_remove;
  std::vector<EdgeId> all_edges;
  for (const MissionId& m : map->mission_ids()) {
    const auto& ids = map->edge_ids(m);
    all_edges.insert(all_edges.end(), ids.begin(), ids.end());
  }
  for (const EdgeId& id : all_edges) {
    Edge& e = map->edge(id);
    if (e.type == EdgeType::kImu) continue;
    const bool from_removed = removed.count(e.from) > 0;
    const bool to_removed = removed.count(e.to) > 0;
    if (!from_removed && !to_removed) continue;
    if (e.type == EdgeType::kPosePrior) {
      other_edges_to_remove.insert(id);
      continue;
    }
    // T_A_B measured between from and to; moving `from` to keyframe K: T_K_B = T_K_A T_A_B
    // with T_K_A from the current vertex poses (the same for `to`).
    Transformation T = e.T_A_B;
    if (from_removed) {
      const VertexId k = merged_into.at(e.from);
      T = map->vertex(k).T_M_I.inverse() * map->vertex(e.from).T_M_I * T;
      e.from = k;
    }
    if (to_removed) {
      const VertexId k = merged_into.at(e.to);
      T = T * map->vertex(e.to).T_M_I.inverse() * map->vertex(k).T_M_I;
      e.to = k;
    }
    e.T_A_B = T;
    if (e.from == e.to) {
      other_edges_to_remove.insert(id);
    } else {
      ++s->edges_reattached;
    }
  }
  s->edges_removed = other_edges_to_remove.size();
  map->RemoveEdges(other_edges_to_remove);

  // The observations made from removed vertices (counted before landmarks go).
  for (const VertexId& v : removed) {
    for (const mapstore::VisualFrame& f : map->vertex(v).frames) {
      for (const LandmarkId& id : f.landmark_ids) s->observations_removed += id.IsValid();
    }
  }

  // Landmarks stored in removed vertices: to the earliest kept observer, else removed.
  mapstore::VIMap::IdSet landmarks_to_remove;
  for (const LandmarkId& id : std::vector<LandmarkId>(map->landmark_ids(mission))) {
    const mapstore::Landmark& l = map->landmark(id);
    if (removed.count(l.store_vertex_id) == 0) continue;
    VertexId best;
    int64_t best_t = 0;
    for (const mapstore::LandmarkObservation& o : l.observations) {
      if (removed.count(o.vertex_id) > 0) continue;
      const int64_t t = map->vertex(o.vertex_id).t_ns;
      if (!best.IsValid() || t < best_t) {
        best = o.vertex_id;
        best_t = t;
      }
    }
    if (best.IsValid()) {
      map->SetLandmarkStoreVertex(id, best);
      ++s->landmarks_moved;
    } else {
      landmarks_to_remove.insert(id);
    }
  }
  map->RemoveLandmarks(landmarks_to_remove);

  // The removed vertices (with their observations), then landmarks left unobserved.
  std::unordered_set<LandmarkId, IdHash> touched;
  for (const VertexId& v : removed) {
    for (const LandmarkId& id : ObservedLandmarks(map->vertex(v))) touched.insert(id);
  }
  map->RemoveVertices(removed);
  mapstore::VIMap::IdSet orphans;
  for (const LandmarkId& id : touched) {
    if (map->HasLandmark(id) && map->landmark(id).observations.empty()) orphans.insert(id);
  }
  map->RemoveLandmarks(orphans);
  s->landmarks_removed = landmarks_to_remove.size() + orphans.size();
  s->vertices_after = map->vertex_ids(mission).size();
  s->imu_samples_after = DistinctImuSamples(*map, mission);
  *progress_done += chain.size();
  ReportProgress(progress, *progress_done);
}

}  // namespace

KeyframingSummary KeyframeHeuristic(const KeyframingOptions& options, VIMap* map,
                                    const std::vector<MissionId>& missions,
                                    ProgressObserver* progress) {
  const auto start = std::chrono::steady_clock::now();
  const std::string problem = options.Validate();
  if (!problem.empty()) throw std::invalid_argument("keyframing options: " + problem);
  const std::vector<MissionId> selected = missions.empty() ? map->mission_ids() : missions;
  // Check every mission first: a refused call changes nothing.
  std::size_t total = 0;
  for (const MissionId& m : selected) {
    const std::size_t chain = map->VertexChain(m).size();
    if (chain != map->vertex_ids(m).size()) {
      throw std::invalid_argument("mission " + m.Hex() + ": its " +
                                  std::to_string(map->vertex_ids(m).size()) +
                                  " vertices are not one chain of IMU edges (the chain has " +
                                  std::to_string(chain) + "); check_map_consistency names the break");
    }
    total += chain;
  }
  KeyframingSummary summary;
  BeginProgress(progress, "kfh", total);
  std::size_t done = 0;
  for (const MissionId& m : selected) {
    MissionKeyframingSummary s;
    KeyframeMission(options, m, map, &s, progress, &done);
    summary.missions.push_back(s);
  }
  summary.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return summary;
}

}  // namespace vilma::mapping
