// A VI-map from a dataset and given poses: interpolation, the seeded perturbation, and maps of
// a simulated stereo session (exact poses: sub-pixel landmarks) and of the real EuRoC
// keyframes (wide baselines, revisits).
#include <catch2/catch.hpp>

#include <algorithm>
#include <filesystem>

#include "integration/process_util.h"
#include "vilma/core/rig.h"
#include "vilma/mapping/from_poses/map_from_poses.h"
#include "vilma/mapstore/consistency.h"
#include "test_skip.h"

namespace vilma::mapping {
namespace {

namespace fs = std::filesystem;

// Reprojection errors [px] of every observation of the map's good landmarks.
std::vector<double> ReprojectionErrors(const mapstore::VIMap& map) {
  std::vector<double> errors;
  for (const mapstore::MissionId& mission_id : map.mission_ids()) {
    const SensorRig& rig = map.mission(mission_id).rig;
    for (const mapstore::LandmarkId& id : map.landmark_ids(mission_id)) {
      const mapstore::Landmark& l = map.landmark(id);
      if (l.quality != mapstore::LandmarkQuality::kGood) continue;
      const Eigen::Vector3d p_M = map.LandmarkPosition_M(id);
      for (const mapstore::LandmarkObservation& o : l.observations) {
        const mapstore::Vertex& v = map.vertex(o.vertex_id);
        const Transformation T_C_M = (v.T_M_I * rig.cameras[o.camera].T_I_C).inverse();
        Eigen::Vector2d uv;
        rig.cameras[o.camera].camera.Project(T_C_M * p_M, &uv);
        errors.push_back((uv - v.frames[o.camera].keypoints[o.keypoint].uv).norm());
      }
    }
  }
  return errors;
}

double Median(std::vector<double> v) {
  REQUIRE_FALSE(v.empty());
  std::nth_element(v.begin(), v.begin() + v.size() / 2, v.end());
  return v[v.size() / 2];
}

TEST_CASE("InterpolatePose: exact samples, slerp between, refuses outside and across gaps") {
  Trajectory t;
  t.Add(0, Transformation(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 0, 0)));
  t.Add(100, Transformation(Eigen::Quaterniond(Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitZ())),
                            Eigen::Vector3d(1, 0, 0)));
  t.Add(10000, Transformation(Eigen::Quaterniond::Identity(), Eigen::Vector3d(2, 0, 0)));
  Transformation T;
  REQUIRE(InterpolatePose(t, 50, 60, &T));
  CHECK(T.translation().x() == Approx(0.5));
  CHECK(Eigen::AngleAxisd(T.rotation()).angle() == Approx(0.1));
  REQUIRE(InterpolatePose(t, 100, 0, &T));
  CHECK(T.translation().x() == 1.0);
  CHECK_FALSE(InterpolatePose(t, -1, 1000, &T));
  CHECK_FALSE(InterpolatePose(t, 10001, 1000, &T));
  CHECK_FALSE(InterpolatePose(t, 5000, 1000, &T));  // 4900 ns from either sample
}

TEST_CASE("PerturbationForVertex: exact magnitudes, seeded directions") {
  for (std::size_t i = 0; i < 20; ++i) {
    const Transformation d = PerturbationForVertex(3, i, 0.2, 3.0);
    CHECK(d.translation().norm() == Approx(0.2));
    CHECK(Eigen::AngleAxisd(d.rotation()).angle() * 180.0 / M_PI == Approx(3.0));
    const Transformation again = PerturbationForVertex(3, i, 0.2, 3.0);
    CHECK(again.translation() == d.translation());
  }
  CHECK(PerturbationForVertex(3, 0, 0.2, 3.0).translation() !=
        PerturbationForVertex(4, 0, 0.2, 3.0).translation());
  MapFromPosesOptions o;
  o.perturb_rotation_deg = 200;
  CHECK_THAT(o.Validate(), Catch::StartsWith("perturb_rotation_deg"));
}

TEST_CASE("a simulated stereo session with its true poses: consistent map, sub-pixel landmarks") {
  const std::string dir = std::string(VILMA_BINARY_DIR) + "/test-cache/map_from_poses";
  fs::remove_all(dir);
  fs::create_directories(dir);
  test::ChildProcess sim({std::string(VILMA_BINARY_DIR) + "/bin/vilma-sim", "room", "--out",
                          dir + "/room", "--seconds", "4", "--seed", "5", "--stereo"},
                         dir + "/sim.out");
  REQUIRE(sim.Wait(120.0) == 0);
  const SensorRig rig = LoadSensorRig(dir + "/room/rig.yaml");
  REQUIRE(rig.cameras.size() == 2);
  const Trajectory gt =
      ReadTrajectoryFile(dir + "/room/mav0/state_groundtruth_estimate0/data.csv");
  MapFromPosesOptions options;
  options.every_nth_frame = 6;  // 0.3 s apart: wide baselines, no video tracking
  MapFromPosesSummary summary;
  const mapstore::VIMap map = BuildMapFromPoses(dir + "/room", rig, gt, options, &summary);
  INFO(summary.FullReport());
  REQUIRE(mapstore::CheckMapConsistency(map).ok());
  CHECK(summary.vertices == 14);  // 81 frames, every 6th
  CHECK(summary.imu_edges == 13);
  CHECK(summary.vertex_pairs_verified > 10);
  CHECK(summary.landmarks_good > 300);
  const std::vector<double> errors = ReprojectionErrors(map);
  CHECK(Median(errors) < 0.5);
  // Deterministic: the same input gives the same map.
  const mapstore::VIMap again = BuildMapFromPoses(dir + "/room", rig, gt, options, nullptr);
  CHECK(again.num_landmarks() == map.num_landmarks());
  CHECK(again.mission_ids() == map.mission_ids());
  CHECK(ReprojectionErrors(again) == errors);
  fs::remove_all(dir);
}

TEST_CASE("real EuRoC keyframes with ground-truth poses: wide-baseline tracks, pixel-level landmarks") {
  const std::string dataset = std::string(VILMA_SHARED_DATA_DIR) + "/euroc_V1_01_keyframes";
  if (!fs::exists(dataset + "/mav0")) {
    VILMA_SKIP(dataset << " not found");
  }
  const SensorRig rig = ImportEurocRig(dataset);
  const Trajectory gt = ReadTrajectoryFile(dataset + "/mav0/state_groundtruth_estimate0/data.csv");
  MapFromPosesOptions options;
  options.every_nth_frame = 3;  // 34 keyframes over the whole sequence
  MapFromPosesSummary summary;
  const mapstore::VIMap map = BuildMapFromPoses(dataset, rig, gt, options, &summary);
  INFO(summary.FullReport());
  REQUIRE(mapstore::CheckMapConsistency(map).ok());
  CHECK(summary.vertices == 34);
  CHECK(summary.landmarks_good > 2000);
  CHECK(Median(ReprojectionErrors(map)) < 1.0);
  // Revisits: landmarks seen from vertices far apart in time (not neighbours in the list).
  std::size_t long_tracks = 0;
  for (const mapstore::LandmarkId& id : map.landmark_ids(map.mission_ids()[0])) {
    int64_t first = INT64_MAX, last = INT64_MIN;
    for (const mapstore::LandmarkObservation& o : map.landmark(id).observations) {
      first = std::min(first, map.vertex(o.vertex_id).t_ns);
      last = std::max(last, map.vertex(o.vertex_id).t_ns);
    }
    if (last - first > 30'000'000'000LL) ++long_tracks;
  }
  CHECK(long_tracks > 50);
}

}  // namespace
}  // namespace vilma::mapping
