// A one-mission VI-map with exact visual-inertial geometry for the optimization tests: a
// simulator trajectory in the room (M = W), a vertex every 0.1 s with its true pose, velocity and
// zero biases, IMU edges from the simulator's noise-free IMU (200 Hz), and landmarks placed
// 2-5 m in front of every 5th vertex's camera, observed by the vertices within 1 s that see them
// (exact projections plus optional pixel noise). Every landmark is good. With `imu_sim` the IMU
// samples are drawn with those options (noise, random walk, turn-on biases) instead of exactly,
// and the vertices carry the true biases; `samples_per_vertex` sets the vertex spacing.
#pragma once

#include <random>
#include <vector>

#include "mapstore/synthetic_map.h"
#include "test_random.h"
#include "vilma/mapstore/vi_map.h"
#include "vilma/sim/imu_sim.h"
#include "vilma/sim/random.h"
#include "vilma/sim/world.h"

namespace vilma::mapping::testing {

struct SimulatedViMap {
  mapstore::VIMap map;
  std::vector<GroundTruthState> ground_truth;  // at every IMU sample
  std::vector<Transformation> T_M_I_true;      // per vertex, chain order
  std::vector<Eigen::Vector3d> p_M_true;       // per landmark, landmark_ids order
};

inline SimulatedViMap MakeSimulatedViMap(double seconds = 4.0, double noise_px = 0.0,
                                         uint64_t seed = 5,
                                         const sim::ImuSimOptions* imu_sim = nullptr,
                                         std::size_t samples_per_vertex = 20) {
  SimulatedViMap s;
  const sim::World world = sim::MakePresetWorld("room", 1);
  sim::TrajectoryOptions t;
  t.duration_s = seconds + 1.0;
  t.static_start_s = 0.3;
  const sim::Trajectory trajectory = sim::GenerateTrajectory(world, t, seed);
  const sim::ImuSimOptions imu_options =
      imu_sim != nullptr ? *imu_sim : sim::ImuSimOptions::NoiseFree();
  sim::Rng rng(seed);
  const int64_t t0 = 1'000'000'000LL;
  const sim::ImuSimResult imu = sim::SimulateImu(trajectory, t0, seconds, imu_options, &rng);
  s.ground_truth = imu.ground_truth;

  mapstore::Mission mission;
  mission.id = mapstore::IdGenerator(seed).Next();
  mission.name = "sim";
  mission.rig = mapstore::testing::TestRig();
  mission.rig.cameras.resize(1);
  mission.complete = true;
  s.map.AddMission(mission);
  mapstore::IdGenerator ids = mapstore::IdGenerator::ForMission(mission.id);
  const Transformation T_I_C = mission.rig.cameras[0].T_I_C;
  const Camera& camera = mission.rig.cameras[0].camera;

  // Vertices every samples_per_vertex samples (20: 0.1 s), IMU edges holding the samples
  // between them.
  std::vector<mapstore::VertexId> chain;
  const std::size_t step = samples_per_vertex;
  for (std::size_t k = 0; k < imu.samples.size(); k += step) {
    const GroundTruthState& g = imu.ground_truth[k];
    mapstore::Vertex v;
    v.id = ids.Next();
    v.mission_id = mission.id;
    v.t_ns = g.t_ns;
    v.T_M_I = Transformation(g.q_W_I, g.p_W_I);
    v.v_M = g.v_W;
    v.gyro_bias = g.b_g;
    v.accel_bias = g.b_a;
    v.frames.emplace_back();
    s.T_M_I_true.push_back(v.T_M_I);
    if (chain.empty()) s.map.mission(mission.id).root_vertex_id = v.id;
    chain.push_back(v.id);
    s.map.AddVertex(std::move(v));
    if (chain.size() > 1) {
      mapstore::Edge e;
      e.id = ids.Next();
      e.type = mapstore::EdgeType::kImu;
      e.from = chain[chain.size() - 2];
      e.to = chain.back();
      e.imu_samples.assign(imu.samples.begin() + static_cast<long>(k - step),
                           imu.samples.begin() + static_cast<long>(k + 1));
      s.map.AddEdge(std::move(e));
    }
  }

  // Landmarks in front of every 5th vertex's camera; keypoints in the vertices within 1 s.
  std::mt19937_64 gen(seed);
  std::uniform_real_distribution<double> u(-1.0, 1.0);
  std::normal_distribution<double> noise(0.0, 1.0);
  struct Pending {
    Eigen::Vector3d p_M;
    std::vector<std::pair<std::size_t, Eigen::Vector2d>> seen;  // vertex index, uv
  };
  std::vector<Pending> pending;
  for (std::size_t a = 0; a < chain.size(); a += 5) {
    const Transformation T_M_C = s.T_M_I_true[a] * T_I_C;
    for (int j = 0; j < 12; ++j) {
      Pending p;
      // The depth first, then y and x: the order GCC drew them in (tests/test_random.h).
      const double depth = 3.5 + 1.5 * u(gen);
      const double y = u(gen);
      const double x = u(gen) * 1.5;
      p.p_M = T_M_C * (Eigen::Vector3d(x, y, 1.0) * depth);
      for (std::size_t b = (a >= 10 ? a - 10 : 0); b < chain.size() && b <= a + 10; ++b) {
        Eigen::Vector2d uv;
        const Eigen::Vector3d p_C = (s.T_M_I_true[b] * T_I_C).inverse() * p.p_M;
        if (camera.Project(p_C, &uv) != Camera::ProjectionResult::kValid) continue;
        if (noise_px > 0) uv += noise_px * vilma::testing::DrawVector2([&] { return noise(gen); });
        p.seen.emplace_back(b, uv);
      }
      if (p.seen.size() >= 4) pending.push_back(p);
    }
  }
  // Keypoints first (frames are parallel arrays), then landmarks and observations.
  std::vector<std::vector<uint32_t>> keypoint_of(pending.size());
  for (std::size_t l = 0; l < pending.size(); ++l) {
    for (const auto& [b, uv] : pending[l].seen) {
      mapstore::VisualFrame& f = s.map.vertex(chain[b]).frames[0];
      mapstore::Keypoint kp;
      kp.uv = uv;
      keypoint_of[l].push_back(static_cast<uint32_t>(f.keypoints.size()));
      f.keypoints.push_back(kp);
      f.track_ids.push_back(static_cast<int64_t>(l));
      f.landmark_ids.emplace_back();
      f.descriptors.insert(f.descriptors.end(), 64, static_cast<uint8_t>(l));
    }
  }
  for (std::size_t l = 0; l < pending.size(); ++l) {
    mapstore::Landmark landmark;
    landmark.id = ids.Next();
    landmark.store_vertex_id = chain[pending[l].seen.front().first];
    landmark.p_I = s.T_M_I_true[pending[l].seen.front().first].inverse() * pending[l].p_M;
    landmark.quality = mapstore::LandmarkQuality::kGood;
    const mapstore::LandmarkId id = landmark.id;
    s.map.AddLandmark(std::move(landmark));
    for (std::size_t k = 0; k < pending[l].seen.size(); ++k) {
      s.map.AddObservation(id, {chain[pending[l].seen[k].first], 0, keypoint_of[l][k]});
    }
    s.p_M_true.push_back(pending[l].p_M);
  }
  return s;
}

}  // namespace vilma::mapping::testing
