// OptimizeViMap on a map with exact visual-inertial geometry (simulated_vi_map.h): it stays
// exact, a perturbed map comes back, the gauge holds, visual-only works, outliers go, bad input
// and cancel leave the map untouched, and two runs agree.
#include <catch2/catch.hpp>

#include <cmath>

#include "mapping_optimization/simulated_vi_map.h"
#include "test_random.h"
#include "vilma/eval/evaluate.h"
#include "vilma/mapping/optimization/vi_optimization.h"
#include "vilma/mapstore/consistency.h"

namespace vilma::mapping {
namespace {

using testing::MakeSimulatedViMap;
using testing::SimulatedViMap;

// Vertex position RMSE against the truth after a posyaw (or no) alignment [m].
double VertexRmse(const SimulatedViMap& s, AlignmentType type = AlignmentType::kPosYaw) {
  const auto chain = s.map.VertexChain(s.map.mission_ids()[0]);
  std::vector<Eigen::Vector3d> p_true, p_est;
  for (std::size_t i = 0; i < chain.size(); ++i) {
    p_true.push_back(s.T_M_I_true[i].translation());
    p_est.push_back(s.map.vertex(chain[i]).T_M_I.translation());
  }
  const Alignment a = AlignPositions(type, p_true, p_est);
  double sum = 0.0;
  for (std::size_t i = 0; i < p_est.size(); ++i) {
    sum += (a.Apply(Transformation(Eigen::Quaterniond::Identity(), p_est[i])).translation() -
            p_true[i])
               .squaredNorm();
  }
  return std::sqrt(sum / static_cast<double>(p_est.size()));
}

void Perturb(SimulatedViMap* s, double meters, double degrees, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n(0.0, 1.0);
  const auto draw = [&] { return n(rng); };
  const auto m = s->map.mission_ids()[0];
  for (const auto& id : s->map.VertexChain(m)) {
    mapstore::Vertex& v = s->map.vertex(id);
    const Eigen::Vector3d axis = vilma::testing::DrawVector3(draw);
    v.T_M_I = Transformation(
        v.T_M_I.rotation() * ExpSO3(axis.normalized() * degrees * M_PI / 180.0),
        v.T_M_I.translation() + vilma::testing::DrawVector3(draw) * meters / std::sqrt(3.0));
    v.v_M += vilma::testing::DrawVector3(draw) * 0.05;
  }
  for (const auto& id : s->map.landmark_ids(m)) {
    s->map.landmark(id).p_I += vilma::testing::DrawVector3(draw) * meters / std::sqrt(3.0);
  }
}

ViOptimizationOptions Quiet() {
  ViOptimizationOptions o;
  o.evaluate_quality = false;  // the test landmarks are judged by the test
  return o;
}

TEST_CASE("optvi keeps an exact map exact") {
  SimulatedViMap s = MakeSimulatedViMap();
  REQUIRE(mapstore::CheckMapConsistency(s.map).ok());
  const ViOptimizationSummary r = OptimizeViMap(Quiet(), &s.map);
  INFO(r.FullReport());
  CHECK(r.inertial_residuals == s.map.vertex_ids(s.map.mission_ids()[0]).size() - 1);
  CHECK(r.reprojection_residuals > 500);
  CHECK(r.initial_cost < 1e-2);  // the integration scheme's error under tight IMU weights
  CHECK(r.reprojection_rmse_after_px < 1e-3);
  CHECK(VertexRmse(s, AlignmentType::kNone) < 1e-4);
}

TEST_CASE("optvi brings a perturbed map back, the first vertex's position and yaw hold") {
  SimulatedViMap s = MakeSimulatedViMap(10.0, 0.5);
  Perturb(&s, 0.05, 1.0, 3);
  const auto first = s.map.VertexChain(s.map.mission_ids()[0]).front();
  const Transformation T_first = s.map.vertex(first).T_M_I;
  const double before = VertexRmse(s, AlignmentType::kSe3);
  ViOptimizationOptions o = Quiet();
  o.ba_num_iterations = 100;
  o.ba_iterations_per_round = 10;
  const ViOptimizationSummary r = OptimizeViMap(o, &s.map);
  INFO(r.FullReport());
  const double after = VertexRmse(s, AlignmentType::kSe3);
  WARN("10 s, perturbed 5 cm / 1 deg, 0.5 px noise: vertex RMSE " << before << " -> " << after << " m (se3), " << VertexRmse(s, AlignmentType::kSim3) << " m (sim3)");
  CHECK(before > 0.03);
  // The shape comes back to millimetres; the scale (seen through the accelerometer over 10 s)
  // to a few parts per thousand.
  CHECK(VertexRmse(s, AlignmentType::kSim3) < 0.003);
  CHECK(after < 0.01);
  CHECK(r.final_cost < r.initial_cost * 1e-2);
  // Gauge: the first vertex's position and yaw did not move (roll and pitch may).
  const Transformation T_after = s.map.vertex(first).T_M_I;
  CHECK((T_after.translation() - T_first.translation()).norm() < 1e-9);
  INFO("yaw before " << GravityYaw(T_first.rotation()) << " after " << GravityYaw(T_after.rotation()));
  CHECK(std::abs(GravityYaw(T_after.rotation()) - GravityYaw(T_first.rotation())) < 1e-9);
  CHECK(mapstore::CheckMapConsistency(s.map).ok());
}

TEST_CASE("optv (visual only) brings the structure back up to a similarity") {
  SimulatedViMap s = MakeSimulatedViMap(4.0, 0.3);
  Perturb(&s, 0.03, 0.5, 4);
  const double before = VertexRmse(s, AlignmentType::kSim3);
  ViOptimizationOptions o = Quiet();
  o.inertial = false;
  o.ba_num_iterations = 50;
  const ViOptimizationSummary r = OptimizeViMap(o, &s.map);
  INFO(r.FullReport());
  CHECK(r.command == "optv");
  CHECK(r.inertial_residuals == 0);
  const double after = VertexRmse(s, AlignmentType::kSim3);
  CHECK(after < 0.25 * before);
}

TEST_CASE("optvi removes an outlier observation and the map stays consistent") {
  SimulatedViMap s = MakeSimulatedViMap();
  const auto m = s.map.mission_ids()[0];
  const auto lid = s.map.landmark_ids(m)[3];
  const auto o = s.map.landmark(lid).observations[1];
  s.map.vertex(o.vertex_id).frames[o.camera].keypoints[o.keypoint].uv += Eigen::Vector2d(40, -30);
  const std::size_t observations = s.map.landmark(lid).observations.size();
  const ViOptimizationSummary r = OptimizeViMap(Quiet(), &s.map);
  CHECK(r.outlier_observations == 1);
  CHECK(s.map.landmark(lid).observations.size() == observations - 1);
  CHECK(VertexRmse(s, AlignmentType::kNone) < 1e-3);
  CHECK(mapstore::CheckMapConsistency(s.map).ok());
}

TEST_CASE("optvi is deterministic") {
  SimulatedViMap a = MakeSimulatedViMap(3.0, 0.5);
  Perturb(&a, 0.03, 0.5, 5);
  mapstore::VIMap b = a.map.Clone();
  ViOptimizationOptions o = Quiet();
  o.ba_num_threads = 1;
  OptimizeViMap(o, &a.map);
  OptimizeViMap(o, &b);
  for (const auto& id : a.map.vertex_ids(a.map.mission_ids()[0])) {
    CHECK(a.map.vertex(id).T_M_I.translation() == b.vertex(id).T_M_I.translation());
    CHECK(a.map.vertex(id).gyro_bias == b.vertex(id).gyro_bias);
  }
}

class CancelAfter : public ProgressObserver {
 public:
  void Begin(const std::string&, std::size_t) override {}
  void Advance(std::size_t done) override { done_ = done; }
  bool CancelRequested() const override { return done_ >= 3; }

