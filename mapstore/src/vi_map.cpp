#include "vilma/mapstore/vi_map.h"

#include <algorithm>
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
