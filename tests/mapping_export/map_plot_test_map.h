// A small VI-map with known geometry for the picture tests (map_plot_test, html_viewer_test):
// two anchored missions driving circles side by side, a loop-closure edge between them, and
// landmarks of each quality on two walls.
//
//   mission "alpha": T_G_M = identity; 40 vertices on a circle of radius 5 m around (0, 0),
//                    z = 1 + 0.2 sin(2 a) m.
//   mission "beta":  T_G_M = yaw +90 deg, p = (20, 0, 0); 40 vertices on a circle of radius 4 m
//                    around its origin, so around (20, 0) in G; z = 1.5 m.
//   loop closure:    beta vertex 10 (at (16, 0, 1.5) in G) -> alpha vertex 0 (at (5, 0, 1)).
//   landmarks:       on the walls y = +-9 m, x in [-8, 28], z in {0.5, 1.5, 2.5}, stored in
//                    alpha's vertex 0: every 7th bad, every 11th (not bad) unknown, else good.
#pragma once

#include <cmath>
#include <vector>

#include "mapstore/synthetic_map.h"
#include "vilma/mapstore/vi_map.h"

namespace vilma::mapping::testing {

struct PictureTestMap {
  mapstore::VIMap map;
  std::vector<std::vector<mapstore::VertexId>> vertices;  // per mission, in time order
  mapstore::EdgeId loop_id;
  std::size_t good = 0, bad = 0, unknown = 0;
};

inline PictureTestMap MakePictureTestMap() {
  using namespace mapstore;
  PictureTestMap out;
  IdGenerator mission_ids(42);
  const double kPi = std::acos(-1.0);
  for (int mi = 0; mi < 2; ++mi) {
    Mission mission;
    mission.id = mission_ids.Next();
    mission.name = mi == 0 ? "alpha" : "beta";
    mission.baseframe_known = true;
    mission.T_G_M =
        mi == 0 ? Transformation()
                : Transformation(
                      Eigen::Quaterniond(Eigen::AngleAxisd(kPi / 2, Eigen::Vector3d::UnitZ())),
                      Eigen::Vector3d(20, 0, 0));
    mission.rig = mapstore::testing::TestRig();
    mission.complete = true;
    out.map.AddMission(mission);
    IdGenerator ids = IdGenerator::ForMission(mission.id);
    out.vertices.emplace_back();
    const double radius = mi == 0 ? 5.0 : 4.0;
    for (int k = 0; k < 40; ++k) {
      const double a = 2 * kPi * k / 40;
      Vertex v;
      v.id = ids.Next();
      v.mission_id = mission.id;
      v.t_ns = 1'600'000'000'000'000'000LL + mi * 100'000'000'000LL + k * 250'000'000LL;
      const Eigen::Vector3d p_M(radius * std::cos(a), radius * std::sin(a),
                                mi == 0 ? 1.0 + 0.2 * std::sin(2 * a) : 1.5);
      v.T_M_I = Transformation(
          Eigen::Quaterniond(Eigen::AngleAxisd(a + kPi / 2, Eigen::Vector3d::UnitZ())), p_M);
      if (k == 0) out.map.mission(mission.id).root_vertex_id = v.id;
      out.vertices[mi].push_back(v.id);
      out.map.AddVertex(v);
      if (k > 0) {
        Edge e;
        e.id = ids.Next();
        e.type = EdgeType::kImu;
        e.from = out.vertices[mi][k - 1];
        e.to = v.id;
        out.map.AddEdge(e);
      }
    }
  }
  Edge loop;
  loop.id = IdGenerator::ForMission(out.map.mission_ids()[1]).Next();
  loop.id.lo ^= 0x1234;
  loop.type = EdgeType::kLoopClosure;
  loop.from = out.vertices[1][10];
  loop.to = out.vertices[0][0];
  loop.T_A_B = out.map.T_G_I(loop.from).inverse() * out.map.T_G_I(loop.to);
  loop.covariance = Matrix6d::Identity() * 1e-4;
  loop.switch_variable_variance = 1e-2;
  out.loop_id = loop.id;
  out.map.AddEdge(loop);

  IdGenerator landmark_ids(4242);
  const VertexId store = out.vertices[0][0];
  const Transformation T_I_G = out.map.T_G_I(store).inverse();
  int n = 0;
  for (double y : {-9.0, 9.0}) {
    for (double x = -8.0; x <= 28.0; x += 0.5) {
      for (double z : {0.5, 1.5, 2.5}) {
        Landmark l;
        l.id = landmark_ids.Next();
        l.store_vertex_id = store;
        l.p_I = T_I_G * Eigen::Vector3d(x, y, z);
        if (n % 7 == 0) {
          l.quality = LandmarkQuality::kBad;
          ++out.bad;
        } else if (n % 11 == 0) {
          l.quality = LandmarkQuality::kUnknown;
          ++out.unknown;
        } else {
          l.quality = LandmarkQuality::kGood;
          ++out.good;
        }
        out.map.AddLandmark(l);
        ++n;
      }
    }
  }
  return out;
}

}  // namespace vilma::mapping::testing
