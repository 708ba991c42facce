// RemoveKeypointsWithoutLandmark: free keypoints go, the others keep their data and order, and
// landmark observations follow their keypoints' new indices.
#include <catch2/catch.hpp>

#include "mapstore/synthetic_map.h"
#include "vilma/mapstore/compaction.h"
#include "vilma/mapstore/consistency.h"

namespace vilma::mapstore {
namespace {

// Per landmark: the descriptors and pixel positions of its observations.
std::map<std::string, std::vector<std::pair<std::vector<uint8_t>, Eigen::Vector2d>>> Observed(
    const VIMap& map) {
  std::map<std::string, std::vector<std::pair<std::vector<uint8_t>, Eigen::Vector2d>>> seen;
  for (const MissionId& m : map.mission_ids()) {
    for (const LandmarkId& l : map.landmark_ids(m)) {
      for (const LandmarkObservation& o : map.landmark(l).observations) {
        const VisualFrame& f = map.vertex(o.vertex_id).frames[o.camera];
        const uint8_t* d = f.descriptor(o.keypoint);
        seen[l.Hex()].emplace_back(std::vector<uint8_t>(d, d + f.descriptor_size_bytes),
                                   f.keypoints[o.keypoint].uv);
      }
    }
  }
  return seen;
}

TEST_CASE("RemoveKeypointsWithoutLandmark keeps what landmarks observe, re-indexed",
          "[compaction]") {
  testing::SyntheticMapOptions o;
  o.vertices_per_mission = 15;
  VIMap map = testing::MakeSyntheticMap(o);
  // Free some keypoints that had a landmark, in the middle of frames.
  const LandmarkId freed = map.landmark_ids(map.mission_ids()[0]).at(5);
  const LandmarkObservation first = map.landmark(freed).observations.front();
  map.RemoveObservation(freed, first);
  REQUIRE(CheckMapConsistency(map).ok());
  const auto before = Observed(map);
  std::size_t keypoints = 0, with_landmark = 0;
  for (const MissionId& m : map.mission_ids()) {
    for (const VertexId& v : map.vertex_ids(m)) {
      for (const VisualFrame& f : map.vertex(v).frames) {
        keypoints += f.size();
        for (const LandmarkId& l : f.landmark_ids) with_landmark += l.IsValid() ? 1 : 0;
      }
    }
  }
  REQUIRE(with_landmark < keypoints);

  const KeypointCompactionStats stats = RemoveKeypointsWithoutLandmark(&map);
  CHECK(stats.keypoints_before == keypoints);
  CHECK(stats.keypoints_after == with_landmark);
  CHECK(CheckMapConsistency(map).ok());
  CHECK(Observed(map) == before);
  for (const MissionId& m : map.mission_ids()) {
    for (const VertexId& v : map.vertex_ids(m)) {
      for (const VisualFrame& f : map.vertex(v).frames) {
        CHECK(f.Validate().empty());
        for (const LandmarkId& l : f.landmark_ids) CHECK(l.IsValid());
      }
    }
  }
  // Idempotent.
  const KeypointCompactionStats again = RemoveKeypointsWithoutLandmark(&map);
  CHECK(again.keypoints_before == again.keypoints_after);
}

}  // namespace
}  // namespace vilma::mapstore
