#include "vilma/mapstore/vi_map.h"

#include <algorithm>
#include <cmath>
#include <stdexcept>

namespace vilma {
namespace mapstore {
namespace {

[[noreturn]] void Invalid(const std::string& what, const Id& id) {
  throw std::invalid_argument("VIMap: " + what + " " + id.Hex());
}

template <typename Map>
auto& At(Map& map, const Id& id, const char* what) {
  auto it = map.find(id);
  if (it == map.end()) throw std::out_of_range(std::string("VIMap: no ") + what + " " + id.Hex());
  return it->second;
}

}  // namespace

const char* EdgeTypeName(EdgeType type) {
  switch (type) {
    case EdgeType::kImu: return "imu";
    case EdgeType::kLoopClosure: return "loop_closure";
    case EdgeType::kOdometry: return "odometry";
    case EdgeType::kPosePrior: return "pose_prior";
  }
  return "unknown";
}

std::string VisualFrame::Validate() const {
  const std::size_t n = keypoints.size();
  if (descriptors.size() != n * descriptor_size_bytes) {
    return "descriptors: expected " + std::to_string(n * descriptor_size_bytes) +
           " bytes (keypoints x descriptor_size_bytes), found " +
           std::to_string(descriptors.size());
  }
  if (track_ids.size() != n) {
    return "track_ids: expected " + std::to_string(n) + " entries, found " +
           std::to_string(track_ids.size());
  }
  if (landmark_ids.size() != n) {
    return "landmark_ids: expected " + std::to_string(n) + " entries, found " +
           std::to_string(landmark_ids.size());
  }
  if (descriptor_type.empty()) return "descriptor_type: expected a name such as BRISK";
  for (std::size_t k = 0; k < n; ++k) {
    const double sigma = keypoints[k].sigma_px;
    if (!(std::isfinite(sigma) && sigma > 0.0)) {
      return "keypoint " + std::to_string(k) + ": sigma_px expected finite and > 0, found " +
             std::to_string(sigma);
    }
  }
  return "";
}

VIMap::VIMap() : resources_(std::make_unique<ResourceStore>()) {}
VIMap::VIMap(VIMap&&) noexcept = default;
VIMap& VIMap::operator=(VIMap&&) noexcept = default;
VIMap::~VIMap() = default;

VIMap::MissionEntry& VIMap::Entry(const MissionId& id) { return At(missions_, id, "mission"); }

void VIMap::AddMission(const Mission& mission) {
  if (!mission.id.IsValid()) Invalid("invalid mission id", mission.id);
  if (missions_.count(mission.id) > 0) Invalid("duplicate mission id", mission.id);
  missions_[mission.id].mission = mission;
  mission_order_.push_back(mission.id);
}

void VIMap::AddVertex(Vertex vertex) {
  if (!vertex.id.IsValid()) Invalid("invalid vertex id", vertex.id);
  if (vertices_.count(vertex.id) > 0) Invalid("duplicate vertex id", vertex.id);
  if (missions_.count(vertex.mission_id) == 0) Invalid("vertex of unknown mission", vertex.mission_id);
  missions_[vertex.mission_id].vertices.push_back(vertex.id);
  const VertexId id = vertex.id;
  vertices_.emplace(id, std::move(vertex));
}

void VIMap::AddEdge(Edge edge) {
  if (!edge.id.IsValid()) Invalid("invalid edge id", edge.id);
  if (edges_.count(edge.id) > 0) Invalid("duplicate edge id", edge.id);
  auto from = vertices_.find(edge.from);
  if (from == vertices_.end()) Invalid("edge from unknown vertex", edge.from);
  const MissionId mission_id = from->second.mission_id;
  missions_[mission_id].edges.push_back(edge.id);
  edge_mission_[edge.id] = mission_id;
  const EdgeId id = edge.id;
  edges_.emplace(id, std::move(edge));
}

void VIMap::AddLandmark(Landmark landmark) {
  if (!landmark.id.IsValid()) Invalid("invalid landmark id", landmark.id);
  if (landmarks_.count(landmark.id) > 0) Invalid("duplicate landmark id", landmark.id);
  auto store = vertices_.find(landmark.store_vertex_id);
  if (store == vertices_.end()) Invalid("landmark in unknown store vertex", landmark.store_vertex_id);
  const MissionId mission_id = store->second.mission_id;
  missions_[mission_id].landmarks.push_back(landmark.id);
  landmark_mission_[landmark.id] = mission_id;
  const LandmarkId id = landmark.id;
  landmarks_.emplace(id, std::move(landmark));
}

void VIMap::UpsertMission(const Mission& mission) {
  auto it = missions_.find(mission.id);
  if (it == missions_.end()) {
    AddMission(mission);
  } else {
    it->second.mission = mission;
  }
}

void VIMap::UpsertVertex(Vertex vertex) {
  auto it = vertices_.find(vertex.id);
  if (it == vertices_.end()) {
    AddVertex(std::move(vertex));
    return;
  }
  if (it->second.mission_id != vertex.mission_id) {
    Invalid("upsert moves vertex to another mission", vertex.id);
  }
  it->second = std::move(vertex);
}

void VIMap::UpsertEdge(Edge edge) {
  auto it = edges_.find(edge.id);
  if (it == edges_.end()) {
    AddEdge(std::move(edge));
    return;
  }
  it->second = std::move(edge);
}

void VIMap::UpsertLandmark(Landmark landmark) {
  auto it = landmarks_.find(landmark.id);
  if (it == landmarks_.end()) {
    AddLandmark(std::move(landmark));
    return;
  }
  if (it->second.store_vertex_id != landmark.store_vertex_id) {
    Invalid("upsert moves landmark to another store vertex", landmark.id);
  }
  it->second = std::move(landmark);
}

void VIMap::AddObservation(const LandmarkId& landmark_id, const LandmarkObservation& observation) {
  Landmark& l = landmark(landmark_id);
  Vertex& v = vertex(observation.vertex_id);
  if (observation.camera >= v.frames.size() ||
      observation.keypoint >= v.frames[observation.camera].landmark_ids.size()) {
    Invalid("observation of a missing camera/keypoint at vertex", observation.vertex_id);
  }
  v.frames[observation.camera].landmark_ids[observation.keypoint] = landmark_id;
  l.observations.push_back(observation);
}

// ---------------------------------------------------------------- editing

namespace {

template <typename Vector, typename Set>
void EraseIn(Vector* ids, const Set& remove) {
  ids->erase(std::remove_if(ids->begin(), ids->end(),
                            [&](const Id& id) { return remove.count(id) > 0; }),
             ids->end());
}

}  // namespace

void VIMap::RemoveObservation(const LandmarkId& landmark_id,
                              const LandmarkObservation& observation) {
  Landmark& l = landmark(landmark_id);
  auto it = std::find(l.observations.begin(), l.observations.end(), observation);
  if (it == l.observations.end()) {
    Invalid("no such observation of landmark", landmark_id);
  }
  l.observations.erase(it);
  auto v = vertices_.find(observation.vertex_id);
  if (v != vertices_.end() && observation.camera < v->second.frames.size()) {
    auto& ids = v->second.frames[observation.camera].landmark_ids;
    if (observation.keypoint < ids.size() && ids[observation.keypoint] == landmark_id) {
      ids[observation.keypoint] = LandmarkId();
    }
  }
}

void VIMap::RemoveLandmarks(const IdSet& landmark_ids) {
  std::unordered_map<MissionId, IdSet, IdHash> by_mission;
  for (const LandmarkId& id : landmark_ids) {
    auto it = landmarks_.find(id);
    if (it == landmarks_.end()) continue;
    for (const LandmarkObservation& o : it->second.observations) {
      auto v = vertices_.find(o.vertex_id);
      if (v == vertices_.end() || o.camera >= v->second.frames.size()) continue;
      auto& ids = v->second.frames[o.camera].landmark_ids;
      if (o.keypoint < ids.size() && ids[o.keypoint] == id) ids[o.keypoint] = LandmarkId();
    }
    by_mission[landmark_mission_.at(id)].insert(id);
    landmarks_.erase(it);
    landmark_mission_.erase(id);
  }
  for (auto& [mission_id, ids] : by_mission) EraseIn(&Entry(mission_id).landmarks, ids);
}

void VIMap::RemoveEdges(const IdSet& edge_ids) {
  std::unordered_map<MissionId, IdSet, IdHash> by_mission;
  for (const EdgeId& id : edge_ids) {
    auto it = edges_.find(id);
    if (it == edges_.end()) continue;
    by_mission[edge_mission_.at(id)].insert(id);
    edges_.erase(it);
    edge_mission_.erase(id);
  }
  for (auto& [mission_id, ids] : by_mission) EraseIn(&Entry(mission_id).edges, ids);
}

void VIMap::RemoveVertices(const IdSet& vertex_ids) {
  // Check everything first so that a refused call changes nothing.
  for (const VertexId& id : vertex_ids) {
    const Vertex& v = vertex(id);
    if (missions_.at(v.mission_id).mission.root_vertex_id == id) {
      Invalid("cannot remove the root vertex of its mission (set another root first):", id);
    }
  }
  for (const auto& [edge_id, e] : edges_) {
    if (vertex_ids.count(e.from) > 0 || vertex_ids.count(e.to) > 0) {
      Invalid("cannot remove a vertex that edge " + edge_id.Hex() + " refers to: vertex",
              vertex_ids.count(e.from) > 0 ? e.from : e.to);
    }
  }
  for (const auto& [landmark_id, l] : landmarks_) {
    if (vertex_ids.count(l.store_vertex_id) > 0) {
      Invalid("cannot remove a vertex that stores landmark " + landmark_id.Hex() + ": vertex",
              l.store_vertex_id);
    }
  }
  std::unordered_map<MissionId, IdSet, IdHash> by_mission;
  for (const VertexId& id : vertex_ids) {
    Vertex& v = vertices_.at(id);
    for (std::size_t camera = 0; camera < v.frames.size(); ++camera) {
      const VisualFrame& frame = v.frames[camera];
      for (std::size_t k = 0; k < frame.landmark_ids.size(); ++k) {
        auto l = landmarks_.find(frame.landmark_ids[k]);
        if (l == landmarks_.end()) continue;
        const LandmarkObservation o{id, static_cast<uint32_t>(camera), static_cast<uint32_t>(k)};
        auto& obs = l->second.observations;
        obs.erase(std::remove(obs.begin(), obs.end(), o), obs.end());
      }
    }
    by_mission[v.mission_id].insert(id);
    vertices_.erase(id);
  }
  for (auto& [mission_id, ids] : by_mission) EraseIn(&Entry(mission_id).vertices, ids);
}

void VIMap::SetLandmarkStoreVertex(const LandmarkId& landmark_id,
                                   const VertexId& new_store_vertex) {
  Landmark& l = landmark(landmark_id);
  const Vertex& target = vertex(new_store_vertex);
  if (l.store_vertex_id == new_store_vertex) return;
  // p_I' = T_G_I'^-1 T_G_I p_I, with the covariance rotated by R_I'_I.
  const Transformation T_Inew_Iold = T_G_I(new_store_vertex).inverse() * T_G_I(l.store_vertex_id);
  l.p_I = T_Inew_Iold * l.p_I;
  const Eigen::Matrix3d R = T_Inew_Iold.rotation().toRotationMatrix();
  l.covariance = R * l.covariance * R.transpose();
  const MissionId old_mission = landmark_mission_.at(landmark_id);
  l.store_vertex_id = new_store_vertex;
  if (old_mission != target.mission_id) {
    EraseIn(&Entry(old_mission).landmarks, IdSet{landmark_id});
    Entry(target.mission_id).landmarks.push_back(landmark_id);
    landmark_mission_[landmark_id] = target.mission_id;
  }
}

void VIMap::RemoveMission(const MissionId& id) {
  MissionEntry& entry = Entry(id);
  const IdSet vertices(entry.vertices.begin(), entry.vertices.end());
  const IdSet own_landmarks(entry.landmarks.begin(), entry.landmarks.end());
  IdSet edges(entry.edges.begin(), entry.edges.end());
  for (const auto& [edge_id, e] : edges_) {  // other missions' edges into this one
    if (vertices.count(e.from) > 0 || vertices.count(e.to) > 0) edges.insert(edge_id);
  }
  RemoveEdges(edges);
  RemoveLandmarks(own_landmarks);
  // Observations of other missions' landmarks made from this mission's vertices.
  for (const VertexId& vertex_id : vertices) {
    for (const VisualFrame& frame : vertices_.at(vertex_id).frames) {
      for (const LandmarkId& landmark_id : frame.landmark_ids) {
        auto l = landmarks_.find(landmark_id);
        if (l == landmarks_.end()) continue;
        auto& obs = l->second.observations;
        obs.erase(std::remove_if(obs.begin(), obs.end(),
                                 [&](const LandmarkObservation& o) {
                                   return vertices.count(o.vertex_id) > 0;
                                 }),
                  obs.end());
      }
    }
  }
  for (const VertexId& vertex_id : vertices) vertices_.erase(vertex_id);
  missions_.erase(id);
  mission_order_.erase(std::remove(mission_order_.begin(), mission_order_.end(), id),
                       mission_order_.end());
}

void VIMap::MergeFrom(VIMap&& other) {
  if (&other == this) return;
  auto check = [&](const auto& mine, const auto& theirs, const char* what) {
    for (const auto& entry : theirs) {
      if (mine.count(entry.first) > 0) {
        Invalid(std::string("merge: ") + what + " id used in both maps (the same map loaded twice?):",
                entry.first);
      }
    }
  };
  check(missions_, other.missions_, "mission");
  check(vertices_, other.vertices_, "vertex");
  check(edges_, other.edges_, "edge");
  check(landmarks_, other.landmarks_, "landmark");
  resources_->MergeFrom(*other.resources_);  // throws before any other change
  for (const MissionId& id : other.mission_order_) {
    missions_.emplace(id, std::move(other.missions_.at(id)));
    mission_order_.push_back(id);
  }
  for (auto& entry : other.vertices_) vertices_.emplace(entry.first, std::move(entry.second));
  for (auto& entry : other.edges_) edges_.emplace(entry.first, std::move(entry.second));
  for (auto& entry : other.landmarks_) landmarks_.emplace(entry.first, std::move(entry.second));
  edge_mission_.insert(other.edge_mission_.begin(), other.edge_mission_.end());
  landmark_mission_.insert(other.landmark_mission_.begin(), other.landmark_mission_.end());
  other = VIMap();
}

VIMap VIMap::Clone() const {
  VIMap copy;
  copy.missions_ = missions_;
  copy.mission_order_ = mission_order_;
  copy.vertices_ = vertices_;
  copy.edges_ = edges_;
  copy.edge_mission_ = edge_mission_;
  copy.landmarks_ = landmarks_;
  copy.landmark_mission_ = landmark_mission_;
  copy.resources_ = resources_->Clone();
  return copy;
}

bool VIMap::HasMission(const MissionId& id) const { return missions_.count(id) > 0; }
bool VIMap::HasVertex(const VertexId& id) const { return vertices_.count(id) > 0; }
bool VIMap::HasEdge(const EdgeId& id) const { return edges_.count(id) > 0; }
bool VIMap::HasLandmark(const LandmarkId& id) const { return landmarks_.count(id) > 0; }

const Mission& VIMap::mission(const MissionId& id) const {
  return At(missions_, id, "mission").mission;
}
Mission& VIMap::mission(const MissionId& id) { return At(missions_, id, "mission").mission; }
const Vertex& VIMap::vertex(const VertexId& id) const { return At(vertices_, id, "vertex"); }
Vertex& VIMap::vertex(const VertexId& id) { return At(vertices_, id, "vertex"); }
const Edge& VIMap::edge(const EdgeId& id) const { return At(edges_, id, "edge"); }
Edge& VIMap::edge(const EdgeId& id) { return At(edges_, id, "edge"); }
const Landmark& VIMap::landmark(const LandmarkId& id) const {
  return At(landmarks_, id, "landmark");
}
Landmark& VIMap::landmark(const LandmarkId& id) { return At(landmarks_, id, "landmark"); }

const std::vector<VertexId>& VIMap::vertex_ids(const MissionId& mission_id) const {
  return At(missions_, mission_id, "mission").vertices;
}
const std::vector<EdgeId>& VIMap::edge_ids(const MissionId& mission_id) const {
  return At(missions_, mission_id, "mission").edges;
}
const std::vector<LandmarkId>& VIMap::landmark_ids(const MissionId& mission_id) const {
  return At(missions_, mission_id, "mission").landmarks;
}

MissionId VIMap::EdgeMission(const EdgeId& id) const { return At(edge_mission_, id, "edge"); }

std::vector<VertexId> VIMap::VertexChain(const MissionId& mission_id) const {
  const MissionEntry& entry = At(missions_, mission_id, "mission");
  // Outgoing IMU edge per vertex of this mission (the first one, in insertion order).
  std::unordered_map<VertexId, VertexId, IdHash> next;
  for (const EdgeId& edge_id : entry.edges) {
    const Edge& e = edges_.at(edge_id);
    if (e.type == EdgeType::kImu) next.emplace(e.from, e.to);
  }
  std::vector<VertexId> chain;
  VertexId current = entry.mission.root_vertex_id;
  while (current.IsValid()) {
    auto v = vertices_.find(current);
    if (v == vertices_.end() || v->second.mission_id != mission_id) break;
    if (!chain.empty() && v->second.t_ns <= vertices_.at(chain.back()).t_ns) break;
    if (chain.size() > entry.vertices.size()) break;  // a cycle
    chain.push_back(current);
    auto n = next.find(current);
    if (n == next.end()) break;
    current = n->second;
  }
  return chain;
}

Transformation VIMap::T_G_I(const VertexId& vertex_id) const {
  const Vertex& v = vertex(vertex_id);
  return mission(v.mission_id).T_G_M * v.T_M_I;
}

Eigen::Vector3d VIMap::LandmarkPosition_M(const LandmarkId& id) const {
  const Landmark& l = landmark(id);
  return vertex(l.store_vertex_id).T_M_I * l.p_I;
}

Eigen::Vector3d VIMap::LandmarkPosition_G(const LandmarkId& id) const {
  const Landmark& l = landmark(id);
  return T_G_I(l.store_vertex_id) * l.p_I;
}

void VIMap::SetLandmarkPosition_M(const LandmarkId& id, const Eigen::Vector3d& p_M) {
  Landmark& l = landmark(id);
  // p_I = T_M_I^-1 p_M
  l.p_I = vertex(l.store_vertex_id).T_M_I.inverse() * p_M;
}

}  // namespace mapstore
}  // namespace vilma
