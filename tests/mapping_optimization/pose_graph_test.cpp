// relax on a drifting circle: correct loop edges pull it back; a wrong one is switched off.
#include <catch2/catch.hpp>

#include <cmath>

#include "vilma/mapping/optimization/pose_graph.h"
#include "vilma/mapstore/consistency.h"

namespace vilma::mapping {
namespace {

struct Circle {
  mapstore::VIMap map;
  std::vector<mapstore::VertexId> chain;
  std::vector<Transformation> T_true;
};

// 40 vertices on a 3 m circle, 1 s apart; the stored poses drift (0.1 deg yaw, 5 mm per step:
// within relax's default odometry noise, 0.2 deg and 2 cm per sqrt(s)).
Circle MakeCircle() {
  Circle c;
  mapstore::Mission mission;
  mission.id = mapstore::IdGenerator(3).Next();
  c.map.AddMission(mission);
  auto ids = mapstore::IdGenerator::ForMission(mission.id);
  Transformation drift;
  for (int i = 0; i < 40; ++i) {
    const double a = 2 * M_PI * i / 40.0;
    const Transformation T(Eigen::Quaterniond(Eigen::AngleAxisd(a + M_PI / 2, Eigen::Vector3d::UnitZ())),
                           Eigen::Vector3d(3 * std::cos(a), 3 * std::sin(a), 1.0));
    c.T_true.push_back(T);
    if (i > 0) {
      const Transformation step = c.T_true[i - 1].inverse() * T;
      drift = Transformation(Eigen::Quaterniond(Eigen::AngleAxisd(0.1 * M_PI / 180, Eigen::Vector3d::UnitZ())),
                             Eigen::Vector3d(0.005, 0.0, 0.0));
      (void)step;
    }
    mapstore::Vertex v;
    v.id = ids.Next();
    v.mission_id = mission.id;
    v.t_ns = 1'000'000'000LL * (i + 1);
    // Drifted pose: previous stored pose composed with the true step and the drift.
    v.T_M_I = i == 0 ? T : c.map.vertex(c.chain.back()).T_M_I * (c.T_true[i - 1].inverse() * T) * drift;
    v.v_M = Eigen::Vector3d(1, 0, 0);
    c.chain.push_back(v.id);
    if (i == 0) c.map.mission(mission.id).root_vertex_id = v.id;
    c.map.AddVertex(std::move(v));
    if (i > 0) {
      mapstore::Edge e;
      e.id = ids.Next();
      e.type = mapstore::EdgeType::kImu;
      e.from = c.chain[i - 1];
      e.to = c.chain[i];
      for (int64_t t : {c.map.vertex(e.from).t_ns, c.map.vertex(e.to).t_ns}) {
        ImuSample s;
        s.t_ns = t;
        e.imu_samples.push_back(s);
      }
      c.map.AddEdge(std::move(e));
    }
  }
  return c;
}

void AddLoop(Circle* c, int a, int b, const Transformation& T_ab) {
  mapstore::Edge e;
  e.id = mapstore::IdGenerator(100 + a * 41 + b).Next();
  e.type = mapstore::EdgeType::kLoopClosure;
  e.from = c->chain[a];
  e.to = c->chain[b];
  e.T_A_B = T_ab;
  e.covariance = Matrix6d::Identity() * 1e-4;
  c->map.AddEdge(e);
}

double Rmse(const Circle& c) {
  double sum = 0;
  for (std::size_t i = 0; i < c.chain.size(); ++i) {
    sum += (c.map.vertex(c.chain[i]).T_M_I.translation() - c.T_true[i].translation()).squaredNorm();
  }
  return std::sqrt(sum / c.chain.size());
}

TEST_CASE("relax pulls a drifting circle back with its loop closures") {
  Circle c = MakeCircle();
  for (int a : {39, 38, 37}) {
    for (int b : {0, 1, 2}) AddLoop(&c, a, b, c.T_true[a].inverse() * c.T_true[b]);
  }
  const double before = Rmse(c);
  const RelaxSummary s = RelaxPoseGraph(RelaxOptions{}, &c.map);
  INFO(s.FullReport());
  CHECK(s.loop_terms == 9);
  CHECK(s.loops_switched_off == 0);
  const double after = Rmse(c);
  CHECK(before > 0.05);
  CHECK(after < 0.5 * before);  // the drift is systematic: the odometry terms keep part of it
  CHECK(c.map.vertex(c.chain[0]).T_M_I.translation() == c.T_true[0].translation());
  CHECK(mapstore::CheckMapConsistency(c.map).ok());
}

TEST_CASE("relax switches off a wrong loop closure, without loops it refuses") {
  Circle c = MakeCircle();
  CHECK_THROWS_WITH(RelaxPoseGraph(RelaxOptions{}, &c.map), Catch::Contains("no loop-closure"));
  for (int a : {39, 38, 37}) {
    for (int b : {0, 1, 2}) AddLoop(&c, a, b, c.T_true[a].inverse() * c.T_true[b]);
  }
  // A place that looked alike: vertex 20 "is" vertex 5.
  AddLoop(&c, 20, 5, Transformation());
  Circle clean = MakeCircle();
  for (int a : {39, 38, 37}) {
    for (int b : {0, 1, 2}) AddLoop(&clean, a, b, clean.T_true[a].inverse() * clean.T_true[b]);
  }
  RelaxPoseGraph(RelaxOptions{}, &clean.map);
  const RelaxSummary s = RelaxPoseGraph(RelaxOptions{}, &c.map);
  INFO(s.FullReport());
  CHECK(s.loops_switched_off == 1);
  CHECK(Rmse(c) < 1.1 * Rmse(clean) + 0.01);
  RelaxOptions bad;
  bad.relax_robust = "maybe";
  CHECK_THROWS_WITH(RelaxPoseGraph(bad, &c.map), Catch::Contains("relax_robust"));
}

}  // namespace
}  // namespace vilma::mapping
