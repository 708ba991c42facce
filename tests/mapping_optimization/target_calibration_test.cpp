// optvi with held landmarks (a calibration target): the landmarks do not move, the extrinsics,
// the camera time offset and the baseframe tilt are recovered on exact simulated geometry
// (docs/optimization.md "Target calibration").
#include <catch2/catch.hpp>

#include <algorithm>
#include <cmath>

#include "mapping_optimization/simulated_vi_map.h"
#include "vilma/mapping/optimization/vi_optimization.h"
#include "vilma/mapstore/consistency.h"

namespace vilma::mapping {
namespace {

using testing::MakeSimulatedViMap;
using testing::SimulatedViMap;

constexpr double kDeg = M_PI / 180.0;

ViOptimizationOptions TargetOptions() {
  ViOptimizationOptions o;
  o.ba_fix_landmarks = true;
  o.ba_fix_extrinsics = false;
  o.evaluate_quality = false;
  o.ba_outlier_rejection = false;
  o.ba_num_iterations = 30;
  return o;
}

// Re-projects every observation from the true pose `samples_later` IMU samples (5 ms each)
// after its vertex: a camera whose exposure lies that much after the vertex time.
void DelayObservations(SimulatedViMap* s, int samples_later) {
  const mapstore::MissionId m = s->map.mission_ids()[0];
  const std::vector<mapstore::VertexId> chain = s->map.VertexChain(m);
  const CameraConfig& cam = s->map.mission(m).rig.cameras[0];
  std::vector<std::pair<mapstore::LandmarkId, mapstore::LandmarkObservation>> beyond;
  for (const mapstore::LandmarkId& lid : s->map.landmark_ids(m)) {
    const Eigen::Vector3d p_M = s->map.LandmarkPosition_G(lid);
    for (const mapstore::LandmarkObservation& o : s->map.landmark(lid).observations) {
      const std::size_t i = static_cast<std::size_t>(
          std::find(chain.begin(), chain.end(), o.vertex_id) - chain.begin());
      const std::size_t sample = 20 * i + static_cast<std::size_t>(samples_later);
      if (sample >= s->ground_truth.size()) {  // the last vertex: no truth that late
        beyond.emplace_back(lid, o);
        continue;
      }
      const GroundTruthState& g = s->ground_truth[sample];
      const Transformation T_M_C = Transformation(g.q_W_I, g.p_W_I) * cam.T_I_C;
      Eigen::Vector2d uv;
      cam.camera.Project(T_M_C.inverse() * p_M, &uv);
      s->map.vertex(o.vertex_id).frames[o.camera].keypoints[o.keypoint].uv = uv;
    }
  }
  for (const auto& [lid, o] : beyond) s->map.RemoveObservation(lid, o);
}

TEST_CASE("optvi with held landmarks: they do not move, and the extrinsics come back") {
  SimulatedViMap s = MakeSimulatedViMap(4.0, 0.0, 7);
  const mapstore::MissionId m = s.map.mission_ids()[0];
  std::vector<Eigen::Vector3d> p_G_before;
  for (const auto& lid : s.map.landmark_ids(m)) p_G_before.push_back(s.map.LandmarkPosition_G(lid));
  const Transformation T_I_C_true = s.map.mission(m).rig.cameras[0].T_I_C;
  const Transformation perturbation(ExpSO3(Eigen::Vector3d(1.0, -1.0, 1.0).normalized() * 2 * kDeg),
                                    Eigen::Vector3d(0.012, -0.01, 0.011));
  s.map.mission(m).rig.cameras[0].T_I_C = perturbation * T_I_C_true;
  // The landmarks are stored in their vertices: moving the vertices must not move them.
  for (const auto& vid : s.map.vertex_ids(m)) {
    s.map.vertex(vid).T_M_I = Transformation(s.map.vertex(vid).T_M_I.rotation(),
                                             s.map.vertex(vid).T_M_I.translation() +
                                                 Eigen::Vector3d(0.01, -0.005, 0.004));
  }
  std::size_t k = 0;
  for (const auto& lid : s.map.landmark_ids(m)) {
    mapstore::Landmark& l = s.map.landmark(lid);
    l.p_I = s.map.T_G_I(l.store_vertex_id).inverse() * p_G_before[k++];
  }

  const ViOptimizationSummary summary = OptimizeViMap(TargetOptions(), &s.map);
  INFO(summary.FullReport());
  k = 0;
  double moved = 0.0;
  for (const auto& lid : s.map.landmark_ids(m)) {
    moved = std::max(moved, (s.map.LandmarkPosition_G(lid) - p_G_before[k++]).norm());
  }
  CHECK(moved < 1e-9);
  const Transformation& T_I_C = s.map.mission(m).rig.cameras[0].T_I_C;
  CHECK((T_I_C.translation() - T_I_C_true.translation()).norm() < 1e-3);
  CHECK(AngleBetween(T_I_C.rotation(), T_I_C_true.rotation()) < 0.02 * kDeg);
  REQUIRE(summary.cameras.size() == 1);
  CHECK(AngleBetween(summary.cameras[0].T_I_C_before.rotation(), T_I_C_true.rotation()) >
        1.9 * kDeg);
  // No vertex was held: the landmarks fix the frame, so the shifted vertices come back too.
  const std::vector<mapstore::VertexId> chain = s.map.VertexChain(m);
  CHECK((s.map.vertex(chain.front()).T_M_I.translation() - s.T_M_I_true.front().translation())
            .norm() < 1e-3);
  CHECK(mapstore::CheckMapConsistency(s.map).ok());
}

TEST_CASE("optvi estimates a camera time offset (5 ms) from held landmarks") {
  SimulatedViMap s = MakeSimulatedViMap(4.0, 0.0, 9);
  DelayObservations(&s, 1);  // exposures 5 ms after the vertex times
  ViOptimizationOptions o = TargetOptions();
  o.ba_fix_extrinsics = true;
  mapstore::VIMap plain = s.map.Clone();
  const ViOptimizationSummary without = OptimizeViMap(o, &plain);
  o.ba_estimate_time_offset = true;
  mapstore::VIMap copy = s.map.Clone();
  const ViOptimizationSummary with = OptimizeViMap(o, &copy);
  INFO(with.FullReport());
  REQUIRE(with.cameras.size() == 1);
  CHECK(with.cameras[0].time_offset_before_s == 0.0);
  CHECK(std::abs(with.cameras[0].time_offset_after_s - 0.005) < 2e-4);
  CHECK(with.reprojection_rmse_after_px < 0.1);
  CHECK(without.reprojection_rmse_after_px > 3 * with.reprojection_rmse_after_px);
  // The rig is not changed (the vertex times were made with its offset).
  CHECK(copy.mission(copy.mission_ids()[0]).rig.cameras[0].time_offset_ns == 0);
}

TEST_CASE("optvi estimates the tilt of a baseframe whose G is fixed by held landmarks") {
  SimulatedViMap s = MakeSimulatedViMap(4.0, 0.0, 11);
  const mapstore::MissionId m = s.map.mission_ids()[0];
  // G: a frame tilted 20 deg against gravity (a target on a slanted board); M the true
  // gravity-aligned mission frame.
  const Transformation T_G_M_true(ExpSO3(Eigen::Vector3d(20 * kDeg, 5 * kDeg, 30 * kDeg)),
                                  Eigen::Vector3d(0.5, -1.0, 2.0));
  std::vector<Eigen::Vector3d> p_G;
  for (const Eigen::Vector3d& p_M : s.p_M_true) p_G.push_back(T_G_M_true * p_M);
  std::vector<Transformation> T_G_I;
  for (const Transformation& T : s.T_M_I_true) T_G_I.push_back(T_G_M_true * T);
  // The start: a baseframe whose gravity is 1.5 deg off, the poses and landmarks right in G.
  const Transformation T_G_M_start(
      T_G_M_true.rotation() * ExpSO3(Eigen::Vector3d(1.0, -0.6, 0.0).normalized() * 1.5 * kDeg),
      T_G_M_true.translation());
  s.map.mission(m).T_G_M = T_G_M_start;
  s.map.mission(m).baseframe_known = false;
  const std::vector<mapstore::VertexId> chain = s.map.VertexChain(m);
  for (std::size_t i = 0; i < chain.size(); ++i) {
    mapstore::Vertex& v = s.map.vertex(chain[i]);
    v.T_M_I = T_G_M_start.inverse() * T_G_I[i];
    v.v_M = T_G_M_start.rotation().inverse() * (T_G_M_true.rotation() * v.v_M);
  }
  std::size_t k = 0;
  for (const auto& lid : s.map.landmark_ids(m)) {
    mapstore::Landmark& l = s.map.landmark(lid);
    l.p_I = s.map.T_G_I(l.store_vertex_id).inverse() * p_G[k++];
  }
  ViOptimizationOptions o = TargetOptions();
  o.ba_fix_extrinsics = true;
  o.ba_estimate_baseframe_tilt = true;
  const ViOptimizationSummary summary = OptimizeViMap(o, &s.map);
  INFO(summary.FullReport());
  const Transformation& T_G_M = s.map.mission(m).T_G_M;
  // Gravity (M's z) in G is back; yaw and position of the baseframe are held.
  const double tilt_error =
      std::acos(std::clamp((T_G_M.rotation() * Eigen::Vector3d::UnitZ())
                               .dot(T_G_M_true.rotation() * Eigen::Vector3d::UnitZ()),
                           -1.0, 1.0));
  CHECK(tilt_error < 0.01 * kDeg);
  CHECK(summary.baseframe_tilt_change_deg > 1.4);
  CHECK((T_G_M.translation() - T_G_M_start.translation()).norm() < 1e-12);
  double worst = 0.0;
  for (std::size_t i = 0; i < chain.size(); ++i) {
    worst = std::max(worst, (s.map.T_G_I(chain[i]).translation() - T_G_I[i].translation()).norm());
  }
  CHECK(worst < 2e-3);
}

TEST_CASE("time offset and tilt options: invalid combinations are rejected, the map untouched") {
  SimulatedViMap s = MakeSimulatedViMap(2.0, 0.0, 13);
  ViOptimizationOptions o;
  o.ba_estimate_baseframe_tilt = true;  // without held landmarks
  CHECK(o.Validate().find("ba_estimate_baseframe_tilt") != std::string::npos);
  CHECK_THROWS_AS(OptimizeViMap(o, &s.map), std::invalid_argument);
  ViOptimizationOptions v;
  v.inertial = false;
  v.ba_estimate_time_offset = true;  // optv: no velocities, no gyroscope
  CHECK(v.Validate().find("ba_estimate_time_offset") != std::string::npos);
}

}  // namespace
}  // namespace vilma::mapping
