#include "vilma/mapstore/mission_repair.h"

#include <algorithm>
#include <exception>
#include <unordered_map>
#include <utility>

namespace vilma {
namespace mapstore {

namespace {

constexpr std::size_t kMaxExamples = 10;

// An id must name one element only (CheckMapConsistency's duplicate-id rule): the first element
// of any kind that arrives with it keeps it.
bool IdTakenByAnotherKind(const VIMap& map, const MissionId& mission_id, const Id& id,
                          bool vertex, bool edge, bool landmark) {
  return id == mission_id || (!vertex && map.HasVertex(id)) || (!edge && map.HasEdge(id)) ||
         (!landmark && map.HasLandmark(id));
}

// Runs `upsert` unless `why_not` already says why the element cannot be taken; an element the
// map refuses (std::invalid_argument: a vertex never sent, ...) is counted like one refused here.
template <typename Upsert>
void UpsertOrRefuse(const char* kind, const Id& id, std::string why_not, Upsert upsert,
                    std::size_t* refused, MissionRepairReport* report) {
  if (why_not.empty()) {
    try {
      upsert();
      return;
    } catch (const std::exception& e) {
      why_not = e.what();
    }
  }
  ++*refused;
  report->Note(std::string(kind) + " " + id.Hex() + " refused: " + why_not);
}

bool ObservationIsMutual(const VIMap& map, const LandmarkId& landmark_id, const LandmarkObservation& o) {
  if (!map.HasVertex(o.vertex_id)) return false;
  const Vertex& v = map.vertex(o.vertex_id);
  return o.camera < v.frames.size() && o.keypoint < v.frames[o.camera].landmark_ids.size() &&
         v.frames[o.camera].landmark_ids[o.keypoint] == landmark_id;
}

bool LandmarkListsKeypoint(const Landmark& l, const VertexId& vertex_id, std::size_t camera,
                           std::size_t keypoint) {
  for (const LandmarkObservation& o : l.observations) {
    if (o.vertex_id == vertex_id && o.camera == camera && o.keypoint == keypoint) return true;
  }
  return false;
}

// Why an edge cannot stay, or "" if it can (the IMU chain rules of CheckMapConsistency; a second
// edge out of or into a vertex is judged by the caller, in stream order).
std::string EdgeProblem(const VIMap& map, const MissionId& mission_id, const Edge& e) {
  if (!map.HasVertex(e.from)) return "starts at missing vertex " + e.from.Hex();
  if (!map.HasVertex(e.to)) return "ends at missing vertex " + e.to.Hex();
  if (e.type == EdgeType::kPosePrior && e.from != e.to) return "is unary but joins two vertices";
  if (e.type != EdgeType::kImu) return "";
  const Vertex& a = map.vertex(e.from);
  const Vertex& b = map.vertex(e.to);
  if (a.mission_id != mission_id || b.mission_id != mission_id) return "joins another mission's vertex";
  if (b.t_ns <= a.t_ns) return "goes back in time";
  const auto& s = e.imu_samples;
  for (std::size_t i = 1; i < s.size(); ++i) {
    if (s[i].t_ns <= s[i - 1].t_ns) return "has IMU samples not strictly increasing in time";
  }
  if (s.empty() || s.front().t_ns > a.t_ns || s.back().t_ns < b.t_ns) {
    return "has IMU samples that do not cover its vertices' times";
  }
  return "";
}

void ClearInvalidFrames(const std::vector<VertexId>& vertex_ids, VIMap* map, MissionRepairReport* report) {
  for (const VertexId& vertex_id : vertex_ids) {
    Vertex& v = map->vertex(vertex_id);
    for (std::size_t c = 0; c < v.frames.size(); ++c) {
      VisualFrame& f = v.frames[c];
      const std::string problem = f.Validate();
      if (problem.empty()) continue;
      VisualFrame cleared;  // no keypoints; the camera's descriptor kind and resources stay
      if (!f.descriptor_type.empty()) cleared.descriptor_type = f.descriptor_type;
      cleared.descriptor_size_bytes = f.descriptor_size_bytes;
      cleared.image_resource_id = f.image_resource_id;
      cleared.depth_resource_id = f.depth_resource_id;
      f = std::move(cleared);
      ++report->frames_cleared;
      report->Note("vertex " + vertex_id.Hex() + " camera " + std::to_string(c) + ": keypoints removed (" + problem + ")");
    }
  }
}

// Both directions of every landmark <-> keypoint reference must agree; a reference with only
// one direction is dropped, and a landmark left without observations is removed.
void KeepMutualReferences(const MissionId& mission_id, VIMap* map, MissionRepairReport* report) {
  VIMap::IdSet orphans;
  for (const LandmarkId& landmark_id : map->landmark_ids(mission_id)) {
    Landmark& l = map->landmark(landmark_id);
    const std::size_t before = l.observations.size();
    std::vector<LandmarkObservation> kept;
    kept.reserve(before);
    for (const LandmarkObservation& o : l.observations) {
      if (ObservationIsMutual(*map, landmark_id, o)) kept.push_back(o);
    }
    if (kept.size() != before) {
      report->observations_dropped += before - kept.size();
      report->Note("landmark " + landmark_id.Hex() + ": " + std::to_string(before - kept.size()) +
                   " observation(s) of keypoints that do not refer back to it dropped");
      l.observations = std::move(kept);
    }
    if (l.observations.empty()) orphans.insert(landmark_id);
  }
  if (!orphans.empty()) {
    report->landmarks_dropped += orphans.size();
    report->Note(std::to_string(orphans.size()) + " landmark(s) without observations removed");
    map->RemoveLandmarks(orphans);
  }
  for (const VertexId& vertex_id : map->vertex_ids(mission_id)) {
    Vertex& v = map->vertex(vertex_id);
    for (std::size_t c = 0; c < v.frames.size(); ++c) {
      VisualFrame& f = v.frames[c];
      for (std::size_t k = 0; k < f.landmark_ids.size(); ++k) {
        LandmarkId& id = f.landmark_ids[k];
        if (!id.IsValid()) continue;
        if (map->HasLandmark(id) && LandmarkListsKeypoint(map->landmark(id), vertex_id, c, k)) continue;
        report->Note("vertex " + vertex_id.Hex() + " camera " + std::to_string(c) + " keypoint " +
                     std::to_string(k) + ": reference to landmark " + id.Hex() + " cleared");
        id = LandmarkId();
        ++report->keypoint_references_cleared;
      }
      for (auto [resource, type] : {std::make_pair(&f.image_resource_id, ResourceType::kImage),
                                    std::make_pair(&f.depth_resource_id, ResourceType::kDepthMap)}) {
        if (resource->IsValid() && !map->resources().Has(type, *resource)) {
          report->Note("vertex " + vertex_id.Hex() + ": " + ResourceTypeName(type) + " resource " +
                       resource->Hex() + " the map does not hold cleared");
          *resource = ResourceId();
          ++report->resource_references_cleared;
        }
      }
    }
  }
}

// Removes the edges that break CheckMapConsistency's rules; afterwards every vertex has at most
// one IMU edge in and one out, and time increases along them. Returns next[v] along the chains.
std::unordered_map<VertexId, VertexId, IdHash> DropBadEdges(const MissionId& mission_id, VIMap* map,
                                                            MissionRepairReport* report) {
  std::unordered_map<VertexId, VertexId, IdHash> next;
  std::unordered_map<VertexId, VertexId, IdHash> previous;
  VIMap::IdSet dropped;
  for (const EdgeId& edge_id : map->edge_ids(mission_id)) {
    const Edge& e = map->edge(edge_id);
    std::string problem = EdgeProblem(*map, mission_id, e);
    if (problem.empty() && e.type == EdgeType::kImu) {
      if (next.count(e.from) > 0) {
        problem = "is a second IMU edge out of vertex " + e.from.Hex();
      } else if (previous.count(e.to) > 0) {
        problem = "is a second IMU edge into vertex " + e.to.Hex();
      } else {
        next[e.from] = e.to;
        previous[e.to] = e.from;
      }
    }
    if (problem.empty()) continue;
    dropped.insert(edge_id);
    report->Note(std::string(EdgeTypeName(e.type)) + " edge " + edge_id.Hex() + " " + problem + ": removed");
  }
  report->edges_dropped += dropped.size();
  if (!dropped.empty()) map->RemoveEdges(dropped);
  return next;
}

// Moves the chains that do not start at the root into missions of their own (a vertex cannot
// change missions in place: the mission is rebuilt and merged back).
void SplitOffChains(const MissionId& mission_id, const std::vector<std::vector<VertexId>>& other_chains,
                    VIMap* map, MissionRepairReport* report) {
  const Mission base = map->mission(mission_id);
  std::unordered_map<VertexId, MissionId, IdHash> owner;
  VIMap rebuilt;
  rebuilt.AddMission(base);
  // Not IdGenerator::ForMission: vilma-estimatord draws the mission's own element ids from it.
  IdGenerator ids(mission_id.hi ^ (mission_id.lo * 0x9E3779B97F4A7C15ULL) ^ 0x7061727473ULL);  // "parts"
  for (std::size_t i = 0; i < other_chains.size(); ++i) {
    Mission part = base;
    do {
      part.id = ids.Next();
    } while (part.id == mission_id || map->HasMission(part.id) || rebuilt.HasMission(part.id) ||
             map->HasVertex(part.id) || map->HasEdge(part.id) || map->HasLandmark(part.id));
    part.name = base.name + " (part " + std::to_string(i + 2) + ")";
    part.root_vertex_id = other_chains[i].front();
    rebuilt.AddMission(part);
    for (const VertexId& v : other_chains[i]) owner[v] = part.id;
    report->Note("vertices " + other_chains[i].front().Hex() + " .. " + other_chains[i].back().Hex() +
                 " (" + std::to_string(other_chains[i].size()) + ", no IMU edge to the root's chain) saved as mission " +
                 part.id.Hex() + " \"" + part.name + "\"");
  }
  report->missions_split_off += other_chains.size();
  for (const VertexId& vertex_id : map->vertex_ids(mission_id)) {
    Vertex v = map->vertex(vertex_id);
    const auto it = owner.find(vertex_id);
    if (it != owner.end()) v.mission_id = it->second;
    rebuilt.AddVertex(std::move(v));
  }
  for (const EdgeId& edge_id : map->edge_ids(mission_id)) rebuilt.AddEdge(map->edge(edge_id));
  for (const LandmarkId& landmark_id : map->landmark_ids(mission_id)) {
    rebuilt.AddLandmark(map->landmark(landmark_id));
  }
  map->RemoveMission(mission_id);
  map->MergeFrom(std::move(rebuilt));
}

}  // namespace

std::size_t MissionRepairReport::Total() const {
  return deltas_unreadable + headers_refused + vertices_refused + edges_refused + landmarks_refused +
         frames_cleared + observations_dropped + keypoint_references_cleared +
         resource_references_cleared + landmarks_dropped + edges_dropped + root_replaced +
         missions_split_off;
}

std::string MissionRepairReport::Summary() const {
  const std::pair<std::size_t, const char*> counts[] = {
      {deltas_unreadable, "unreadable delta(s) skipped"},
      {headers_refused, "mission header(s) of another mission refused"},
      {vertices_refused, "vertex(es) refused"},
      {edges_refused, "edge(s) refused"},
      {landmarks_refused, "landmark(s) refused"},
      {frames_cleared, "frame(s) with inconsistent keypoint arrays cleared"},
      {observations_dropped, "landmark observation(s) without the way back dropped"},
      {keypoint_references_cleared,
       "keypoint reference(s) to landmarks the stream did not hold (or that do not observe the keypoint) cleared"},
      {resource_references_cleared, "resource reference(s) cleared"},
      {landmarks_dropped, "landmark(s) without observations removed"},
      {edges_dropped, "edge(s) removed"},
      {root_replaced, "root vertex replaced"},
      {missions_split_off, "chain piece(s) saved as mission(s) of their own"}};
  std::string out;
  for (const auto& [count, what] : counts) {
    if (count == 0) continue;
    if (!out.empty()) out += ", ";
    out += std::to_string(count) + " " + what;
  }
  return out.empty() ? "no repairs" : out;
}

void MissionRepairReport::Note(const std::string& example) {
  if (examples.size() < kMaxExamples) examples.push_back(example);
}

void ApplyStreamedDelta(const MissionDelta& delta, const MissionId& mission_id, VIMap* map,
                        MissionRepairReport* report) {
  if (delta.mission.id == mission_id) {
    map->UpsertMission(delta.mission);
  } else {
    ++report->headers_refused;
    report->Note("a mission header of " + delta.mission.id.Hex() + " refused");
  }
  constexpr char kIdTaken[] = "its id names another element";
  for (const Vertex& v : delta.vertices) {
    const std::string why = v.mission_id != mission_id ? "it says mission " + v.mission_id.Hex()
                            : IdTakenByAnotherKind(*map, mission_id, v.id, true, false, false) ? kIdTaken
                                                                                                 : "";
    UpsertOrRefuse("vertex", v.id, why, [&] { map->UpsertVertex(v); }, &report->vertices_refused, report);
  }
  for (const Edge& e : delta.edges) {
    const bool taken = IdTakenByAnotherKind(*map, mission_id, e.id, false, true, false);
    UpsertOrRefuse("edge", e.id, taken ? kIdTaken : "", [&] { map->UpsertEdge(e); }, &report->edges_refused, report);
  }
  for (const Landmark& l : delta.landmarks) {
    const bool taken = IdTakenByAnotherKind(*map, mission_id, l.id, false, false, true);
    UpsertOrRefuse("landmark", l.id, taken ? kIdTaken : "", [&] { map->UpsertLandmark(l); },
                   &report->landmarks_refused, report);
  }
}

void RepairStreamedMission(const MissionId& mission_id, VIMap* map, MissionRepairReport* report) {
  const std::vector<VertexId> vertex_ids = map->vertex_ids(mission_id);
  ClearInvalidFrames(vertex_ids, map, report);
  KeepMutualReferences(mission_id, map, report);
  const std::unordered_map<VertexId, VertexId, IdHash> next = DropBadEdges(mission_id, map, report);
  if (vertex_ids.empty()) return;

  // The IMU edges now form disjoint chains (time increases along each, so there is no cycle).
  // A chain starts at a vertex without an incoming IMU edge; stream order breaks time ties.
  std::unordered_map<VertexId, bool, IdHash> has_previous;
  for (const auto& [from, to] : next) has_previous[to] = true;
  std::vector<std::vector<VertexId>> chains;
  for (const VertexId& start : vertex_ids) {
    if (has_previous.count(start) > 0) continue;
    std::vector<VertexId> chain{start};
    for (auto it = next.find(start); it != next.end(); it = next.find(it->second)) chain.push_back(it->second);
    chains.push_back(std::move(chain));
  }
  std::stable_sort(chains.begin(), chains.end(), [&](const auto& a, const auto& b) {
    return map->vertex(a.front()).t_ns < map->vertex(b.front()).t_ns;
  });

  Mission& mission = map->mission(mission_id);
  std::size_t root_chain = 0;  // the earliest, unless the root is on another one
  if (map->HasVertex(mission.root_vertex_id) && map->vertex(mission.root_vertex_id).mission_id == mission_id) {
    for (std::size_t i = 0; i < chains.size(); ++i) {
      if (std::find(chains[i].begin(), chains[i].end(), mission.root_vertex_id) != chains[i].end()) root_chain = i;
    }
  }
  if (mission.root_vertex_id != chains[root_chain].front()) {
    report->Note("root vertex " + mission.root_vertex_id.Hex() + " replaced by " +
                 chains[root_chain].front().Hex() + ", the start of its IMU chain");
    mission.root_vertex_id = chains[root_chain].front();
    ++report->root_replaced;
  }
  if (chains.size() == 1) return;
  chains.erase(chains.begin() + static_cast<std::ptrdiff_t>(root_chain));
  SplitOffChains(mission_id, chains, map, report);
}

}  // namespace mapstore
}  // namespace vilma
