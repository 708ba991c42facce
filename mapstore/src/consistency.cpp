#include "vilma/mapstore/consistency.h"

#include <filesystem>
#include <sstream>
#include <unordered_map>
#include <unordered_set>

namespace vilma {
namespace mapstore {

const char* ConsistencyProblemKindName(ConsistencyProblemKind kind) {
  switch (kind) {
    case ConsistencyProblemKind::kDuplicateId: return "duplicate_id";
    case ConsistencyProblemKind::kMissionMismatch: return "mission_mismatch";
    case ConsistencyProblemKind::kBadReference: return "bad_reference";
    case ConsistencyProblemKind::kBackReference: return "back_reference";
    case ConsistencyProblemKind::kVisualFrame: return "visual_frame";
    case ConsistencyProblemKind::kBrokenChain: return "broken_chain";
    case ConsistencyProblemKind::kImuSamples: return "imu_samples";
    case ConsistencyProblemKind::kOrphanLandmark: return "orphan_landmark";
    case ConsistencyProblemKind::kOrphanVertex: return "orphan_vertex";
    case ConsistencyProblemKind::kMissingResource: return "missing_resource";
  }
  return "unknown";
}

std::size_t ConsistencyReport::Count(ConsistencyProblemKind kind) const {
  std::size_t n = 0;
  for (const ConsistencyProblem& p : problems) n += p.kind == kind ? 1 : 0;
  return n;
}

std::string ConsistencyReport::BriefReport() const {
  if (problems.empty()) return "map is consistent";
  std::string first = problems.front().message;
  first = first.substr(0, first.find('\n'));
  return std::to_string(problems.size()) + " problem(s), first: " +
         ConsistencyProblemKindName(problems.front().kind) + ": " + first;
}

std::string ConsistencyReport::FullReport() const {
  if (problems.empty()) return "map is consistent\n";
  std::ostringstream out;
  out << problems.size() << " problem(s):\n";
  for (const ConsistencyProblem& p : problems) {
    out << ConsistencyProblemKindName(p.kind) << ": " << p.message << "\n";
  }
  return out.str();
}

ConsistencyReport CheckMapConsistency(const VIMap& map) {
  ConsistencyReport report;
  auto add = [&](ConsistencyProblemKind kind, const std::string& message) {
    report.problems.push_back({kind, message});
  };

  // Ids are unique per kind by construction (VIMap refuses duplicates); check across kinds.
  std::unordered_map<Id, const char*, IdHash> owner;
  auto claim = [&](const Id& id, const char* kind) {
    auto inserted = owner.emplace(id, kind);
    if (!inserted.second) {
      add(ConsistencyProblemKind::kDuplicateId,
          std::string(kind) + " " + id.Hex() + " has the id of a " + inserted.first->second);
    }
  };
  for (const MissionId& mission_id : map.mission_ids()) {
    claim(mission_id, "mission");
    for (const VertexId& id : map.vertex_ids(mission_id)) claim(id, "vertex");
    for (const EdgeId& id : map.edge_ids(mission_id)) claim(id, "edge");
    for (const LandmarkId& id : map.landmark_ids(mission_id)) claim(id, "landmark");
  }

  std::unordered_set<VertexId, IdHash> vertices_with_edges;
  for (const MissionId& mission_id : map.mission_ids()) {
    const Mission& mission = map.mission(mission_id);
    const std::string m = "mission " + mission_id.Hex();
    const auto& vertex_ids = map.vertex_ids(mission_id);

    // Vertices: mission, visual frames, keypoint -> landmark references, resources.
    for (const VertexId& vertex_id : vertex_ids) {
      const Vertex& v = map.vertex(vertex_id);
      const std::string vs = "vertex " + vertex_id.Hex();
      if (v.mission_id != mission_id) {
        add(ConsistencyProblemKind::kMissionMismatch,
            vs + " is listed in " + m + " but says mission " + v.mission_id.Hex());
      }
      for (std::size_t c = 0; c < v.frames.size(); ++c) {
        const VisualFrame& f = v.frames[c];
        const std::string problem = f.Validate();
        if (!problem.empty()) {
          add(ConsistencyProblemKind::kVisualFrame,
              vs + " camera " + std::to_string(c) + ": " + problem);
          continue;
        }
        for (std::size_t k = 0; k < f.landmark_ids.size(); ++k) {
          const LandmarkId& lid = f.landmark_ids[k];
          if (!lid.IsValid()) continue;
          const std::string where =
              vs + " camera " + std::to_string(c) + " keypoint " + std::to_string(k);
          if (!map.HasLandmark(lid)) {
            add(ConsistencyProblemKind::kBackReference,
                where + " refers to missing landmark " + lid.Hex());
            continue;
          }
          bool found = false;
          for (const LandmarkObservation& o : map.landmark(lid).observations) {
            if (o.vertex_id == vertex_id && o.camera == c && o.keypoint == k) {
              found = true;
              break;
            }
          }
          if (!found) {
            add(ConsistencyProblemKind::kBackReference,
                where + " refers to landmark " + lid.Hex() +
                    " which has no observation back to it");
          }
        }
        if (f.image_resource_id.IsValid()) {
          if (!map.resources().Has(ResourceType::kImage, f.image_resource_id)) {
            add(ConsistencyProblemKind::kMissingResource,
                vs + " camera " + std::to_string(c) + " refers to image resource " +
                    f.image_resource_id.Hex() + " which the map does not hold");
          }
        }
        if (f.depth_resource_id.IsValid()) {
          if (!map.resources().Has(ResourceType::kDepthMap, f.depth_resource_id)) {
            add(ConsistencyProblemKind::kMissingResource,
                vs + " camera " + std::to_string(c) + " refers to depth resource " +
                    f.depth_resource_id.Hex() + " which the map does not hold");
          }
        }
      }
    }

    // Edges: endpoints, IMU samples; the chain is checked below.
    std::unordered_map<VertexId, const Edge*, IdHash> outgoing_imu;
    std::unordered_map<VertexId, int, IdHash> incoming_imu;
    for (const EdgeId& edge_id : map.edge_ids(mission_id)) {
      const Edge& e = map.edge(edge_id);
      const std::string es = std::string(EdgeTypeName(e.type)) + " edge " + edge_id.Hex();
      const bool from_ok = map.HasVertex(e.from);
      const bool to_ok = map.HasVertex(e.to);
      if (!from_ok) add(ConsistencyProblemKind::kBadReference, es + " starts at missing vertex " + e.from.Hex());
      if (!to_ok) add(ConsistencyProblemKind::kBadReference, es + " ends at missing vertex " + e.to.Hex());
      if (from_ok) vertices_with_edges.insert(e.from);
      if (to_ok) vertices_with_edges.insert(e.to);
      if (e.type == EdgeType::kPosePrior && e.from != e.to) {
        add(ConsistencyProblemKind::kBadReference, es + " is unary but joins two vertices");
      }
      if (e.type != EdgeType::kImu || !from_ok || !to_ok) continue;
      const Vertex& a = map.vertex(e.from);
      const Vertex& b = map.vertex(e.to);
      if (a.mission_id != mission_id || b.mission_id != mission_id) {
        add(ConsistencyProblemKind::kBrokenChain, es + " joins vertices of another mission");
        continue;
      }
      if (!outgoing_imu.emplace(e.from, &e).second) {
        add(ConsistencyProblemKind::kBrokenChain,
            "vertex " + e.from.Hex() + " has more than one outgoing IMU edge");
      }
      if (++incoming_imu[e.to] > 1) {
        add(ConsistencyProblemKind::kBrokenChain,
            "vertex " + e.to.Hex() + " has more than one incoming IMU edge");
      }
      if (b.t_ns <= a.t_ns) {
        add(ConsistencyProblemKind::kBrokenChain,
            es + " goes back in time: " + std::to_string(a.t_ns) + " ns -> " +
                std::to_string(b.t_ns) + " ns");
      }
      const auto& s = e.imu_samples;
      bool sorted = true;
      for (std::size_t i = 1; i < s.size(); ++i) sorted = sorted && s[i].t_ns > s[i - 1].t_ns;
      if (!sorted) {
        add(ConsistencyProblemKind::kImuSamples, es + " has IMU samples not strictly increasing in time");
      } else if (s.empty() || s.front().t_ns > a.t_ns || s.back().t_ns < b.t_ns) {
        add(ConsistencyProblemKind::kImuSamples,
            es + " has IMU samples that do not cover [" + std::to_string(a.t_ns) + ", " +
                std::to_string(b.t_ns) + "] ns");
      }
    }

    // Chain: from the root through the outgoing IMU edges, every vertex exactly once.
    if (!vertex_ids.empty()) {
      if (!map.HasVertex(mission.root_vertex_id) ||
          map.vertex(mission.root_vertex_id).mission_id != mission_id) {
        add(ConsistencyProblemKind::kBadReference,
            m + " has root vertex " + mission.root_vertex_id.Hex() + " which is not one of its vertices");
      } else {
        const std::vector<VertexId> chain = map.VertexChain(mission_id);
        if (chain.size() != vertex_ids.size()) {
          add(ConsistencyProblemKind::kBrokenChain,
              m + ": the IMU edge chain from the root reaches " + std::to_string(chain.size()) +
                  " of " + std::to_string(vertex_ids.size()) + " vertices (it stops after vertex " +
                  chain.back().Hex() + ")");
        }
      }
    }

    // Landmarks: store vertex, observations -> vertex keypoints.
    for (const LandmarkId& landmark_id : map.landmark_ids(mission_id)) {
      const Landmark& l = map.landmark(landmark_id);
      const std::string ls = "landmark " + landmark_id.Hex();
      if (!map.HasVertex(l.store_vertex_id)) {
        add(ConsistencyProblemKind::kBadReference, ls + " is stored in missing vertex " + l.store_vertex_id.Hex());
      }
      if (l.observations.empty()) {
        add(ConsistencyProblemKind::kOrphanLandmark, ls + " has no observations");
      }
      for (const LandmarkObservation& o : l.observations) {
        const std::string os = ls + " observation (vertex " + o.vertex_id.Hex() + ", camera " +
                               std::to_string(o.camera) + ", keypoint " +
                               std::to_string(o.keypoint) + ")";
        if (!map.HasVertex(o.vertex_id)) {
          add(ConsistencyProblemKind::kBackReference, os + " points to a missing vertex");
          continue;
        }
        const Vertex& v = map.vertex(o.vertex_id);
        if (o.camera >= v.frames.size() || o.keypoint >= v.frames[o.camera].landmark_ids.size()) {
          add(ConsistencyProblemKind::kBackReference, os + " points to a missing keypoint");
          continue;
        }
        const LandmarkId& back = v.frames[o.camera].landmark_ids[o.keypoint];
        if (back != landmark_id) {
          add(ConsistencyProblemKind::kBackReference,
              os + " but that keypoint refers to " + (back.IsValid() ? "landmark " + back.Hex() : "no landmark"));
        }
      }
    }
  }

  // Orphan vertices: in a mission of several vertices, every vertex has an edge.
  for (const MissionId& mission_id : map.mission_ids()) {
    const auto& vertex_ids = map.vertex_ids(mission_id);
    if (vertex_ids.size() < 2) continue;
    for (const VertexId& id : vertex_ids) {
      if (vertices_with_edges.count(id) == 0) {
        add(ConsistencyProblemKind::kOrphanVertex, "vertex " + id.Hex() + " has no edge");
      }
    }
  }

  // Resources of a saved map: the file of every indexed resource exists.
  const ResourceStore& resources = map.resources();
  if (!resources.folder().empty()) {
    for (const ResourceInfo& info : resources.List()) {
      const auto path = std::filesystem::path(resources.folder()) / info.RelativePath();
      std::error_code ec;
      if (!std::filesystem::exists(path, ec)) {
        // A pending (not yet saved) resource has no file; Load serves it from memory.
        bool pending = false;
        try {
          pending = resources.Load(info.type, info.id) != nullptr;
        } catch (const std::exception&) {
          pending = false;
        }
        if (!pending) {
          add(ConsistencyProblemKind::kMissingResource,
              std::string(ResourceTypeName(info.type)) + " resource " + info.id.Hex() +
                  " has no file " + path.string());
        }
      }
    }
  }
  return report;
}

}  // namespace mapstore
}  // namespace vilma
