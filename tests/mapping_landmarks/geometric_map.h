// A small VI-map with true geometry for the landmark tests: vertices 0.3 m apart along a line,
// landmarks 3-6 m in front of the first camera, keypoints their exact projections (plus seeded
// pixel noise), one feature track per landmark. A second mission (optional) sees the same
// landmarks from its own frame M1 (T_G_M1 != identity) through cross-mission observations.
#pragma once

#include <random>
#include <vector>

#include "mapstore/synthetic_map.h"
#include "test_random.h"
#include "vilma/mapstore/vi_map.h"

namespace vilma::mapping::testing {

struct GeometricMap {
  mapstore::VIMap map;
  std::vector<mapstore::LandmarkId> landmarks;  // in creation order
  std::vector<Eigen::Vector3d> p_G_true;        // parallel to `landmarks`
};

inline GeometricMap MakeGeometricMap(int vertices = 6, int landmarks = 40, double noise_px = 0.0,
                                     bool second_mission = false, uint64_t seed = 3) {
  std::mt19937_64 rng(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::normal_distribution<double> noise(0.0, noise_px > 0.0 ? noise_px : 1.0);
  GeometricMap g;
  const SensorRig rig = mapstore::testing::TestRig();
  const Transformation& T_I_C = rig.cameras[0].T_I_C;
  const Camera& camera = rig.cameras[0].camera;
  // The G-frame vertex poses: rotation fixed, moving along the camera's x axis.
  std::vector<Transformation> T_G_I;
  const Eigen::Vector3d step_G = T_I_C.rotation() * Eigen::Vector3d(0.3, 0.0, 0.0);
  for (int i = 0; i < vertices; ++i) {
    T_G_I.emplace_back(Eigen::Quaterniond::Identity(), step_G * static_cast<double>(i));
  }
  const Transformation T_G_C0 = T_G_I[0] * T_I_C;
  for (int j = 0; j < landmarks; ++j) {
    // z, y, x: the order GCC drew them in (tests/test_random.h).
    const double z = 4.5 + u(rng) * 1.5;
    const double y = u(rng) * 0.8;
    const double x = u(rng) * 1.2;
    g.p_G_true.push_back(T_G_C0 * Eigen::Vector3d(x, y, z));
  }
  const int missions = second_mission ? 2 : 1;
  mapstore::IdGenerator mission_ids(seed);
  std::vector<std::vector<mapstore::VertexId>> chains(missions);
  for (int mi = 0; mi < missions; ++mi) {
    mapstore::Mission mission;
    mission.id = mission_ids.Next();
    mission.name = "m" + std::to_string(mi);
    mission.rig = rig;
    mission.complete = true;
    mission.baseframe_known = mi == 0;
    if (mi == 1) {
      mission.T_G_M = Transformation(
          Eigen::Quaterniond(Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.2, 0.3, 1.0).normalized())),
          Eigen::Vector3d(4.0, -2.0, 0.5));
    }
    g.map.AddMission(mission);
    mapstore::IdGenerator ids = mapstore::IdGenerator::ForMission(mission.id);
    for (int i = 0; i < vertices; ++i) {
      mapstore::Vertex v;
      v.id = ids.Next();
      v.mission_id = mission.id;
      v.t_ns = 1'000'000'000LL * (mi * 100 + 1) + i * 100'000'000LL;
      // Mission 1's vertices are offset by 5 cm so that they are other cameras.
      v.T_M_I = mission.T_G_M.inverse() * T_G_I[i] *
                Transformation(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 0.05 * mi, 0));
      mapstore::VisualFrame f;
      const Transformation T_C_G = (mission.T_G_M * v.T_M_I * T_I_C).inverse();
      for (int j = 0; j < landmarks; ++j) {
        Eigen::Vector2d uv;
        if (camera.Project(T_C_G * g.p_G_true[j], &uv) != Camera::ProjectionResult::kValid) {
          continue;
        }
        if (noise_px > 0.0) uv += vilma::testing::DrawVector2([&] { return noise(rng); });
        mapstore::Keypoint kp;
        kp.uv = uv;
        f.keypoints.push_back(kp);
        f.track_ids.push_back(mi * 1000 + j);
        f.landmark_ids.emplace_back();
        f.descriptors.insert(f.descriptors.end(), 64, static_cast<uint8_t>(j));
      }
      v.frames.push_back(std::move(f));
      if (i == 0) g.map.mission(mission.id).root_vertex_id = v.id;
      chains[mi].push_back(v.id);
      g.map.AddVertex(std::move(v));
      if (i > 0) {
        mapstore::Edge e;
        e.id = ids.Next();
        e.type = mapstore::EdgeType::kImu;
        e.from = chains[mi][i - 1];
        e.to = chains[mi][i];
        for (int64_t t : {g.map.vertex(e.from).t_ns, g.map.vertex(e.to).t_ns}) {
          ImuSample s;
          s.t_ns = t;
          s.a_I = Eigen::Vector3d(0, 0, 9.81);
          e.imu_samples.push_back(s);
        }
        g.map.AddEdge(std::move(e));
      }
    }
  }
  // Landmark j stored in mission 0's first observer, observed by every keypoint of its track
  // (and of mission 1's track: cross-mission observations).
  mapstore::IdGenerator landmark_ids(seed + 1000);
  for (int j = 0; j < landmarks; ++j) {
    std::vector<mapstore::LandmarkObservation> observations;
    for (int mi = 0; mi < missions; ++mi) {
      for (const auto& vid : chains[mi]) {
        const auto& f = g.map.vertex(vid).frames[0];
        for (std::size_t k = 0; k < f.track_ids.size(); ++k) {
          if (f.track_ids[k] == mi * 1000 + j) {
            observations.push_back({vid, 0, static_cast<uint32_t>(k)});
          }
        }
      }
    }
    if (observations.empty()) continue;
    mapstore::Landmark l;
    l.id = landmark_ids.Next();
    l.store_vertex_id = observations.front().vertex_id;
    l.p_I = g.map.T_G_I(l.store_vertex_id).inverse() * g.p_G_true[j];
    g.map.AddLandmark(l);
    for (const auto& o : observations) g.map.AddObservation(l.id, o);
    g.landmarks.push_back(l.id);
  }
  // Keep p_G_true parallel to `landmarks` (a landmark no camera sees is skipped).
  std::vector<Eigen::Vector3d> kept;
  for (const auto& id : g.landmarks) {
    const Eigen::Vector3d p = g.map.LandmarkPosition_G(id);
    for (const auto& t : g.p_G_true) {
      if ((t - p).norm() < 1e-9) kept.push_back(t);
    }
  }
  g.p_G_true = kept;
  return g;
}

}  // namespace vilma::mapping::testing
