#include "vilma/estimator/vio_pipeline.h"

#include <catch2/catch.hpp>
#include <cmath>
#include <deque>
#include <vector>

#include "estimator/plane_scene.h"
#include "vilma/core/error.h"
#include "vilma/core/geometry.h"

namespace vilma::estimator {
namespace {

using testing::PlaneScene;

constexpr int64_t kImuDt = 5'000'000, kCamDt = 50'000'000;

FilterOptions SmallOptions() {
  FilterOptions options;
  options.features.max_features = 10;
  options.features.detect_below = 8;
  return options;
}

// Images rendered once per test process (rendering dominates the run time).
const std::vector<cv::Mat>& Frames(const PlaneScene& scene, int n) {
  static std::vector<cv::Mat> frames;
  while (static_cast<int>(frames.size()) < n) {
    frames.push_back(scene.Render(static_cast<double>(frames.size() * kCamDt) * 1e-9));
  }
  return frames;
}

// Feeds `frames` frames in arrival order: every IMU sample up to the frame's time plus
// `image_delay_samples` more arrive before the image (a camera with latency).
std::vector<VioFrameOutput> RunPipeline(VioPipeline* pipeline, const PlaneScene& scene,
                                        int frames, int image_delay_samples,
                                        int64_t jump_at_frame = -1) {
  const std::vector<cv::Mat>& images = Frames(scene, frames);
  std::vector<VioFrameOutput> outputs;
  VioFrameOutput out;
  int64_t next_imu = 0;
  int64_t shift = 0;  // a time jump of the sensor clock
  for (int i = 0; i < frames; ++i) {
    const int64_t t_cam = i * kCamDt;
    if (i == jump_at_frame) shift = 100'000'000'000;
    for (; next_imu <= t_cam + image_delay_samples * kImuDt; next_imu += kImuDt) {
      ImuSample s = scene.Imu(next_imu);
      s.t_ns += shift;
      pipeline->AddImu(s);
      while (pipeline->NextOutput(&out)) outputs.push_back(out);
    }
    pipeline->AddImage(0, t_cam + shift, images[static_cast<std::size_t>(i)]);
    while (pipeline->NextOutput(&out)) outputs.push_back(out);
  }
  return outputs;
}

TEST_CASE("the pipeline gives the filter what the daemon's sync stage gives it") {
  const PlaneScene scene;
  VioPipelineOptions options;
  options.filter = SmallOptions();
  const int frames = 40;

  // Reference: the stage fed by hand with each frame's IMU up to and including the first
  // sample at or after the frame time (SensorSynchronizer's contract).
  VioFilterStage reference(scene.rig(), 0, options.filter);
  std::vector<VioFrameOutput> expected;
  int64_t next_imu = 0;
  for (int i = 0; i < frames - 1; ++i) {  // the last frame waits for IMU beyond the run
    const int64_t t_cam = i * kCamDt;
    for (; next_imu < t_cam + kImuDt; next_imu += kImuDt) reference.AddImu(scene.Imu(next_imu));
    expected.push_back(reference.AddFrame(t_cam, Frames(scene, frames)[static_cast<std::size_t>(i)]));
  }

  for (int delay : {1, 4}) {  // images arrive 1 or 4 IMU samples late: the same outputs
    VioPipeline pipeline(scene.rig(), options);
    const std::vector<VioFrameOutput> outputs = RunPipeline(&pipeline, scene, frames, delay);
    INFO("image delay " << delay << " IMU samples");
    REQUIRE(outputs.size() >= expected.size());
    int tracking = 0;
    std::size_t imu_given = 0;
    for (std::size_t i = 0; i < expected.size(); ++i) {
      const VioPose& a = outputs[i].pose;
      const VioPose& b = expected[i].pose;
      CHECK(a.t_ns == b.t_ns);
      CHECK(a.status == b.status);
      CHECK(a.T_M_I.translation() == b.T_M_I.translation());  // bit for bit
      CHECK(a.T_M_I.rotation().coeffs() == b.T_M_I.rotation().coeffs());
      CHECK(a.covariance == b.covariance);
      CHECK(outputs[i].t_cam_ns[0] == static_cast<int64_t>(i) * kCamDt);
      CHECK_FALSE(outputs[i].images[0].empty());
      imu_given += outputs[i].imu.size();
      if (a.tracking()) ++tracking;
    }
    CHECK(tracking > 30);
    // Each sample once, from t = 0 up to the one at the last released frame's time.
    CHECK(imu_given == static_cast<std::size_t>((expected.size() - 1) * 10 + 1));
    CHECK(pipeline.stage().counters().frames == static_cast<int64_t>(outputs.size()));
    CHECK(pipeline.sync_counters().frames_dropped_no_imu == 0);
  }
}

TEST_CASE("pipeline status: initializing, tracking, lost on a reset, a restart on a time jump") {
  const PlaneScene scene;
  VioPipelineOptions options;
  options.filter = SmallOptions();
  VioPipeline pipeline(scene.rig(), options);
  // Static start: the first frames wait for half the init window of IMU (0.25 s).
  std::vector<VioFrameOutput> outputs = RunPipeline(&pipeline, scene, 30, 1, /*jump_at_frame=*/20);
  REQUIRE(outputs.size() >= 28);
  CHECK(outputs[0].pose.status == TrackingStatus::kInitializing);
  CHECK(outputs[0].pose.t_ns == 0);  // the frame time while not tracking
  CHECK(outputs[10].pose.status == TrackingStatus::kTracking);
  // The jump: the filter restarts, the new one initializes anew (INITIALIZING, not LOST).
  int restarted = -1;
  for (std::size_t i = 0; i < outputs.size(); ++i) {
    if (outputs[i].restarted) {
      CHECK(restarted < 0);
      restarted = static_cast<int>(i);
    }
  }
  REQUIRE(restarted == 20);
  CHECK(outputs[20].pose.status == TrackingStatus::kInitializing);
  CHECK(pipeline.stage().counters().restarts == 1);
  CHECK(pipeline.sync_counters().imu_time_jumps + pipeline.sync_counters().image_time_jumps >= 1);

  // A requested reset: LOST on that frame, the filter's resets counted by the stage.
  VioFilterStage stage(scene.rig(), 0, options.filter);
  int64_t next_imu = 0;
  TrackingStatus last = TrackingStatus::kInitializing;
  for (int i = 0; i < 16; ++i) {
    const int64_t t_cam = i * kCamDt;
    for (; next_imu < t_cam + kImuDt; next_imu += kImuDt) stage.AddImu(scene.Imu(next_imu));
    if (i == 12) stage.RequestReset("test");
    const VioFrameOutput out = stage.AddFrame(t_cam, Frames(scene, 16)[static_cast<std::size_t>(i)]);
    if (i == 12) {
      CHECK(out.filter.reset);
      CHECK(out.pose.status == TrackingStatus::kLost);
    }
    if (i == 13) CHECK(out.pose.status != TrackingStatus::kInitializing);  // LOST until re-init
    last = out.pose.status;
  }
  CHECK(stage.counters().resets == 1);
  CHECK(last == TrackingStatus::kTracking);
}

TEST_CASE("the pose covariance is the filter's, with the rotation error moved to the left") {
  const PlaneScene scene;
  VioFilterStage stage(scene.rig(), 0, SmallOptions());
  int64_t next_imu = 0;
  VioFrameOutput out;
  for (int i = 0; i < 30; ++i) {
    const int64_t t_cam = i * kCamDt;
    for (; next_imu < t_cam + kImuDt; next_imu += kImuDt) stage.AddImu(scene.Imu(next_imu));
    out = stage.AddFrame(t_cam, Frames(scene, 30)[static_cast<std::size_t>(i)]);
  }
  REQUIRE(out.pose.tracking());
  // Make the attitude non-trivial so that R matters: the conversion is checked with a rotated
  // copy of the pose. d delta / d dtheta of delta = Log(R Exp(dtheta) R^T), numerically.
  const Eigen::Matrix3d R = out.pose.T_M_I.rotation().toRotationMatrix();
  Eigen::Matrix3d J;
  const double h = 1e-6;
  for (int k = 0; k < 3; ++k) {
    const Eigen::Vector3d d = Eigen::Vector3d::Unit(k) * h;
    const Eigen::Vector3d plus = LogSO3(Eigen::Quaterniond(R * ExpSO3(d).toRotationMatrix() * R.transpose()));
    const Eigen::Vector3d minus = LogSO3(Eigen::Quaterniond(R * ExpSO3(-d).toRotationMatrix() * R.transpose()));
    J.col(k) = (plus - minus) / (2 * h);
  }
  const Eigen::MatrixXd& P = stage.filter().covariance();
  const Eigen::Matrix3d P_tt = P.block<3, 3>(kIdxQ, kIdxQ);
  const Eigen::Matrix3d P_pt = P.block<3, 3>(kIdxP, kIdxQ);
  const Matrix6d& C = out.pose.covariance;
  CHECK((C.block<3, 3>(0, 0) - P.block<3, 3>(kIdxP, kIdxP)).norm() == 0.0);
  CHECK((C.block<3, 3>(3, 3) - J * P_tt * J.transpose()).norm() < 1e-8 * (1.0 + P_tt.norm()));
  CHECK((C.block<3, 3>(0, 3) - P_pt * J.transpose()).norm() < 1e-8 * (1.0 + P_pt.norm()));
  CHECK((C - C.transpose()).norm() <= 1e-12 * C.norm());
  CHECK(out.pose.v_M == stage.filter().state().v_M);
  CHECK(out.pose.omega_I == scene.Imu(next_imu - kImuDt).omega_I - stage.filter().state().b_g);
}

TEST_CASE("pipeline options are validated with clear errors") {
  const PlaneScene mono;
  VioPipelineOptions options;
  options.vio_camera = 1;
  CHECK_THROWS_WITH(VioPipeline(mono.rig(), options), Catch::Contains("vio_camera"));
  const PlaneScene stereo(2);
  options.vio_camera = 0;
  options.cameras = {1};
  CHECK_THROWS_WITH(VioPipeline(stereo.rig(), options),
                    Catch::Contains("cameras: expected to include vio_camera"));
  options.cameras = {0, 0};
  CHECK_THROWS_WITH(VioPipeline(stereo.rig(), options), Catch::Contains("each camera once"));
  options.cameras = {0};
  options.filter.stereo.enabled = true;
  CHECK_THROWS_WITH(VioPipeline(stereo.rig(), options), Catch::Contains("stereo.camera"));
  options.cameras = {0, 1};
  options.filter.stereo.camera = 0;
  CHECK_THROWS_WITH(VioPipeline(stereo.rig(), options),
                    Catch::Contains("a camera other than vio_camera"));
  options = VioPipelineOptions();
  options.sync.max_pending_frames = 0;
  CHECK_THROWS_WITH(VioPipeline(mono.rig(), options), Catch::Contains("sync."));
}

TEST_CASE("two synchronized cameras: frames carry both images, frames without cam0 are counted") {
  const PlaneScene scene(2);
  VioPipelineOptions options;
  options.filter = SmallOptions();
  VioPipeline pipeline(scene.rig(), options);
  const std::vector<cv::Mat>& images = Frames(scene, 20);
  VioFrameOutput out;
  std::vector<VioFrameOutput> outputs;
  int64_t next_imu = 0;
  for (int i = 0; i < 20; ++i) {
    const int64_t t_cam = i * kCamDt;
    for (; next_imu <= t_cam + kImuDt; next_imu += kImuDt) pipeline.AddImu(scene.Imu(next_imu));
    if (i != 7) pipeline.AddImage(0, t_cam, images[static_cast<std::size_t>(i)]);  // cam0 drops one
    pipeline.AddImage(1, t_cam + 1000, images[static_cast<std::size_t>(i)]);  // 1 us later
    while (pipeline.NextOutput(&out)) outputs.push_back(out);
  }
  REQUIRE(outputs.size() >= 17);
  CHECK(pipeline.stage().counters().frames_without_vio_camera == 1);
  for (const VioFrameOutput& o : outputs) {
    REQUIRE(o.images.size() == 2);
    CHECK_FALSE(o.images[1].empty());
    CHECK(o.t_cam_ns[1] == o.t_cam_ns[0] + 1000);
  }
}

}  // namespace
}  // namespace vilma::estimator