 private:
  std::size_t done_ = 0;
};

TEST_CASE("optvi: bad input and cancel leave the map untouched") {
  SimulatedViMap s = MakeSimulatedViMap(2.0);
  Perturb(&s, 0.02, 0.2, 6);
  const auto m = s.map.mission_ids()[0];
  const auto v0 = s.map.VertexChain(m)[3];
  const Eigen::Vector3d p_before = s.map.vertex(v0).T_M_I.translation();

  CancelAfter cancel;
  ViOptimizationOptions o = Quiet();
  o.ba_iterations_per_round = 1;
  CHECK_THROWS_AS(OptimizeViMap(o, &s.map, {}, &cancel), Cancelled);
  CHECK(s.map.vertex(v0).T_M_I.translation() == p_before);

  o = Quiet();
  o.ba_num_iterations = 0;
  CHECK_THROWS_WITH(OptimizeViMap(o, &s.map), Catch::Contains("ba_num_iterations"));

  mapstore::VIMap empty;
  CHECK_THROWS_WITH(OptimizeViMap(Quiet(), &empty), Catch::Contains("nothing to optimize"));

  mapstore::VIMap nan = s.map.Clone();
  nan.vertex(v0).v_M.x() = std::nan("");
  CHECK_THROWS_WITH(OptimizeViMap(Quiet(), &nan), Catch::Contains("not finite"));

  mapstore::VIMap broken = s.map.Clone();
  for (const auto& id : broken.edge_ids(m)) {
    if (broken.edge(id).from == v0) {
      broken.RemoveEdge(id);
      break;
    }
  }
  CHECK_THROWS_WITH(OptimizeViMap(Quiet(), &broken), Catch::Contains("not one chain"));
  CHECK(s.map.vertex(v0).T_M_I.translation() == p_before);
}

}  // namespace
}  // namespace vilma::mapping
