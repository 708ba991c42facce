// Deterministic synthetic VI-maps for the mapstore tests and the benchmark: random-looking but
// seeded values (odd bits in every double), landmarks observed by consecutive vertices, and
// optionally cross-mission observations and image resources.
#pragma once

#include <catch2/catch.hpp>

#include <cstring>
#include <random>
#include <string>

#include "test_random.h"
#include "vilma/mapstore/vi_map.h"

namespace vilma {
namespace mapstore {
namespace testing {

struct SyntheticMapOptions {
  int missions = 2;
  int vertices_per_mission = 12;
  int cameras = 2;
  int landmarks_per_vertex = 4;    // created (stored) at each vertex, camera 0
  int observations_per_landmark = 3;  // by consecutive vertices
  int imu_samples_per_edge = 6;
  bool cross_mission = true;       // missions > 0 also observe landmarks of mission 0
  bool images = false;             // a PNG-like resource per vertex and camera
  bool extra_edges = true;         // a loop closure, an odometry and a pose-prior edge
  uint64_t seed = 7;
};

inline SensorRig TestRig() {
  SensorRig rig;
  CameraConfig cam;
  cam.name = "cam0";
  cam.camera = Camera(752, 480, Eigen::Vector4d(458.654, 457.296, 367.215, 248.375),
                      DistortionModel::kRadTan,
                      Eigen::Vector4d(-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05));
  cam.T_I_C = Transformation(Eigen::Quaterniond(0.7123, -0.0077, 0.0105, 0.7018),
                             Eigen::Vector3d(-0.0216, -0.0647, 0.0098));
  rig.cameras.push_back(cam);
  cam.name = "cam1";
  rig.cameras.push_back(cam);
  return rig;
}

inline Transformation RandomPose(std::mt19937_64& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  const auto draw = [&] { return n(rng); };
  // The translation first, then the rotation: the order GCC drew them in (tests/test_random.h).
  const Eigen::Vector3d p = vilma::testing::DrawVector3(draw) * 3.0;
  return Transformation(vilma::testing::DrawQuaternion(draw), p);
}

template <int R, int C>
Eigen::Matrix<double, R, C> RandomMatrix(std::mt19937_64& rng) {
  std::normal_distribution<double> n(0.0, 1.0);
  Eigen::Matrix<double, R, C> m;
  for (int i = 0; i < m.size(); ++i) m.data()[i] = n(rng);
  return m;
}

inline VIMap MakeSyntheticMap(const SyntheticMapOptions& o) {
  std::mt19937_64 rng(o.seed);
  std::normal_distribution<double> n(0.0, 1.0);
  std::uniform_int_distribution<int> byte(0, 255);
  VIMap map;
  IdGenerator mission_ids(o.seed);
  std::vector<std::vector<VertexId>> vertices(o.missions);
  std::vector<std::vector<LandmarkId>> landmarks(o.missions);  // [vertex * per_vertex + j]
  const int kp_per_frame = o.landmarks_per_vertex * o.observations_per_landmark;
  for (int mi = 0; mi < o.missions; ++mi) {
    Mission mission;
    mission.id = mission_ids.Next();
    IdGenerator ids = IdGenerator::ForMission(mission.id);
    mission.name = "mission" + std::to_string(mi);
    mission.baseframe_known = mi == 0;
    mission.T_G_M = RandomPose(rng);
    mission.T_G_M_covariance = RandomMatrix<6, 6>(rng);
    mission.rig = TestRig();
    mission.complete = mi % 2 == 0;
    map.AddMission(mission);
    int64_t t_ns = 1'403'636'579'763'555'584LL + mi * 1'000'000'000'000LL;
    for (int vi = 0; vi < o.vertices_per_mission; ++vi) {
      Vertex v;
      v.id = ids.Next();
      v.mission_id = mission.id;
      v.t_ns = t_ns + vi * 100'000'000LL;
      v.T_M_I = RandomPose(rng);
      v.v_M = RandomMatrix<3, 1>(rng);
      v.accel_bias = RandomMatrix<3, 1>(rng) * 0.1;
      v.gyro_bias = RandomMatrix<3, 1>(rng) * 0.01;
      for (int c = 0; c < o.cameras; ++c) {
        VisualFrame f;
        const int k = c == 0 ? kp_per_frame + ((o.cross_mission && mi > 0) ? 1 : 0) : 5;
        for (int i = 0; i < k; ++i) {
          Keypoint kp;
          const double y = std::abs(n(rng)) * 200;  // y before x, as GCC drew them
          const double x = std::abs(n(rng)) * 300;
          kp.uv = Eigen::Vector2d(x, y);
          kp.scale = 8.0 + n(rng);
          kp.orientation = n(rng);
          kp.score = std::abs(n(rng)) * 50;
          // Per-keypoint noise, varied without drawing from rng (the other values stay as they
          // were); camera 1 keeps the default (a frame without the optional field).
          if (c == 0) kp.sigma_px = 0.1 + 0.05 * ((vi + i) % 5);
          f.keypoints.push_back(kp);
          f.track_ids.push_back(i % 7 == 6 ? -1 : vi * 1000 + i);
          for (int b = 0; b < 64; ++b) f.descriptors.push_back(static_cast<uint8_t>(byte(rng)));
        }
        f.landmark_ids.assign(k, LandmarkId());
        if (o.images) {
          f.image_resource_id = ids.Next();
          std::string bytes = "\x89PNG fake " + std::to_string(vi) + "/" + std::to_string(c);
          bytes.append(200 + 37 * vi, static_cast<char>('a' + c));
          map.resources().Add(ResourceType::kImage, f.image_resource_id, "png", bytes);
          if (c == 0) {  // a depth map beside the first camera's image
            f.depth_resource_id = ids.Next();
            map.resources().Add(ResourceType::kDepthMap, f.depth_resource_id, "vdepth",
                                "vilma-depth fake " + std::to_string(vi));
          }
        }
        v.frames.push_back(std::move(f));
      }
      if (vi == 0) map.mission(mission.id).root_vertex_id = v.id;
      vertices[mi].push_back(v.id);
      map.AddVertex(std::move(v));
      if (vi > 0) {
        Edge e;
        e.id = ids.Next();
        e.type = EdgeType::kImu;
        e.from = vertices[mi][vi - 1];
        e.to = vertices[mi][vi];
        const int64_t t0 = map.vertex(e.from).t_ns, t1 = map.vertex(e.to).t_ns;
        for (int s = 0; s < o.imu_samples_per_edge; ++s) {
          ImuSample sample;
          sample.t_ns = t0 + (t1 - t0) * s / (o.imu_samples_per_edge - 1);
          sample.omega_I = RandomMatrix<3, 1>(rng);
          sample.a_I = RandomMatrix<3, 1>(rng) + Eigen::Vector3d(0, 0, 9.81);
          e.imu_samples.push_back(sample);
        }
        map.AddEdge(std::move(e));
      }
    }
    // Landmark (s, j) is stored at vertex s and seen by vertex s + d at keypoint
    // j * observations + d of camera 0.
    for (int s = 0; s < o.vertices_per_mission; ++s) {
      for (int j = 0; j < o.landmarks_per_vertex; ++j) {
        Landmark l;
        l.id = ids.Next();
        l.store_vertex_id = vertices[mi][s];
        l.p_I = RandomMatrix<3, 1>(rng) * 5.0;
        l.covariance = RandomMatrix<3, 3>(rng);
        l.quality = static_cast<LandmarkQuality>(j % 3);
        map.AddLandmark(l);
        landmarks[mi].push_back(l.id);
        for (int d = 0; d < o.observations_per_landmark && s + d < o.vertices_per_mission; ++d) {
          map.AddObservation(l.id, {vertices[mi][s + d], 0,
                                    static_cast<uint32_t>(j * o.observations_per_landmark + d)});
        }
      }
    }
    if (o.cross_mission && mi > 0) {
      // The last keypoint of camera 0 sees landmark 0 of mission 0's vertex with the same index.
      for (int vi = 0; vi < o.vertices_per_mission; ++vi) {
        const int s = std::min(vi, o.vertices_per_mission - 1);
        map.AddObservation(landmarks[0][s * o.landmarks_per_vertex],
                           {vertices[mi][vi], 0, static_cast<uint32_t>(kp_per_frame)});
      }
    }
    if (o.extra_edges && o.vertices_per_mission >= 3) {
      Edge prior;
      prior.id = ids.Next();
      prior.type = EdgeType::kPosePrior;
      prior.from = prior.to = vertices[mi][0];
      prior.T_A_B = RandomPose(rng);
      prior.covariance = RandomMatrix<6, 6>(rng);
      map.AddEdge(prior);
      Edge odom;
      odom.id = ids.Next();
      odom.type = EdgeType::kOdometry;
      odom.from = vertices[mi][1];
      odom.to = vertices[mi][2];
      odom.T_A_B = RandomPose(rng);
      odom.covariance = RandomMatrix<6, 6>(rng);
      map.AddEdge(odom);
    }
  }
  if (o.extra_edges && o.missions >= 2) {
    Edge loop;
    loop.id = IdGenerator::ForMission(map.mission_ids()[1]).Next();
    loop.id.lo ^= 0x5a5a;  // distinct from the mission's own stream
    loop.type = EdgeType::kLoopClosure;
    loop.from = vertices[1].back();
    loop.to = vertices[0].front();
    loop.T_A_B = RandomPose(rng);
    loop.covariance = RandomMatrix<6, 6>(rng);
    loop.switch_variable = 0.8125 + n(rng) * 1e-3;
    loop.switch_variable_variance = 0.0123;
    map.AddEdge(loop);
  }
  return map;
}

inline bool BitEqual(const double* a, const double* b, std::size_t n) {
  return std::memcmp(a, b, n * sizeof(double)) == 0;
}
template <typename A, typename B>
bool BitEqual(const Eigen::MatrixBase<A>& a, const Eigen::MatrixBase<B>& b) {
  typename A::PlainObject pa = a;
  typename B::PlainObject pb = b;
  return pa.size() == pb.size() && BitEqual(pa.data(), pb.data(), pa.size());
}
inline bool BitEqual(const Transformation& a, const Transformation& b) {
  return BitEqual(a.rotation().coeffs(), b.rotation().coeffs()) &&
         BitEqual(a.translation(), b.translation());
}
inline bool BitEqual(double a, double b) { return BitEqual(&a, &b, 1); }

// Every element of `b` equals `a` bit for bit (and in the same order).
inline void RequireMapsEqual(const VIMap& a, const VIMap& b) {
  REQUIRE(a.mission_ids() == b.mission_ids());
  for (const MissionId& mid : a.mission_ids()) {
    const Mission& ma = a.mission(mid);
    const Mission& mb = b.mission(mid);
    CHECK(ma.name == mb.name);
    CHECK(ma.baseframe_known == mb.baseframe_known);
    CHECK(BitEqual(ma.T_G_M, mb.T_G_M));
    CHECK(BitEqual(ma.T_G_M_covariance, mb.T_G_M_covariance));
    CHECK(ma.root_vertex_id == mb.root_vertex_id);
    CHECK(ma.complete == mb.complete);
    REQUIRE(ma.rig.cameras.size() == mb.rig.cameras.size());
    for (std::size_t c = 0; c < ma.rig.cameras.size(); ++c) {
      CHECK(ma.rig.cameras[c].name == mb.rig.cameras[c].name);
      CHECK(ma.rig.cameras[c].camera.fx() == mb.rig.cameras[c].camera.fx());
      CHECK(BitEqual(ma.rig.cameras[c].T_I_C, mb.rig.cameras[c].T_I_C));
    }
    REQUIRE(a.vertex_ids(mid) == b.vertex_ids(mid));
    REQUIRE(a.edge_ids(mid) == b.edge_ids(mid));
    REQUIRE(a.landmark_ids(mid) == b.landmark_ids(mid));
    for (const VertexId& id : a.vertex_ids(mid)) {
      const Vertex& va = a.vertex(id);
      const Vertex& vb = b.vertex(id);
      REQUIRE(va.mission_id == vb.mission_id);
      REQUIRE(va.t_ns == vb.t_ns);
      REQUIRE(BitEqual(va.T_M_I, vb.T_M_I));
      REQUIRE(BitEqual(va.v_M, vb.v_M));
      REQUIRE(BitEqual(va.accel_bias, vb.accel_bias));
      REQUIRE(BitEqual(va.gyro_bias, vb.gyro_bias));
      REQUIRE(va.frames.size() == vb.frames.size());
      for (std::size_t c = 0; c < va.frames.size(); ++c) {
        const VisualFrame& fa = va.frames[c];
        const VisualFrame& fb = vb.frames[c];
        REQUIRE(fa.keypoints.size() == fb.keypoints.size());
        for (std::size_t k = 0; k < fa.keypoints.size(); ++k) {
          REQUIRE(BitEqual(fa.keypoints[k].uv, fb.keypoints[k].uv));
          REQUIRE(BitEqual(fa.keypoints[k].scale, fb.keypoints[k].scale));
          REQUIRE(BitEqual(fa.keypoints[k].orientation, fb.keypoints[k].orientation));
          REQUIRE(BitEqual(fa.keypoints[k].score, fb.keypoints[k].score));
          REQUIRE(BitEqual(fa.keypoints[k].sigma_px, fb.keypoints[k].sigma_px));
        }
        REQUIRE(fa.descriptor_type == fb.descriptor_type);
        REQUIRE(fa.descriptor_size_bytes == fb.descriptor_size_bytes);
        REQUIRE(fa.descriptors == fb.descriptors);
        REQUIRE(fa.track_ids == fb.track_ids);
        REQUIRE(fa.landmark_ids == fb.landmark_ids);
        REQUIRE(fa.image_resource_id == fb.image_resource_id);
        REQUIRE(fa.depth_resource_id == fb.depth_resource_id);
      }
    }
    for (const EdgeId& id : a.edge_ids(mid)) {
      const Edge& ea = a.edge(id);
      const Edge& eb = b.edge(id);
      REQUIRE(ea.type == eb.type);
      REQUIRE(ea.from == eb.from);
      REQUIRE(ea.to == eb.to);
      REQUIRE(ea.imu_samples.size() == eb.imu_samples.size());
      for (std::size_t s = 0; s < ea.imu_samples.size(); ++s) {
        REQUIRE(ea.imu_samples[s].t_ns == eb.imu_samples[s].t_ns);
        REQUIRE(BitEqual(ea.imu_samples[s].omega_I, eb.imu_samples[s].omega_I));
        REQUIRE(BitEqual(ea.imu_samples[s].a_I, eb.imu_samples[s].a_I));
      }
      REQUIRE(BitEqual(ea.T_A_B, eb.T_A_B));
      REQUIRE(BitEqual(ea.covariance, eb.covariance));
      REQUIRE(BitEqual(ea.switch_variable, eb.switch_variable));
      REQUIRE(BitEqual(ea.switch_variable_variance, eb.switch_variable_variance));
    }
    for (const LandmarkId& id : a.landmark_ids(mid)) {
      const Landmark& la = a.landmark(id);
      const Landmark& lb = b.landmark(id);
      REQUIRE(la.store_vertex_id == lb.store_vertex_id);
      REQUIRE(BitEqual(la.p_I, lb.p_I));
      REQUIRE(BitEqual(la.covariance, lb.covariance));
      REQUIRE(la.quality == lb.quality);
      REQUIRE(la.observations == lb.observations);
    }
  }
}

}  // namespace testing
}  // namespace mapstore
}  // namespace vilma
