#include "vilma/mapstore/compaction.h"

#include <stdexcept>
#include <string>

namespace vilma::mapstore {
namespace {

// Keeps the elements of `values` whose index has keep[i] (`stride` values per element).
template <typename T>
void KeepElements(const std::vector<char>& keep, std::size_t stride, std::vector<T>* values) {
  std::size_t out = 0;
  for (std::size_t i = 0; i < keep.size(); ++i) {
    if (!keep[i]) continue;
    for (std::size_t b = 0; b < stride; ++b) (*values)[out * stride + b] = (*values)[i * stride + b];
    ++out;
  }
  values->resize(out * stride);
}

void CompactFrame(VIMap* map, const VertexId& vertex_id, uint32_t camera,
                  KeypointCompactionStats* stats) {
  VisualFrame& frame = map->vertex(vertex_id).frames[camera];
  const std::size_t n = frame.size();
  stats->keypoints_before += n;
  std::vector<char> keep(n, 0);
  std::size_t kept = 0;
  for (std::size_t k = 0; k < n; ++k) {
    if (frame.landmark_ids[k].IsValid()) {
      keep[k] = 1;
      // The landmark's observation of this keypoint moves to its new index.
      Landmark& landmark = map->landmark(frame.landmark_ids[k]);
      bool found = false;
      for (LandmarkObservation& o : landmark.observations) {
        if (o.vertex_id == vertex_id && o.camera == camera && o.keypoint == k) {
          o.keypoint = static_cast<uint32_t>(kept);
          found = true;
          break;
        }
      }
      if (!found) {
        throw std::invalid_argument("RemoveKeypointsWithoutLandmark: landmark " +
                                    frame.landmark_ids[k].Hex() + " lacks the observation of " +
                                    "keypoint " + std::to_string(k) + " of vertex " +
                                    vertex_id.Hex() + " (check_map_consistency)");
      }
      ++kept;
    }
  }
  stats->keypoints_after += kept;
  if (kept == n) return;
  KeepElements(keep, 1, &frame.keypoints);
  KeepElements(keep, frame.descriptor_size_bytes, &frame.descriptors);
  KeepElements(keep, 1, &frame.track_ids);
  KeepElements(keep, 1, &frame.landmark_ids);
}

}  // namespace

KeypointCompactionStats RemoveKeypointsWithoutLandmark(VIMap* map,
                                                       const std::vector<VertexId>& vertices) {
  KeypointCompactionStats stats;
  std::vector<VertexId> all;
  if (vertices.empty()) {
    for (const MissionId& m : map->mission_ids()) {
      all.insert(all.end(), map->vertex_ids(m).begin(), map->vertex_ids(m).end());
    }
  }
  for (const VertexId& v : vertices.empty() ? all : vertices) {
    const std::size_t cameras = map->vertex(v).frames.size();
    for (std::size_t c = 0; c < cameras; ++c) {
      CompactFrame(map, v, static_cast<uint32_t>(c), &stats);
    }
  }
  return stats;
}

}  // namespace vilma::mapstore
