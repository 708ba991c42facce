// EvaluateMap on a map with true geometry: zero errors when exact, the shift when moved, the
// alignment removes it; the world of a vilma-sim dataset folder.
#include <catch2/catch.hpp>

#include <filesystem>
#include <fstream>

#include "mapping_landmarks/geometric_map.h"
#include "vilma/core/error.h"
#include "vilma/mapping/evaluation/map_evaluation.h"

namespace vilma::mapping {
namespace {

// Ground truth = the vertices' true poses in G (mission 0), zero velocity and biases.
std::vector<GroundTruthState> TrueStates(const mapstore::VIMap& map) {
  std::vector<GroundTruthState> gt;
  for (const auto& id : map.VertexChain(map.mission_ids()[0])) {
    GroundTruthState s;
    s.t_ns = map.vertex(id).t_ns;
    const Transformation T = map.T_G_I(id);
    s.p_W_I = T.translation();
    s.q_W_I = T.rotation();
    gt.push_back(s);
  }
  return gt;
}

// A 20 cm square around each true landmark, in a plane facing the first camera.
sim::World LandmarkWorld(const testing::GeometricMap& g) {
  sim::World world;
  for (const Eigen::Vector3d& p : g.p_G_true) {
    sim::Quad q;
    q.origin_W = p - Eigen::Vector3d(0.1, 0.1, 0.0);
    q.edge_u_W = Eigen::Vector3d(0.2, 0.0, 0.0);
    q.edge_v_W = Eigen::Vector3d(0.0, 0.2, 0.0);
    world.quads.push_back(q);
  }
  return world;
}

TEST_CASE("EvaluateMap: an exact map has zero errors") {
  testing::GeometricMap g = testing::MakeGeometricMap(6, 30);
  for (const auto& id : g.landmarks) g.map.landmark(id).quality = mapstore::LandmarkQuality::kGood;
  const sim::World world = LandmarkWorld(g);
  MapEvaluationOptions o;
  o.alignment = AlignmentType::kNone;
  const MapEvaluation e = EvaluateMap(g.map, g.map.mission_ids()[0], TrueStates(g.map), &world, o);
  CHECK(e.vertices == 6);
  CHECK(e.trajectory.ate.translation_m.count == 6);
  CHECK(e.trajectory.ate.translation_m.max < 1e-12);
  CHECK(e.trajectory.ate.rotation_deg.max < 1e-6);
  CHECK(e.good_landmarks == g.landmarks.size());
  CHECK(e.reprojection_px.count > 6 * 10);
  CHECK(e.reprojection_px.max < 1e-6);
  CHECK(e.has_world);
  CHECK(e.surface_distance_m.max < 1e-9);
  CHECK(e.gyro_bias_error.max == 0.0);
  CHECK_THAT(e.FullReport(), Catch::Contains("ATE translation [m]: median 0.0000"));
  CHECK_THAT(e.ToJson(), Catch::Contains("\"surface_distance_m\": {\"count\": 30"));
}

TEST_CASE("EvaluateMap: a moved map shows the shift, posyaw alignment removes it") {
  testing::GeometricMap g = testing::MakeGeometricMap(6, 30);
  for (const auto& id : g.landmarks) g.map.landmark(id).quality = mapstore::LandmarkQuality::kGood;
  const std::vector<GroundTruthState> gt = TrueStates(g.map);
  const sim::World world = LandmarkWorld(g);
  // Shift the whole mission 0.3 m up and turn it 10 deg about z: poses and landmarks move.
  g.map.mission(g.map.mission_ids()[0]).T_G_M =
      Transformation(Eigen::Quaterniond(Eigen::AngleAxisd(0.1745, Eigen::Vector3d::UnitZ())),
                     Eigen::Vector3d(0.0, 0.0, 0.3));
  MapEvaluationOptions o;
  o.alignment = AlignmentType::kNone;
  MapEvaluation e = EvaluateMap(g.map, g.map.mission_ids()[0], gt, &world, o);
  CHECK(e.trajectory.ate.translation_m.min > 0.29);
  CHECK(e.trajectory.ate.rotation_deg.median == Approx(10.0).epsilon(0.01));
  CHECK(e.surface_distance_m.median > 0.1);
  CHECK(e.reprojection_px.max < 1e-6);  // the map is consistent in itself
  o.alignment = AlignmentType::kPosYaw;
  e = EvaluateMap(g.map, g.map.mission_ids()[0], gt, &world, o);
  CHECK(e.trajectory.ate.translation_m.max < 1e-9);
  CHECK(e.surface_distance_m.max < 1e-9);
}

TEST_CASE("EvaluateMap: the reprojection error per keypoint sigma class") {
  testing::GeometricMap g = testing::MakeGeometricMap(6, 30);
  for (const auto& id : g.landmarks) g.map.landmark(id).quality = mapstore::LandmarkQuality::kGood;
  const std::vector<GroundTruthState> gt = TrueStates(g.map);
  MapEvaluationOptions o;
  o.alignment = AlignmentType::kNone;
  // One sigma everywhere: one class, no extra report lines.
  MapEvaluation e = EvaluateMap(g.map, g.map.mission_ids()[0], gt, nullptr, o);
  REQUIRE(e.reprojection_by_sigma.size() == 1);
  CHECK(e.reprojection_by_sigma[0].reprojection_px.count == e.reprojection_px.count);
  CHECK_THAT(e.FullReport(), !Catch::Contains("keypoints at sigma"));
  // The first vertex's keypoints at 0.15 px, moved by 0.5 px; the rest exact at 1 px.
  const mapstore::VertexId first = g.map.VertexChain(g.map.mission_ids()[0])[0];
  std::size_t moved = 0;
  for (mapstore::VisualFrame& f : g.map.vertex(first).frames) {
    for (mapstore::Keypoint& k : f.keypoints) {
      k.sigma_px = 0.15;
      k.uv.x() += 0.5;
      ++moved;
    }
  }
  REQUIRE(moved > 0);
  e = EvaluateMap(g.map, g.map.mission_ids()[0], gt, nullptr, o);
  REQUIRE(e.reprojection_by_sigma.size() == 2);
  CHECK(e.reprojection_by_sigma[0].sigma_px == 0.15);
  CHECK(e.reprojection_by_sigma[0].reprojection_px.median == Approx(0.5));
  CHECK(e.reprojection_by_sigma[1].sigma_px == 1.0);
  CHECK(e.reprojection_by_sigma[1].reprojection_px.max < 1e-6);
  CHECK(e.reprojection_by_sigma[0].reprojection_px.count +
            e.reprojection_by_sigma[1].reprojection_px.count ==
        e.reprojection_px.count);
  CHECK_THAT(e.FullReport(), Catch::Contains("keypoints at sigma 0.15 px"));
  CHECK_THAT(e.ToJson(), Catch::Contains("\"reprojection_by_sigma\": [{\"sigma_px\": 0.15"));
}

TEST_CASE("EvaluateMap: bad input") {
  testing::GeometricMap g = testing::MakeGeometricMap(4, 10);
  const auto m = g.map.mission_ids()[0];
  CHECK_THROWS_AS(EvaluateMap(g.map, m, {}, nullptr, MapEvaluationOptions{}), InputError);
  MapEvaluationOptions o;
  o.alignment = AlignmentType::kFirst;
  CHECK_THROWS_WITH(EvaluateMap(g.map, m, TrueStates(g.map), nullptr, o),
                    Catch::Contains("alignment"));
  // Ground truth from another time: nothing matches.
  std::vector<GroundTruthState> late = TrueStates(g.map);
  for (auto& s : late) s.t_ns += 1'000'000'000'000LL;
  CHECK_THROWS_AS(EvaluateMap(g.map, m, late, nullptr, MapEvaluationOptions{}), InputError);
}

TEST_CASE("LoadDatasetWorld reads a vilma-sim dataset's sim.yaml") {
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() / "vilma-map-eval-world-test";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir / "mav0");
  sim::World world;
  CHECK_FALSE(LoadDatasetWorld(dir.string(), &world));
  std::ofstream(dir / "sim.yaml") << "world: room\nseed: 1\n";
  REQUIRE(LoadDatasetWorld(dir.string(), &world));
  CHECK(world.quads.size() == sim::MakePresetWorld("room", 1).quads.size());
  REQUIRE(LoadDatasetWorld((dir / "mav0").string(), &world));
  std::ofstream(dir / "sim.yaml") << "world: room\n";
  CHECK_THROWS_WITH(LoadDatasetWorld(dir.string(), &world), Catch::Contains("seed"));
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace vilma::mapping
