// A VI-map mission with known landmark qualities for the mapping/locmap tests.
#pragma once

#include <Eigen/Core>
#include <vector>

#include "vilma/mapstore/vi_map.h"

namespace vilma::mapping::test {

// Adds a mission with baseframe T_G_M = translation `t_G_M` (`anchored`: known) and `vertices`
// vertices with one camera of `vertices` keypoints each; landmark l is seen by keypoint l of
// every vertex; landmark quality alternates good / bad / good / unknown. Keypoint k of vertex v
// has descriptor bytes 16 v + k.
inline void AddTestMission(mapstore::VIMap* map, mapstore::IdGenerator* ids, int vertices,
                           bool anchored, const Eigen::Vector3d& t_G_M) {
  mapstore::Mission mission;
  mission.id = ids->Next();
  mission.baseframe_known = anchored;
  mission.T_G_M = Transformation(Eigen::Quaterniond::Identity(), t_G_M);
  map->AddMission(mission);
  std::vector<mapstore::VertexId> vertex_ids;
  for (int v = 0; v < vertices; ++v) {
    mapstore::Vertex vertex;
    vertex.id = ids->Next();
    vertex.mission_id = mission.id;
    vertex.T_M_I = Transformation(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, v, 0));
    mapstore::VisualFrame frame;
    for (int k = 0; k < vertices; ++k) {
      frame.keypoints.push_back({});
      frame.descriptors.insert(frame.descriptors.end(), 64, static_cast<uint8_t>(16 * v + k));
      frame.track_ids.push_back(k);
      frame.landmark_ids.emplace_back();
    }
    vertex.frames.push_back(frame);
    vertex_ids.push_back(vertex.id);
    map->AddVertex(vertex);
  }
  const mapstore::LandmarkQuality q[] = {
      mapstore::LandmarkQuality::kGood, mapstore::LandmarkQuality::kBad,
      mapstore::LandmarkQuality::kGood, mapstore::LandmarkQuality::kUnknown};
  for (int l = 0; l < vertices; ++l) {
    mapstore::Landmark lm;
    lm.id = ids->Next();
    lm.store_vertex_id = vertex_ids[0];
    lm.p_I = Eigen::Vector3d(l, 0, 1);
    lm.quality = q[l % 4];
    map->AddLandmark(lm);
    for (int v = 0; v < vertices; ++v) {
      map->AddObservation(lm.id, {vertex_ids[v], 0, static_cast<uint32_t>(l)});
    }
  }
}

}  // namespace vilma::mapping::test
