#include <catch2/catch.hpp>

#include "mapstore/synthetic_map.h"
#include "vilma/mapstore/vi_map.h"

using namespace vilma;
using namespace vilma::mapstore;
using namespace vilma::mapstore::testing;

TEST_CASE("vertex chain follows IMU edges in time order", "[mapstore]") {
  SyntheticMapOptions o;
  VIMap map = MakeSyntheticMap(o);
  for (const MissionId& mid : map.mission_ids()) {
    const std::vector<VertexId> chain = map.VertexChain(mid);
    REQUIRE(chain == map.vertex_ids(mid));
    for (std::size_t i = 1; i < chain.size(); ++i) {
      CHECK(map.vertex(chain[i]).t_ns > map.vertex(chain[i - 1]).t_ns);
    }
  }
}

TEST_CASE("frames: T_G_I and landmark positions in M and G", "[mapstore]") {
  VIMap map = MakeSyntheticMap({});
  const MissionId mid = map.mission_ids()[1];
  const VertexId vid = map.vertex_ids(mid)[3];
  const Mission& m = map.mission(mid);
  const Vertex& v = map.vertex(vid);
  const Transformation T_G_I = map.T_G_I(vid);
  CHECK((T_G_I.matrix() - (m.T_G_M.matrix() * v.T_M_I.matrix())).norm() < 1e-12);

  const LandmarkId lid = map.landmark_ids(mid)[7];
  const Landmark& l = map.landmark(lid);
  const Vertex& store = map.vertex(l.store_vertex_id);
  const Eigen::Vector3d p_M = store.T_M_I.rotationMatrix() * l.p_I + store.T_M_I.translation();
  CHECK((map.LandmarkPosition_M(lid) - p_M).norm() < 1e-12);
  CHECK((map.LandmarkPosition_G(lid) - m.T_G_M * p_M).norm() < 1e-12);
  // Re-anchoring the mission moves G positions but not M positions.
  map.mission(mid).T_G_M = Transformation(Eigen::Quaterniond(1, 0, 0, 0), Eigen::Vector3d(1, 2, 3));
  CHECK((map.LandmarkPosition_M(lid) - p_M).norm() < 1e-12);
  CHECK((map.LandmarkPosition_G(lid) - (p_M + Eigen::Vector3d(1, 2, 3))).norm() < 1e-12);
  // Setting a position in M stores it in the store vertex's frame.
  map.SetLandmarkPosition_M(lid, Eigen::Vector3d(4, 5, 6));
  CHECK((map.LandmarkPosition_M(lid) - Eigen::Vector3d(4, 5, 6)).norm() < 1e-12);
}

TEST_CASE("observations keep both directions in step", "[mapstore]") {
  VIMap map = MakeSyntheticMap({});
  // Cross-mission observations: the last keypoint of mission 1's camera 0 frames.
  const MissionId m0 = map.mission_ids()[0], m1 = map.mission_ids()[1];
  const Vertex& v = map.vertex(map.vertex_ids(m1)[2]);
  const LandmarkId lid = v.frames[0].landmark_ids.back();
  REQUIRE(lid.IsValid());
  const Landmark& l = map.landmark(lid);
  CHECK(map.vertex(l.store_vertex_id).mission_id == m0);
  bool found = false;
  for (const LandmarkObservation& o : l.observations) found = found || o.vertex_id == v.id;
  CHECK(found);
}

TEST_CASE("adding duplicates or dangling elements is refused", "[mapstore]") {
  VIMap map = MakeSyntheticMap({});
  const MissionId mid = map.mission_ids()[0];
  Vertex v = map.vertex(map.vertex_ids(mid)[0]);
  CHECK_THROWS_AS(map.AddVertex(v), std::invalid_argument);
  v.id = IdGenerator(99).Next();
  v.mission_id = IdGenerator(98).Next();
  CHECK_THROWS_AS(map.AddVertex(v), std::invalid_argument);
  Landmark l;
  l.id = IdGenerator(97).Next();
  l.store_vertex_id = IdGenerator(96).Next();
  CHECK_THROWS_AS(map.AddLandmark(l), std::invalid_argument);
  CHECK_THROWS_AS(map.vertex(IdGenerator(95).Next()), std::out_of_range);
  Mission m = map.mission(mid);
  CHECK_THROWS_AS(map.AddMission(m), std::invalid_argument);
}

TEST_CASE("visual frame validation names the array that disagrees", "[mapstore]") {
  VisualFrame f;
  f.keypoints.resize(2);
  f.track_ids = {1, 2};
  f.landmark_ids.resize(2);
  f.descriptors.resize(127);
  CHECK_THAT(f.Validate(), Catch::Contains("descriptors: expected 128 bytes"));
  f.descriptors.resize(128);
  CHECK(f.Validate().empty());
  f.track_ids.pop_back();
  CHECK_THAT(f.Validate(), Catch::Contains("track_ids"));
}
