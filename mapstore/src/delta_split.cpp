#include "vilma/mapstore/delta_split.h"

#include <algorithm>
#include <unordered_map>
#include <unordered_set>

namespace vilma::mapstore {
namespace {

std::size_t VertexBytes(const MissionDelta& delta, const Vertex& v) {
  MissionDelta one;
  one.mission = delta.mission;
  one.vertices.push_back(v);
  return SerializeMissionDelta(one).size();
}

std::size_t LandmarkBytes(const Landmark& l) {
  // Ids 2 x 18, position 3 x 9 + covariance 9 x 9 with tags, 19 per observation (protobuf).
  return 160 + 20 * l.observations.size();
}

}  // namespace

std::vector<MissionDelta> SplitMissionDelta(const MissionDelta& delta, std::size_t max_bytes) {
  // Without landmarks there is nothing to split by (and the periodic deltas mid-mission, which
  // have none, skip the serialization this check costs).
  if (delta.landmarks.empty() || SerializeMissionDelta(delta).size() <= max_bytes) return {delta};

  std::unordered_map<VertexId, std::size_t, IdHash> vertex_index;
  std::vector<std::size_t> vertex_bytes(delta.vertices.size());
  for (std::size_t i = 0; i < delta.vertices.size(); ++i) {
    vertex_index.emplace(delta.vertices[i].id, i);
    vertex_bytes[i] = VertexBytes(delta, delta.vertices[i]);
  }
  // Which landmarks each vertex of the delta observes (by observation).
  std::vector<std::vector<std::size_t>> observers(delta.landmarks.size());
  std::vector<char> touched(delta.vertices.size(), 0);
  for (std::size_t l = 0; l < delta.landmarks.size(); ++l) {
    for (const LandmarkObservation& o : delta.landmarks[l].observations) {
      const auto it = vertex_index.find(o.vertex_id);
      if (it == vertex_index.end()) continue;
      observers[l].push_back(it->second);
      touched[it->second] = 1;
    }
  }

  std::unordered_set<Id, IdHash> in_delta;  // a vertex may also refer to landmarks stored before
  for (const Landmark& l : delta.landmarks) in_delta.insert(l.id);
  std::unordered_set<Id, IdHash> sent;  // the delta's landmark ids sent so far
  // A vertex as it may be stored now: without the ids of the delta's landmarks not sent yet.
  const auto with_sent_landmarks = [&](const Vertex& v) {
    Vertex copy = v;
    for (VisualFrame& f : copy.frames) {
      for (LandmarkId& id : f.landmark_ids) {
        if (id.IsValid() && in_delta.count(id) != 0 && sent.count(id) == 0) id = LandmarkId();
      }
    }
    return copy;
  };

  // Part 0: the edges with both their vertices (a vertex new in this delta must exist before
  // its edge: the vertices since the last delta), and the vertices no landmark touches.
  std::vector<MissionDelta> parts;
  MissionDelta first;
  first.mission = delta.mission;
  first.edges = delta.edges;
  std::vector<char> in_first(delta.vertices.size(), 0);
  for (const Edge& e : delta.edges) {
    for (const VertexId& end : {e.from, e.to}) {
      const auto it = vertex_index.find(end);
      if (it != vertex_index.end()) in_first[it->second] = 1;
    }
  }
  for (std::size_t i = 0; i < delta.vertices.size(); ++i) {
    if (!touched[i] || in_first[i]) first.vertices.push_back(with_sent_landmarks(delta.vertices[i]));
  }
  parts.push_back(std::move(first));

  // Landmark groups: add landmarks while the group's landmarks and the vertices they touch fit.
  std::size_t begin = 0;
  while (begin < delta.landmarks.size()) {
    std::size_t end = begin, bytes = 0;
    std::unordered_set<std::size_t> vertices;
    while (end < delta.landmarks.size()) {
      std::size_t add = LandmarkBytes(delta.landmarks[end]);
      for (std::size_t v : observers[end]) {
        if (vertices.count(v) == 0) add += vertex_bytes[v];
      }
      if (end > begin && bytes + add > max_bytes) break;
      bytes += add;
      for (std::size_t v : observers[end]) vertices.insert(v);
      ++end;
    }
    for (std::size_t l = begin; l < end; ++l) sent.insert(delta.landmarks[l].id);
    MissionDelta part;
    part.mission = delta.mission;
    std::vector<std::size_t> ordered(vertices.begin(), vertices.end());
    std::sort(ordered.begin(), ordered.end());  // the delta's order: deterministic parts
    for (std::size_t v : ordered) part.vertices.push_back(with_sent_landmarks(delta.vertices[v]));
    part.landmarks.assign(delta.landmarks.begin() + static_cast<std::ptrdiff_t>(begin),
                          delta.landmarks.begin() + static_cast<std::ptrdiff_t>(end));
    parts.push_back(std::move(part));
    begin = end;
  }
  return parts;
}

}  // namespace vilma::mapstore
