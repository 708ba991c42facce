#include "vilma/mapstore/stream/synthetic_mission.h"

#include <random>
#include <stdexcept>

namespace vilma {
namespace mapstore {
namespace {

// Three draws as a vector, z first. One statement per draw: C++ leaves the order of a call's
// arguments unspecified, and `Vector3d(n(rng), n(rng), n(rng))` made other missions under clang
// than under GCC; GCC's former order (last argument first) is kept, so the missions stay the same.
Eigen::Vector3d DrawVector3(std::normal_distribution<double>& normal, std::mt19937_64& rng) {
  Eigen::Vector3d v;
  v.z() = normal(rng);
  v.y() = normal(rng);
  v.x() = normal(rng);
  return v;
}

}  // namespace

std::string SyntheticMissionOptions::Validate() const {
  if (vertices < 0) return "vertices: expected >= 0";
  if (vertices_per_delta < 1) return "vertices_per_delta: expected >= 1";
  if (keypoints_per_frame < 0) return "keypoints_per_frame: expected >= 0";
  if (landmarks_per_vertex < 0 || landmarks_per_vertex > keypoints_per_frame) {
    return "landmarks_per_vertex: expected 0..keypoints_per_frame";
  }
  if (imu_samples_per_edge < 0) return "imu_samples_per_edge: expected >= 0";
  return "";
}

std::vector<MissionDelta> MakeSyntheticMissionDeltas(const SyntheticMissionOptions& o) {
  const std::string error = o.Validate();
  if (!error.empty()) throw std::invalid_argument("SyntheticMissionOptions: " + error);
  std::mt19937_64 rng(o.seed);
  std::normal_distribution<double> n(0.0, 1.0);
  std::uniform_int_distribution<int> byte(0, 255);

  Mission mission;
  mission.id = IdGenerator(o.seed).Next();
  mission.name = o.name;
  CameraConfig cam;
  cam.name = "cam0";
  cam.camera = Camera(752, 480, Eigen::Vector4d(458.654, 457.296, 367.215, 248.375),
                      DistortionModel::kRadTan,
                      Eigen::Vector4d(-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05));
  mission.rig.cameras.push_back(cam);
  IdGenerator ids = IdGenerator::ForMission(mission.id);

  std::vector<MissionDelta> deltas;
  VertexId previous;
  int64_t t_ns = 1'403'636'579'763'555'584LL;
  constexpr int64_t kVertexPeriodNs = 100'000'000;  // 10 Hz vertices
  for (int i = 0; i < o.vertices; ++i) {
    if (i % o.vertices_per_delta == 0) {
      deltas.emplace_back();
      deltas.back().mission = mission;
    }
    MissionDelta& delta = deltas.back();
    Vertex v;
    v.id = ids.Next();
    v.mission_id = mission.id;
    v.t_ns = t_ns;
    const double p_z = n(rng), p_y = n(rng);
    const Eigen::Vector3d q_xyz = DrawVector3(n, rng);
    v.T_M_I = Transformation(Eigen::Quaterniond(1.0, 0.01 * q_xyz.x(), 0.01 * q_xyz.y(), 0.01 * q_xyz.z()),
                             Eigen::Vector3d(0.1 * i, p_y, p_z));
    v.v_M = DrawVector3(n, rng);
    v.accel_bias = 0.01 * DrawVector3(n, rng);
    v.gyro_bias = 0.001 * DrawVector3(n, rng);
    VisualFrame frame;
    frame.keypoints.resize(o.keypoints_per_frame);
    frame.descriptors.resize(static_cast<std::size_t>(o.keypoints_per_frame) * frame.descriptor_size_bytes);
    frame.track_ids.resize(o.keypoints_per_frame);
    frame.landmark_ids.resize(o.keypoints_per_frame);
    for (int k = 0; k < o.keypoints_per_frame; ++k) {
      Keypoint& kp = frame.keypoints[k];
      const double v_px = 240.0 + 80.0 * n(rng);
      kp.uv = Eigen::Vector2d(376.0 + 100.0 * n(rng), v_px);
      kp.scale = 8.0 + n(rng);
      kp.orientation = n(rng);
      kp.score = 50.0 + n(rng);
      frame.track_ids[k] = static_cast<int64_t>(i) * 1000 + k;
    }
    for (uint8_t& b : frame.descriptors) b = static_cast<uint8_t>(byte(rng));
    for (int l = 0; l < o.landmarks_per_vertex; ++l) {
      Landmark lm;
      lm.id = ids.Next();
      lm.store_vertex_id = v.id;
      lm.p_I = DrawVector3(n, rng) + Eigen::Vector3d(0.0, 0.0, 3.0);
      lm.covariance = 0.01 * Eigen::Matrix3d::Identity();
      lm.quality = LandmarkQuality::kGood;
      lm.observations.push_back({v.id, 0u, static_cast<uint32_t>(l)});
      frame.landmark_ids[l] = lm.id;
      delta.landmarks.push_back(lm);
    }
    v.frames.push_back(std::move(frame));
    if (i == 0) {
      mission.root_vertex_id = v.id;
      for (MissionDelta& d : deltas) d.mission.root_vertex_id = v.id;
    } else {
      Edge e;
      e.id = ids.Next();
      e.type = EdgeType::kImu;
      e.from = previous;
      e.to = v.id;
      for (int s = 0; s <= o.imu_samples_per_edge; ++s) {
        if (o.imu_samples_per_edge == 0) break;
        ImuSample sample;
        // (s * period) / n, not s * (period / n): the last sample must fall on the vertex
        // time for any n (with n = 3 it ended 1 ns early, an edge check_map_consistency rejects).
        sample.t_ns = t_ns - kVertexPeriodNs + (s * kVertexPeriodNs) / o.imu_samples_per_edge;
        sample.omega_I = 0.1 * DrawVector3(n, rng);
        sample.a_I = DrawVector3(n, rng) + Eigen::Vector3d(0.0, 0.0, 9.81);
        e.imu_samples.push_back(sample);
      }
      delta.edges.push_back(std::move(e));
    }
    previous = v.id;
    // Vertex before its edge and landmarks: ApplyMissionDelta upserts vertices first.
    delta.vertices.push_back(std::move(v));
    t_ns += kVertexPeriodNs;
  }
  return deltas;
}

VIMap ApplyDeltas(const std::vector<MissionDelta>& deltas) {
  VIMap map;
  for (const MissionDelta& d : deltas) ApplyMissionDelta(d, &map);
  return map;
}

}  // namespace mapstore
}  // namespace vilma
