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
  // Gauge: the first vertex's position and heading in M did not move (roll and pitch may):
  // R_after R_firstᵀ is a rotation about a horizontal axis.
  const Transformation T_after = s.map.vertex(first).T_M_I;
  CHECK((T_after.translation() - T_first.translation()).norm() < 1e-9);
  const double heading_change = GravityYaw(T_after.rotation() * T_first.rotation().conjugate());
  INFO("heading change " << heading_change << " rad, tilt change "
                         << T_after.rotation().angularDistance(T_first.rotation()) << " rad");
  CHECK(std::abs(heading_change) < 1e-9);
  CHECK(mapstore::CheckMapConsistency(s.map).ok());
}

TEST_CASE("optvi corrects the first vertex's tilt without turning the map") {
  // Noise-free geometry, perturbed: the optimum is the true shape placed by the gauge, so the
  // map's heading against the truth (posyaw over all vertices) must be the first vertex's
  // perturbed heading. Holding the body's own yaw ψ(R_M_I) instead (before 2026-11-27) turned
  // the map by ~tan(β/2) times that vertex's tilt correction on this camera-like IMU mount
  // (its z axis β ≈ 90° from up).
  SimulatedViMap s = MakeSimulatedViMap(10.0, 0.0);
  Perturb(&s, 0.05, 1.0, 3);
  const auto chain = s.map.VertexChain(s.map.mission_ids()[0]);
  const Transformation T_first = s.map.vertex(chain.front()).T_M_I;
  ViOptimizationOptions o = Quiet();
  o.ba_num_iterations = 100;
  o.ba_iterations_per_round = 10;
  const ViOptimizationSummary r = OptimizeViMap(o, &s.map);
  INFO(r.FullReport());
  std::vector<Eigen::Vector3d> p_true, p_est;
  for (std::size_t i = 0; i < chain.size(); ++i) {
    p_true.push_back(s.T_M_I_true[i].translation());
    p_est.push_back(s.map.vertex(chain[i]).T_M_I.translation());
  }
  const double map_heading =
      GravityYaw(AlignPositions(AlignmentType::kPosYaw, p_true, p_est).T_G_E.rotation());
  const double first_heading =
      GravityYaw(s.T_M_I_true.front().rotation() * T_first.rotation().conjugate());
  const Eigen::Vector3d up_true =
      s.T_M_I_true.front().rotation().conjugate() * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d up_first = T_first.rotation().conjugate() * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d up_after =
      s.map.vertex(chain.front()).T_M_I.rotation().conjugate() * Eigen::Vector3d::UnitZ();
  const double tilt_before = std::asin(std::min(1.0, up_first.cross(up_true).norm()));
  const double tilt_after = std::asin(std::min(1.0, up_after.cross(up_true).norm()));
  INFO("map heading against the truth " << map_heading << " rad, the first vertex's perturbed "
                                        << first_heading << " rad; its tilt error " << tilt_before
                                        << " -> " << tilt_after << " rad");
  CHECK(VertexRmse(s, AlignmentType::kPosYaw) < 1e-3);
  CHECK(tilt_before > 0.005);                           // the first vertex's tilt was off
  CHECK(tilt_after < 1e-3);                             // and was corrected
  CHECK(std::abs(map_heading - first_heading) < 1e-4);  // without turning the map
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

// The initial cost of optv (visual terms only, no robust loss: 1/2 sum |r / sigma|^2) when the
// keypoints of the vertices in [from, to) of the chain store sigma_px.
double InitialVisualCost(const SimulatedViMap& s, std::size_t from, std::size_t to,
                         double sigma_px, double override_sigma_px = 0.0) {
  mapstore::VIMap map = s.map.Clone();
  const auto chain = map.VertexChain(map.mission_ids()[0]);
  for (std::size_t i = from; i < to && i < chain.size(); ++i) {
    for (mapstore::VisualFrame& f : map.vertex(chain[i]).frames) {
      for (mapstore::Keypoint& k : f.keypoints) k.sigma_px = sigma_px;
    }
  }
  ViOptimizationOptions o = Quiet();
  o.inertial = false;
  o.ba_robust_loss = "none";
  o.ba_num_iterations = 1;
  o.ba_iterations_per_round = 1;
  o.keypoint_sigma_px = override_sigma_px;
  return OptimizeViMap(o, &map).initial_cost;
}

TEST_CASE("optv whitens each reprojection residual by its keypoint's sigma_px") {
  const SimulatedViMap s = MakeSimulatedViMap(4.0, 0.3);
  const std::size_t n = s.map.vertex_ids(s.map.mission_ids()[0]).size();
  const double c_default = InitialVisualCost(s, 0, 0, 1.0);  // the map's 1 px everywhere
  REQUIRE(c_default > 0.0);
  // All keypoints at 0.5 px: residuals x2, cost x4.
  CHECK(InitialVisualCost(s, 0, n, 0.5) == Approx(4.0 * c_default).epsilon(1e-9));
  // Per observation: 0.5 px on the first half, then on the second half; the two costs are
  // 4 C_first + C_second and C_first + 4 C_second, together 5 C.
  const double c_first = InitialVisualCost(s, 0, n / 2, 0.5);
  const double c_second = InitialVisualCost(s, n / 2, n, 0.5);
  CHECK(c_first != Approx(c_second).epsilon(1e-6));
  CHECK(c_first + c_second == Approx(5.0 * c_default).epsilon(1e-9));
  // keypoint_sigma_px > 0 overrides the map's sigmas.
  CHECK(InitialVisualCost(s, 0, n, 0.5, 1.0) == Approx(c_default).epsilon(1e-12));
  CHECK(InitialVisualCost(s, 0, n, 0.5, 2.0) == Approx(0.25 * c_default).epsilon(1e-9));
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

TEST_CASE("optvi: ba_imu_noise_scale multiplies the IMU densities (inertial cost / scale^2)") {
  SimulatedViMap s = MakeSimulatedViMap(2.0);
  Perturb(&s, 0.02, 0.2, 7);
  ViOptimizationOptions o = Quiet();
  o.visual = false;  // the inertial terms alone
  o.ba_initialize_imu_states = false;
  o.ba_num_iterations = 1;
  mapstore::VIMap a = s.map.Clone();
  const double cost1 = OptimizeViMap(o, &a).initial_cost;
  o.ba_imu_noise_scale = 4.0;
  mapstore::VIMap b = s.map.Clone();
  const double cost4 = OptimizeViMap(o, &b).initial_cost;
  REQUIRE(cost1 > 1.0);
  // Every density (white and random walk) times 4: every covariance times 16 (to 1 %: the
  // preintegration's fixed floors, 1e-12 on the covariance and 1e-9 on a zero random walk).
  CHECK(cost4 / cost1 == Approx(1.0 / 16.0).epsilon(1e-2));
  o.ba_imu_noise_scale = 0.0;
  CHECK_THROWS_WITH(OptimizeViMap(o, &b), Catch::Contains("ba_imu_noise_scale"));
}

TEST_CASE("optvi: ba_gyro_noise_scale and ba_accel_noise_scale scale one sensor each") {
  SimulatedViMap s = MakeSimulatedViMap(2.0);
  Perturb(&s, 0.02, 0.2, 7);
  ViOptimizationOptions o = Quiet();
  o.visual = false;
  o.ba_initialize_imu_states = false;
  o.ba_num_iterations = 1;
  auto cost = [&](const ViOptimizationOptions& options) {
    mapstore::VIMap m = s.map.Clone();
    return OptimizeViMap(options, &m).initial_cost;
  };
  const double cost1 = cost(o);
  o.ba_imu_noise_scale = 4.0;
  const double cost_all = cost(o);
  o.ba_imu_noise_scale = 1.0;
  o.ba_gyro_noise_scale = 4.0;
  o.ba_accel_noise_scale = 4.0;
  // Both sensors times 4 is ba_imu_noise_scale 4, to the last bit.
  CHECK(cost(o) == cost_all);
  o.ba_gyro_noise_scale = 1.0;
  const double cost_accel = cost(o);
  o.ba_accel_noise_scale = 1.0;
  o.ba_gyro_noise_scale = 4.0;
  const double cost_gyro = cost(o);
  // Either alone lowers the cost, and not as far as both.
  CHECK(cost_accel < cost1);
  CHECK(cost_gyro < cost1);
  CHECK(cost_accel > cost_all);
  CHECK(cost_gyro > cost_all);
  // The scales multiply: ba_imu_noise_scale 2 with ba_accel_noise_scale 2 and
  // ba_gyro_noise_scale 2 is every density times 4.
  o.ba_imu_noise_scale = 2.0;
  o.ba_gyro_noise_scale = 2.0;
  o.ba_accel_noise_scale = 2.0;
  CHECK(cost(o) == Approx(cost_all).epsilon(1e-12));
  o.ba_gyro_noise_scale = 0.0;
  CHECK_THROWS_WITH(cost(o), Catch::Contains("ba_gyro_noise_scale"));
  o.ba_gyro_noise_scale = 1.0;
  o.ba_accel_noise_scale = -1.0;
  CHECK_THROWS_WITH(cost(o), Catch::Contains("ba_accel_noise_scale"));
}

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
