// MapBuilder, the streaming half (docs/mapping.md "Mission stream and determinism"): which vertices are
// final, what the next mission delta carries, and releasing what vilma-mapstored acknowledged.
// The building half (IMU, keyframes, tracks, landmarks) is in map_builder.cpp.
#include <algorithm>
#include <stdexcept>
#include <unordered_set>

#include "vilma/mapping/map_builder.h"
#include "vilma/mapstore/compaction.h"

namespace vilma::mapping {

using mapstore::Id;
using mapstore::VertexId;

MapBuilder::HeldVertex& MapBuilder::held_by_id(const VertexId& id) {
  // held_ is sorted by index and short (the vertices of the open tracks and those waiting for
  // an acknowledgement): a binary search over the indices via the id's index.
  const auto it = held_index_.find(id);
  if (it == held_index_.end()) {
    throw std::logic_error("map builder: vertex " + id.Hex() + " is not held");
  }
  const auto h = std::lower_bound(held_.begin(), held_.end(), it->second,
                                  [](const HeldVertex& v, int64_t i) { return v.index < i; });
  return *h;
}

bool MapBuilder::IsFinal(const VertexId& id) const {
  const auto it = held_index_.find(id);
  if (it == held_index_.end()) return true;  // released: final and acknowledged
  return it->second < final_frontier_;
}

void MapBuilder::MakeFinal(int64_t up_to_index) {
  if (up_to_index <= final_frontier_) return;
  std::vector<VertexId> now_final;
  for (const HeldVertex& h : held_) {
    if (h.index >= final_frontier_ && h.index < up_to_index) now_final.push_back(h.id);
  }
  final_frontier_ = up_to_index;
  if (now_final.empty()) return;
  // Every landmark of these vertices exists (their tracks are closed): the compaction that
  // Finish() would do is final for them.
  if (options_.compact != "none") {
    const mapstore::KeypointCompactionStats compaction =
        mapstore::RemoveKeypointsWithoutLandmark(&map_, now_final);
    stats_.keypoints_dropped +=
        static_cast<int64_t>(compaction.keypoints_before - compaction.keypoints_after);
  }
  for (const VertexId& id : now_final) {
    held_by_id(id).final = true;
    delta_vertices_.push_back(id);
    delta_final_vertices_.push_back(id);
    for (const mapstore::VisualFrame& f : map_.vertex(id).frames) {
      for (const mapstore::LandmarkId& lid : f.landmark_ids) {
        if (!lid.IsValid()) continue;
        // The landmark goes out with this vertex's observation (and those of the vertices
        // final before); with the last observer it is complete.
        delta_landmarks_.push_back(lid);
        if (--held_landmarks_.at(lid).pending_observers == 0) completed_since_delta_.push_back(lid);
      }
    }
  }
}

void MapBuilder::ReleaseAcknowledged(int64_t delta_index) {
  if (memory_ != MapBuilderMemory::kReleaseAcknowledged) return;
  mapstore::VIMap::IdSet edges, landmarks, vertices;
  while (!sent_edges_.empty() && sent_edges_.front().second <= delta_index) {
    edges.insert(sent_edges_.front().first);
    sent_edges_.pop_front();
  }
  map_.RemoveEdges(edges);
  while (!complete_landmarks_.empty() && complete_landmarks_.front().second <= delta_index) {
    const mapstore::LandmarkId lid = complete_landmarks_.front().first;
    complete_landmarks_.pop_front();
    for (const mapstore::LandmarkObservation& o : map_.landmark(lid).observations) {
      if (held_index_.count(o.vertex_id) != 0) --held_by_id(o.vertex_id).open_landmarks;
    }
    held_landmarks_.erase(lid);
    landmarks.insert(lid);
  }
  map_.RemoveLandmarks(landmarks);
  // Vertices still referred to by an edge (held, or pending its end sample) stay.
  mapstore::VIMap::IdSet linked;
  for (const mapstore::EdgeId& e : map_.edge_ids(mission_id_)) {
    linked.insert(map_.edge(e).from);
    linked.insert(map_.edge(e).to);
  }
  for (const PendingEdge& p : pending_edges_) {
    linked.insert(p.from);
    linked.insert(p.to);
  }
  const VertexId root = map_.mission(mission_id_).root_vertex_id;
  for (auto it = held_.begin(); it != held_.end();) {
    if (it->final && it->final_delta >= 0 && it->final_delta <= delta_index &&
        it->open_landmarks == 0 && it->id != root && linked.count(it->id) == 0) {
      vertices.insert(it->id);
      held_index_.erase(it->id);
      it = held_.erase(it);
    } else {
      ++it;
    }
  }
  map_.RemoveVertices(vertices);
}

MapBuilderHeld MapBuilder::Held() const {
  MapBuilderHeld h;
  const auto& vertex_ids = map_.vertex_ids(mission_id_);
  const auto& edge_ids = map_.edge_ids(mission_id_);
  const auto& landmark_ids = map_.landmark_ids(mission_id_);
  h.vertices = static_cast<int64_t>(vertex_ids.size());
  h.edges = static_cast<int64_t>(edge_ids.size());
  h.landmarks = static_cast<int64_t>(landmark_ids.size());
  h.open_tracks = static_cast<int64_t>(open_tracks_.size());
  // Heap bytes of the elements' arrays plus their structs (hash-map nodes not counted).
  int64_t bytes = 0;
  for (const VertexId& id : vertex_ids) {
    const mapstore::Vertex& v = map_.vertex(id);
    bytes += static_cast<int64_t>(sizeof(mapstore::Vertex));
    for (const mapstore::VisualFrame& f : v.frames) {
      bytes += static_cast<int64_t>(sizeof(f) + f.keypoints.capacity() * sizeof(mapstore::Keypoint) +
                                    f.descriptors.capacity() +
                                    f.track_ids.capacity() * sizeof(int64_t) +
                                    f.landmark_ids.capacity() * sizeof(mapstore::LandmarkId));
    }
  }
  for (const mapstore::EdgeId& id : edge_ids) {
    bytes += static_cast<int64_t>(sizeof(mapstore::Edge) +
                                  map_.edge(id).imu_samples.capacity() * sizeof(ImuSample));
  }
  for (const mapstore::LandmarkId& id : landmark_ids) {
    bytes += static_cast<int64_t>(sizeof(mapstore::Landmark) +
                                  map_.landmark(id).observations.capacity() *
                                      sizeof(mapstore::LandmarkObservation));
  }
  for (const auto& [track_id, track] : open_tracks_) {
    (void)track_id;
    bytes += static_cast<int64_t>(sizeof(OpenTrack) + track.observations.capacity() *
                                                          sizeof(mapstore::LandmarkObservation));
  }
  h.bytes = bytes;
  return h;
}

mapstore::MissionDelta MapBuilder::TakeDelta() {
  const int64_t index = deltas_taken_++;
  const bool release = memory_ == MapBuilderMemory::kReleaseAcknowledged;
  mapstore::MissionDelta delta;
  delta.mission = map_.mission(mission_id_);
  std::unordered_set<Id, mapstore::IdHash> seen;
  for (const VertexId& id : delta_vertices_) {
    if (!seen.insert(id).second) continue;
    delta.vertices.push_back(map_.vertex(id));
    // The stream carries no resources: a receiver would hold ids of images it does not have.
    for (mapstore::VisualFrame& f : delta.vertices.back().frames) {
      f.image_resource_id = mapstore::ResourceId();
      // Incremental: a vertex that is not final goes out without landmark ids (its landmarks
      // carry no observation of it yet); its final form follows.
      if (release && !IsFinal(id)) f.landmark_ids.assign(f.landmark_ids.size(), {});
    }
  }
  for (const mapstore::EdgeId& id : delta_edges_) {
    delta.edges.push_back(map_.edge(id));
    if (release) sent_edges_.emplace_back(id, index);
  }
  seen.clear();
  for (const mapstore::LandmarkId& id : delta_landmarks_) {
    if (!seen.insert(id).second) continue;
    delta.landmarks.push_back(map_.landmark(id));
    if (release) {
      // Only the observations of final vertices: those carry the landmark's id.
      auto& obs = delta.landmarks.back().observations;
      obs.erase(std::remove_if(obs.begin(), obs.end(),
                               [&](const mapstore::LandmarkObservation& o) {
                                 return !IsFinal(o.vertex_id);
                               }),
                obs.end());
    }
  }
  if (release) {
    for (const VertexId& id : delta_final_vertices_) held_by_id(id).final_delta = index;
    for (const mapstore::LandmarkId& id : completed_since_delta_) {
      held_landmarks_.at(id).complete_delta = index;
      complete_landmarks_.emplace_back(id, index);
    }
    delta_final_vertices_.clear();
    completed_since_delta_.clear();
  }
  delta_vertices_.clear();
  delta_edges_.clear();
  delta_landmarks_.clear();
  return delta;
}

}  // namespace vilma::mapping
