// Keyframing (kfh): the keyframe rules, and the merged map — consistent, IMU samples conserved,
// landmarks kept in place, edges re-attached, deterministic.
#include <catch2/catch.hpp>

#include <cmath>
#include <set>

#include "mapstore/synthetic_map.h"
#include "vilma/mapping/keyframing/keyframe_heuristic.h"
#include "vilma/mapstore/consistency.h"

namespace vilma::mapping {
namespace {

using mapstore::EdgeType;
using mapstore::VertexId;
using mapstore::VIMap;

// The synthetic map with smooth poses: vertex i of each mission at x = step_m * i, turning
// yaw_step_deg per vertex.
VIMap SmoothMap(double step_m, double yaw_step_deg, int vertices = 25,
                int observations_per_landmark = 3) {
  mapstore::testing::SyntheticMapOptions o;
  o.vertices_per_mission = vertices;
  o.observations_per_landmark = observations_per_landmark;
  VIMap map = mapstore::testing::MakeSyntheticMap(o);
  for (const auto& m : map.mission_ids()) {
    const std::vector<VertexId> chain = map.VertexChain(m);
    for (std::size_t i = 0; i < chain.size(); ++i) {
      const double yaw = yaw_step_deg * M_PI / 180.0 * static_cast<double>(i);
      map.vertex(chain[i]).T_M_I =
          Transformation(Eigen::Quaterniond(Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ())),
                         Eigen::Vector3d(step_m * static_cast<double>(i), 0.0, 1.0));
    }
  }
  return map;
}

KeyframingOptions NoSharedRule() {
  KeyframingOptions o;
  o.kf_min_shared_landmarks_obs = 0;
  return o;
}

std::vector<std::size_t> Select(const KeyframingOptions& o, const VIMap& map) {
  return SelectKeyframes(o, map, map.VertexChain(map.mission_ids()[0]));
}

TEST_CASE("SelectKeyframes keeps a vertex by distance, rotation and every n-th") {
  SECTION("distance: 0.1 m steps, 0.75 m threshold -> every 8th") {
    const VIMap map = SmoothMap(0.1, 0.0);
    KeyframingOptions o = NoSharedRule();
    o.kf_every_nth_vertex = 100;
    CHECK(Select(o, map) == std::vector<std::size_t>{0, 8, 16, 24});
  }
  SECTION("rotation: 6 deg steps, 20 deg threshold -> every 4th") {
    const VIMap map = SmoothMap(0.0, 6.0);
    KeyframingOptions o = NoSharedRule();
    o.kf_every_nth_vertex = 100;
    CHECK(Select(o, map) == std::vector<std::size_t>{0, 4, 8, 12, 16, 20, 24});
  }
  SECTION("every n-th, the last vertex always kept") {
    const VIMap map = SmoothMap(0.01, 0.0);
    KeyframingOptions o = NoSharedRule();
    o.kf_every_nth_vertex = 7;
    MissionKeyframingSummary reasons;
    CHECK(SelectKeyframes(o, map, map.VertexChain(map.mission_ids()[0]), &reasons) ==
          std::vector<std::size_t>{0, 7, 14, 21, 24});
    CHECK(reasons.kept_by_every_nth == 3);
    CHECK(reasons.kept_by_distance == 0);
  }
  SECTION("shared landmarks: each landmark seen by 3 consecutive vertices, 4 per vertex") {
    // Vertex i sees the landmarks stored at i-2..i (4 each; vertex 1 sees 8); it shares 8 with
    // i-1, 4 with i-2 and none with i-3. With a minimum of 5 shared: vertex 1 (4 shared with
    // vertex 0), then every second vertex.
    const VIMap map = SmoothMap(0.0, 0.0);
    KeyframingOptions o;
    o.kf_every_nth_vertex = 100;
    o.kf_min_shared_landmarks_obs = 5;
    MissionKeyframingSummary reasons;
    const auto kept = SelectKeyframes(o, map, map.VertexChain(map.mission_ids()[0]), &reasons);
    CHECK(kept ==
          std::vector<std::size_t>{0, 1, 3, 5, 7, 9, 11, 13, 15, 17, 19, 21, 23, 24});
    CHECK(reasons.kept_by_shared_landmarks == 12);
  }
  SECTION("one and two vertices") {
    const VIMap map = SmoothMap(0.0, 0.0, 2);
    CHECK(Select(NoSharedRule(), map) == std::vector<std::size_t>{0, 1});
    CHECK(SelectKeyframes(NoSharedRule(), map, {map.VertexChain(map.mission_ids()[0])[0]}) ==
          std::vector<std::size_t>{0});
  }
}

TEST_CASE("KeyframeHeuristic merges vertices into a consistent map") {
  VIMap map = SmoothMap(0.1, 0.0);
  REQUIRE(mapstore::CheckMapConsistency(map).ok());
  const auto missions = map.mission_ids();
  std::vector<std::size_t> samples_before;
  std::vector<std::vector<VertexId>> chains_before;
  for (const auto& m : missions) {
    samples_before.push_back(DistinctImuSamples(map, m));
    chains_before.push_back(map.VertexChain(m));
  }
  // Landmark positions in G before, for every landmark that survives.
  std::map<mapstore::LandmarkId, Eigen::Vector3d> p_G_before;
  for (const auto& m : missions) {
    for (const auto& id : map.landmark_ids(m)) p_G_before[id] = map.LandmarkPosition_G(id);
  }
  const VIMap untouched = map.Clone();
  auto observations = [](const VIMap& m) {
    std::size_t n = 0;
    for (const auto& mission : m.mission_ids()) {
      for (const auto& id : m.landmark_ids(mission)) n += m.landmark(id).observations.size();
    }
    return n;
  };

  KeyframingOptions o = NoSharedRule();
  o.kf_every_nth_vertex = 100;
  const KeyframingSummary summary = KeyframeHeuristic(o, &map);
  CHECK(observations(untouched) - observations(map) ==
        summary.missions[0].observations_removed + summary.missions[1].observations_removed);

  INFO(mapstore::CheckMapConsistency(map).FullReport());
  CHECK(mapstore::CheckMapConsistency(map).ok());
  REQUIRE(summary.missions.size() == 2);
  CHECK(summary.vertices_before() == 50);
  CHECK(summary.vertices_after() == 8);
  for (std::size_t mi = 0; mi < missions.size(); ++mi) {
    const auto& m = missions[mi];
    const std::vector<VertexId> chain = map.VertexChain(m);
    // Kept: 0, 8, 16, 24 of the old chain, the same vertices (ids, poses) as before.
    REQUIRE(chain.size() == 4);
    CHECK(chain[0] == chains_before[mi][0]);
    CHECK(chain[1] == chains_before[mi][8]);
    CHECK(chain[2] == chains_before[mi][16]);
    CHECK(chain[3] == chains_before[mi][24]);
    for (const auto& v : chain) {
      CHECK(mapstore::testing::BitEqual(map.vertex(v).T_M_I.translation(),
                                        untouched.vertex(v).T_M_I.translation()));
    }
    // IMU samples: every distinct sample time kept once, each edge spans its keyframes.
    CHECK(DistinctImuSamples(map, m) == samples_before[mi]);
    CHECK(summary.missions[mi].imu_samples_after == samples_before[mi]);
    std::size_t edges = 0;
    for (const auto& id : map.edge_ids(m)) {
      const auto& e = map.edge(id);
      if (e.type != EdgeType::kImu) continue;
      ++edges;
      REQUIRE(!e.imu_samples.empty());
      CHECK(e.imu_samples.front().t_ns == map.vertex(e.from).t_ns);
      CHECK(e.imu_samples.back().t_ns == map.vertex(e.to).t_ns);
      for (std::size_t s = 1; s < e.imu_samples.size(); ++s) {
        CHECK(e.imu_samples[s].t_ns > e.imu_samples[s - 1].t_ns);
      }
      // 8 edges of 6 samples with 7 joints in between: 8 * 6 - 7.
      CHECK(e.imu_samples.size() == 41);
    }
    CHECK(edges == 3);
  }
  // Surviving landmarks did not move in G; the removed ones had no kept observer.
  std::size_t survivors = 0;
  for (const auto& [id, p_G] : p_G_before) {
    if (!map.HasLandmark(id)) {
      for (const auto& obs : untouched.landmark(id).observations) {
        const auto& chain = map.VertexChain(untouched.vertex(obs.vertex_id).mission_id);
        CHECK(std::find(chain.begin(), chain.end(), obs.vertex_id) == chain.end());
      }
      continue;
    }
    ++survivors;
    CHECK((map.LandmarkPosition_G(id) - p_G).norm() < 1e-9);
    for (const auto& obs : map.landmark(id).observations) CHECK(map.HasVertex(obs.vertex_id));
  }
  CHECK(survivors > 0);
  CHECK(survivors < p_G_before.size());
}

TEST_CASE("KeyframeHeuristic re-attaches loop closures and drops collapsed edges") {
  VIMap map = SmoothMap(0.1, 0.0);
  const auto chain0 = map.VertexChain(map.mission_ids()[0]);
  const auto chain1 = map.VertexChain(map.mission_ids()[1]);
  // A loop closure from a vertex that will be removed (mission 1, vertex 5) to one kept
  // (mission 0, vertex 8): it moves to mission 1's keyframe 0 with T_K_R * T_R_X.
  mapstore::Edge loop;
  loop.id = mapstore::IdGenerator(99).Next();
  loop.type = EdgeType::kLoopClosure;
  loop.from = chain1[5];
  loop.to = chain0[8];
  loop.T_A_B = map.vertex(chain1[5]).T_M_I.inverse() * map.vertex(chain0[8]).T_M_I;
  map.AddEdge(loop);
  const Transformation expected =
      map.vertex(chain1[0]).T_M_I.inverse() * map.vertex(chain0[8]).T_M_I;

  KeyframingOptions o = NoSharedRule();
  o.kf_every_nth_vertex = 100;
  const KeyframingSummary summary = KeyframeHeuristic(o, &map);
  CHECK(mapstore::CheckMapConsistency(map).ok());
  REQUIRE(map.HasEdge(loop.id));
  const auto& moved = map.edge(loop.id);
  CHECK(moved.from == chain1[0]);
  CHECK(moved.to == chain0[8]);
  CHECK((moved.T_A_B.translation() - expected.translation()).norm() < 1e-9);
  CHECK(Eigen::AngleAxisd(moved.T_A_B.rotation().inverse() * expected.rotation()).angle() < 1e-9);
  // The synthetic odometry edge (vertex 1 -> 2) collapses onto keyframe 0: removed; the pose
  // prior on vertex 0 (kept) stays; the synthetic loop closure (last of 1 -> first of 0) stays.
  std::size_t odometry = 0, priors = 0, loops = 0;
  for (const auto& m : map.mission_ids()) {
    for (const auto& id : map.edge_ids(m)) {
      odometry += map.edge(id).type == EdgeType::kOdometry;
      priors += map.edge(id).type == EdgeType::kPosePrior;
      loops += map.edge(id).type == EdgeType::kLoopClosure;
    }
  }
  CHECK(odometry == 0);
  CHECK(priors == 2);
  CHECK(loops == 2);
  CHECK(summary.missions[0].edges_removed + summary.missions[1].edges_removed == 2);
}

TEST_CASE("KeyframeHeuristic on one mission leaves the others alone") {
  VIMap map = SmoothMap(0.1, 0.0);
  const auto second = map.mission_ids()[1];
  const std::size_t before = map.vertex_ids(second).size();
  KeyframeHeuristic(NoSharedRule(), &map, {map.mission_ids()[0]});
  CHECK(map.vertex_ids(second).size() == before);
  CHECK(map.vertex_ids(map.mission_ids()[0]).size() < before);
  CHECK(mapstore::CheckMapConsistency(map).ok());
}

TEST_CASE("KeyframeHeuristic is deterministic") {
  VIMap a = SmoothMap(0.07, 3.0);
  VIMap b = a.Clone();
  KeyframeHeuristic(KeyframingOptions{}, &a);
  KeyframeHeuristic(KeyframingOptions{}, &b);
  for (const auto& m : a.mission_ids()) {
    CHECK(a.vertex_ids(m) == b.vertex_ids(m));
    CHECK(a.edge_ids(m) == b.edge_ids(m));
    CHECK(a.landmark_ids(m) == b.landmark_ids(m));
    for (const auto& id : a.landmark_ids(m)) {
      CHECK(a.landmark(id).store_vertex_id == b.landmark(id).store_vertex_id);
      CHECK(mapstore::testing::BitEqual(a.landmark(id).p_I, b.landmark(id).p_I));
    }
  }
}

TEST_CASE("KeyframeHeuristic refuses bad options and broken chains, changing nothing") {
  VIMap map = SmoothMap(0.1, 0.0);
  const std::size_t vertices = map.num_vertices();
  KeyframingOptions o;
  o.kf_every_nth_vertex = 0;
  CHECK_THROWS_WITH(KeyframeHeuristic(o, &map), Catch::Contains("kf_every_nth_vertex"));
  o = KeyframingOptions{};
  o.kf_distance_threshold_m = -1.0;
  CHECK_THROWS_WITH(KeyframeHeuristic(o, &map), Catch::Contains("kf_distance_threshold_m"));
  CHECK(map.num_vertices() == vertices);

  // Break mission 1's chain: remove an IMU edge in the middle.
  const auto m1 = map.mission_ids()[1];
  const auto chain = map.VertexChain(m1);
  for (const auto& id : map.edge_ids(m1)) {
    if (map.edge(id).type == EdgeType::kImu && map.edge(id).from == chain[10]) {
      map.RemoveEdge(id);
      break;
    }
  }
  CHECK_THROWS_WITH(KeyframeHeuristic(KeyframingOptions{}, &map),
                    Catch::Contains("not one chain"));
  CHECK(map.num_vertices() == vertices);  // mission 0 was not keyframed either
}

}  // namespace
}  // namespace vilma::mapping
