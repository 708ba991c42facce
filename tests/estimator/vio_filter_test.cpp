#include "vilma/estimator/vio_filter.h"

#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <opencv2/imgproc.hpp>
#include <string>
#include <vector>
#include <unistd.h>

#include "vilma/core/asl_dataset.h"
#include "vilma/core/rig.h"
#include "vilma/eval/evaluate.h"
#include "test_skip.h"

namespace vilma::estimator {
namespace {

// A synthetic world for the filter: a textured plane z = kPlaneZ in W seen by a pinhole
// camera that looks up (+z of W; C = I), moving along x and y after a 1 s static start.
constexpr double kPlaneZ = 3.0;  // [m]
constexpr int kWidth = 320, kHeight = 240;
constexpr double kF = 300.0;

struct Scene {
  cv::Mat texture;  // 1 px = 1 cm over [-5, 5]^2 m
  SensorRig rig;

  Scene() {
    cv::Mat noise(1000, 1000, CV_32F);
    cv::RNG rng(12345);
    rng.fill(noise, cv::RNG::UNIFORM, 0.0, 1.0);
    cv::GaussianBlur(noise, texture, cv::Size(0, 0), 2.5);
    cv::normalize(texture, texture, 0.0, 255.0, cv::NORM_MINMAX);
    CameraConfig cam;
    cam.camera = Camera(kWidth, kHeight, Eigen::Vector4d(kF, kF, 160, 120), DistortionModel::kNone,
                        Eigen::VectorXd());
    rig.cameras.push_back(cam);
  }

  // Motion starts at t = kStart (a static start); tests of a moving start shift time.
  static double& StartTime() {
    static double start = 1.0;
    return start;
  }
  static Eigen::Vector3d Position(double t) {
    const double tau = std::max(0.0, t - StartTime());
    return Eigen::Vector3d(0.4 * (1.0 - std::cos(2.0 * tau)), 0.2 * (1.0 - std::cos(1.3 * tau)),
                           0.0);
  }
  static Eigen::Vector3d AccelerationW(double t) {
    const double tau = t - StartTime();
    if (tau < 0.0) return Eigen::Vector3d::Zero();
    return Eigen::Vector3d(0.4 * 4.0 * std::cos(2.0 * tau), 0.2 * 1.69 * std::cos(1.3 * tau), 0);
  }
  static ImuSample Imu(int64_t t_ns) {
    ImuSample s;
    s.t_ns = t_ns;
    s.a_I = AccelerationW(static_cast<double>(t_ns) * 1e-9) + Eigen::Vector3d(0, 0, 9.81);
    return s;
  }
  cv::Mat Render(double t) const {
    const Eigen::Vector3d c = Position(t);
    cv::Mat image(kHeight, kWidth, CV_8U);
    for (int v = 0; v < kHeight; ++v) {
      for (int u = 0; u < kWidth; ++u) {
        const double s = (kPlaneZ - c.z());
        const double x = c.x() + s * (u - 160) / kF, y = c.y() + s * (v - 120) / kF;
        const double tu = x * 100.0 + 500.0, tv = y * 100.0 + 500.0;
        const int iu = static_cast<int>(std::floor(tu)), iv = static_cast<int>(std::floor(tv));
        const double fu = tu - iu, fv = tv - iv;
        auto at = [&](int a, int b) { return static_cast<double>(texture.at<float>(b, a)); };
        const double value = (1 - fv) * ((1 - fu) * at(iu, iv) + fu * at(iu + 1, iv)) +
                             fv * ((1 - fu) * at(iu, iv + 1) + fu * at(iu + 1, iv + 1));
        image.at<unsigned char>(v, u) = cv::saturate_cast<unsigned char>(value);
      }
    }
    return image;
  }
};

const Scene& TheScene() {
  static const Scene scene;
  return scene;
}

struct RunConfig {
  double seconds = 4.0;
  int drop_frame = -1;                    // frame index not given to the filter
  double imu_gap_from = -1, imu_gap_to = -1;  // [s] IMU samples removed
  double duplicate_imu_at = -1;           // [s] this sample is sent twice
  double corrupt_from = -1, corrupt_to = -1;  // [s] IMU samples replaced by garbage
};

// Runs the filter over the synthetic scene; returns the final position error [m] and
// fills `filter_out` state checks through the callback.
double RunScene(const RunConfig& config, VioFilter* filter,
                int* resets) {
  const Scene& scene = TheScene();
  const int64_t imu_dt = 5'000'000, cam_dt = 50'000'000;
  int64_t next_imu = 0;
  const int frames = static_cast<int>(config.seconds * 20.0);
  *resets = 0;
  double t_init = 0.0;
  for (int i = 0; i <= frames; ++i) {
    const int64_t t_cam = i * cam_dt;
    for (; next_imu <= t_cam + imu_dt; next_imu += imu_dt) {
      const double t = static_cast<double>(next_imu) * 1e-9;
      if (t >= config.imu_gap_from && t < config.imu_gap_to) continue;
      ImuSample sample = Scene::Imu(next_imu);
      if (t >= config.corrupt_from && t < config.corrupt_to) sample.a_I.x() += 500.0;
      filter->AddImu(sample);
      if (std::abs(t - config.duplicate_imu_at) < 1e-6) filter->AddImu(Scene::Imu(next_imu));
    }
    if (i == config.drop_frame) continue;
    const FrameResult r = filter->AddImage(t_cam, scene.Render(static_cast<double>(t_cam) * 1e-9));
    if (r.reset) ++*resets;
    if (r.initialized_now) t_init = static_cast<double>(t_cam) * 1e-9;
  }
  // The filter starts at the origin: compare displacements since initialization.
  return (filter->state().p_M_I -
          (Scene::Position(config.seconds) - Scene::Position(t_init)))
      .norm();
}

TEST_CASE("a single feature's inverse distance converges to the true value") {
  FilterOptions options;
  options.features.max_features = 1;
  options.features.detect_below = 1;
  VioFilter filter(TheScene().rig, 0, options);
  int resets = 0;
  RunConfig config;
  config.seconds = 3.0;
  RunScene(config, &filter, &resets);
  CHECK(resets == 0);
  REQUIRE(filter.state().num_active() == 1);
  CHECK(filter.stats().static_starts == 1);
  const FeatureState& f = filter.state().features[0];
  // True distance along the bearing to the plane (C = I, camera looks along +z of W).
  const Eigen::Vector3d mu_M = filter.state().q_M_I * f.mu_C;
  const double rho_true = mu_M.z() / (kPlaneZ - filter.state().p_M_I.z());
  INFO("rho " << f.rho << " true " << rho_true << " (started at "
              << options.features.init_inverse_depth << ")");
  CHECK(std::abs(f.rho - rho_true) < 0.1 * rho_true);
  // And the uncertainty shrank from the initial 0.5 [1/m].
  const int k = FeatureIndex(0);
  CHECK(std::sqrt(filter.covariance()(k + 2, k + 2)) < 0.1);
}

TEST_CASE("every detected feature gets its own id") {
  FilterOptions options;
  VioFilter filter(TheScene().rig, 0, options);
  for (int slot = 0; slot < options.features.max_features; ++slot)
    CHECK(filter.feature_id(slot) == 0);
  int resets = 0;
  RunConfig config;
  config.seconds = 3.0;
  RunScene(config, &filter, &resets);
  std::vector<int64_t> ids;
  for (int slot = 0; slot < options.features.max_features; ++slot) {
    if (filter.state().features[static_cast<std::size_t>(slot)].active)
      ids.push_back(filter.feature_id(slot));
  }
  REQUIRE(ids.size() >= 2);
  std::sort(ids.begin(), ids.end());
  CHECK(ids.front() >= 1);
  CHECK(std::adjacent_find(ids.begin(), ids.end()) == ids.end());  // no id twice
}

TEST_CASE("a frame drop, an IMU gap and a duplicated IMU sample don't break the filter") {
  FilterOptions options;
  options.features.max_features = 12;
  options.features.detect_below = 8;
  RunConfig nominal;
  RunConfig dropped = nominal;
  dropped.drop_frame = 50;
  RunConfig gap = nominal;
  gap.imu_gap_from = 2.0;
  gap.imu_gap_to = 2.08;
  RunConfig duplicate = nominal;
  duplicate.duplicate_imu_at = 2.5;
  for (const RunConfig& config : {nominal, dropped, gap, duplicate}) {
    VioFilter filter(TheScene().rig, 0, options);
    int resets = 0;
    const double error = RunScene(config, &filter, &resets);
    INFO("drop " << config.drop_frame << " gap " << config.imu_gap_from << " duplicate "
                 << config.duplicate_imu_at << ": final position error " << error << " m");
    CHECK(resets == 0);
    CHECK(filter.state().p_M_I.allFinite());
    CHECK(error < 0.05);  // of a 0.8 m x 0.4 m motion over 3 s
    if (config.duplicate_imu_at > 0) CHECK(filter.stats().imu_duplicates == 1);
    if (config.imu_gap_from > 0) CHECK(filter.stats().imu_gaps == 1);
  }
}

TEST_CASE("a moving start initializes and tracks") {
  // Motion from the first sample on: the start window sees acceleration that changes, the
  // velocity at initialization is not zero.
  Scene::StartTime() = -0.5;
  FilterOptions options;
  options.features.max_features = 12;
  options.features.detect_below = 8;
  VioFilter filter(TheScene().rig, 0, options);
  int resets = 0;
  RunConfig config;
  const double error = RunScene(config, &filter, &resets);
  Scene::StartTime() = 1.0;
  INFO("final position error " << error << " m, resets " << resets);
  CHECK(filter.initialized());
  CHECK(filter.stats().moving_starts == 1);
  // By the visual-inertial alignment, not the mean-accelerometer fallback.
  CHECK(filter.stats().dynamic_starts == 1);
  CHECK(filter.stats().dynamic_init.accepted == 1);
  CHECK(resets == 0);
  CHECK(error < 0.1);
  // The camera does not rotate: the attitude stays level (gravity along +z of W in I = W).
  const Eigen::Vector3d z_I = filter.state().q_M_I.conjugate() * Eigen::Vector3d::UnitZ();
  CHECK(std::acos(std::min(1.0, z_I.z())) < 0.5 * 3.14159265358979 / 180.0);
}

TEST_CASE("without the alignment a moving start falls back to the mean accelerometer") {
  Scene::StartTime() = -0.5;
  FilterOptions options;
  options.features.max_features = 12;
  options.features.detect_below = 8;
  options.init.dynamic.enabled = false;
  VioFilter filter(TheScene().rig, 0, options);
  int resets = 0;
  RunConfig config;
  config.seconds = 1.0;
  RunScene(config, &filter, &resets);
  Scene::StartTime() = 1.0;
  CHECK(filter.initialized());
  CHECK(filter.stats().fallback_starts == 1);
  CHECK(filter.stats().dynamic_init.attempts == 0);
}

TEST_CASE("a given start state is used at the first frame, carried there by the IMU") {
  // Moving from the start; the given state is the truth 20 ms before the first frame.
  Scene::StartTime() = -0.5;
  FilterOptions options;
  options.features.max_features = 12;
  options.features.detect_below = 8;
  VioFilter filter(TheScene().rig, 0, options);
  GivenState given;
  given.t_ns = -20'000'000;
  given.p_M_I = Scene::Position(-0.02);
  const double tau = -0.02 + 0.5;
  given.v_M = Eigen::Vector3d(0.4 * 2.0 * std::sin(2.0 * tau), 0.2 * 1.3 * std::sin(1.3 * tau), 0);
  filter.StartFrom(given);
  for (int64_t t = -40'000'000; t <= 5'000'000; t += 5'000'000) filter.AddImu(Scene::Imu(t));
  const FrameResult first = filter.AddImage(0, TheScene().Render(0.0));
  Scene::StartTime() = 1.0;
  REQUIRE(first.pose_valid);
  CHECK(first.initialized_now);
  CHECK(filter.stats().given_starts == 1);
  // The state at t = 0: the given position and velocity carried 20 ms by exact IMU.
  Scene::StartTime() = -0.5;
  CHECK((filter.state().p_M_I - Scene::Position(0.0)).norm() < 1e-4);
  const Eigen::Vector3d v_true(0.4 * 2.0 * std::sin(1.0), 0.2 * 1.3 * std::sin(0.65), 0);
  CHECK((filter.state().v_M - v_true).norm() < 1e-3);
  Scene::StartTime() = 1.0;
  GivenState bad;
  bad.sigma_velocity = 0.0;
  CHECK_THROWS_WITH(filter.StartFrom(bad), Catch::Contains("sigma"));
}

TEST_CASE("a diverging filter is detected, reset and re-initialized") {
  FilterOptions options;
  options.features.max_features = 12;
  options.features.detect_below = 8;
  VioFilter filter(TheScene().rig, 0, options);
  int resets = 0;
  RunConfig config;
  config.corrupt_from = 1.5;  // 0.2 s of 500 m/s^2: |v| goes far beyond health.max_speed
  config.corrupt_to = 1.7;
  RunScene(config, &filter, &resets);
  CHECK(resets >= 1);
  CHECK(filter.stats().resets == resets);
  CHECK(filter.initialized());  // re-initialized from clean IMU after the corruption
  CHECK(filter.state().p_M_I.allFinite());
  CHECK(filter.state().v_M.norm() < 2.0);  // the true speed is below 1 m/s
  CHECK(filter.state().num_active() > 0);
}

TEST_CASE("a template refresh re-extracts tracked patches and the filter still tracks") {
  // features.refresh_patch_every (ROVIO re-extracts after every tracked frame; session 36).
  FilterOptions options;
  options.features.max_features = 12;
  options.features.detect_below = 8;
  for (const int every : {1, 5}) {
    options.features.refresh_patch_every = every;
    VioFilter filter(TheScene().rig, 0, options);
    int resets = 0;
    const double error = RunScene(RunConfig(), &filter, &resets);
    const FilterStats& s = filter.stats();
    INFO("every " << every << ": " << s.patch_refreshes << " refreshes, "
                  << s.patch_refresh_rejections << " not; final position error " << error
                  << " m");
    CHECK(resets == 0);
    // Roughly one refresh per `every` accepted updates (the plane's texture is good
    // everywhere, so the score test seldom refuses one).
    CHECK(s.patch_refreshes > s.updates / (2 * every));
    CHECK(error < 0.05);  // of a 0.8 m x 0.4 m motion, as without the refresh
  }
  options.features.refresh_patch_every = 0;
  VioFilter never(TheScene().rig, 0, options);
  int resets = 0;
  RunScene(RunConfig(), &never, &resets);
  CHECK(never.stats().patch_refreshes == 0);
  CHECK(never.stats().patch_refresh_rejections == 0);
}

TEST_CASE("a persistent template error makes the vision updates less informative") {
  // update.persistent_pixel_sigma adds variance that grows with the updates made with a
  // template: over the same run, the position covariance ends larger than without it.
  FilterOptions options;
  options.features.max_features = 12;
  options.features.detect_below = 8;
  RunConfig config;
  config.seconds = 3.0;
  VioFilter white(TheScene().rig, 0, options);
  options.update.persistent_pixel_sigma = 0.25;
  VioFilter persistent(TheScene().rig, 0, options);
  int resets_white = 0, resets_persistent = 0;
  const double error_white = RunScene(config, &white, &resets_white);
  const double error_persistent = RunScene(config, &persistent, &resets_persistent);
  const double var_white = white.covariance().block<3, 3>(kIdxP, kIdxP).trace();
  const double var_persistent = persistent.covariance().block<3, 3>(kIdxP, kIdxP).trace();
  INFO("position std " << std::sqrt(var_white) << " -> " << std::sqrt(var_persistent)
                       << " m; error " << error_white << " -> " << error_persistent << " m");
  CHECK(resets_white + resets_persistent == 0);
  CHECK(var_persistent > 1.2 * var_white);
  CHECK(error_persistent < 0.05);
}

TEST_CASE("the filter is deterministic") {
  FilterOptions options;
  options.features.max_features = 8;
  options.features.detect_below = 6;
  RunConfig config;
  config.seconds = 1.5;
  VioFilter a(TheScene().rig, 0, options), b(TheScene().rig, 0, options);
  int resets = 0;
  RunScene(config, &a, &resets);
  RunScene(config, &b, &resets);
  CHECK(a.state().p_M_I == b.state().p_M_I);
  CHECK(a.state().q_M_I.coeffs() == b.state().q_M_I.coeffs());
  CHECK(a.covariance() == b.covariance());
}

TEST_CASE("the filter rejects invalid options and rigs with clear errors") {
  FilterOptions options;
  options.features.max_features = 0;
  CHECK_THROWS_WITH(VioFilter(TheScene().rig, 0, options),
                    Catch::Contains("features.max_features: expected >= 1"));
  CHECK_THROWS_WITH(VioFilter(TheScene().rig, 3, FilterOptions()),
                    Catch::Contains("camera with index 3"));
}

TEST_CASE("a simulated room sequence is tracked within a loose bound") {
  const std::string sim = std::string(VILMA_BINARY_DIR) + "/bin/vilma-sim";
  if (!std::filesystem::exists(sim)) {
    VILMA_SKIP(sim << " is not built");
  }
  const std::filesystem::path dir =
      std::filesystem::temp_directory_path() /
      ("vilma_vio_filter_test_room_" + std::to_string(::getpid()));
  // Generated once for both sections (Catch runs the test case once per section).
  static bool generated = false;
  if (!generated) {
    std::filesystem::remove_all(dir);
    const std::string command =
        sim + " room --out " + dir.string() + " --seconds 10 > /dev/null 2>&1";
    REQUIRE(std::system(command.c_str()) == 0);
    generated = true;
  }
  const AslDataset dataset = AslDataset::Open(dir.string());
  const SensorRig rig = LoadSensorRig((dir / "rig.yaml").string());
  Trajectory truth;
  for (const GroundTruthState& g : dataset.ground_truth()) {
    truth.Add(g.t_ns, Transformation(g.q_W_I, g.p_W_I));
  }
  auto run = [&](VioFilter* filter) {
    Trajectory estimate;
    std::size_t next = 0;
    for (const CameraFrame& frame : dataset.cameras()[0].frames) {
      while (next < dataset.imu().size() && dataset.imu()[next].t_ns <= frame.t_ns) {
        filter->AddImu(dataset.imu()[next++]);
      }
      const FrameResult r = filter->AddImage(frame.t_ns, AslDataset::LoadImage(frame.image_path));
      CHECK_FALSE(r.reset);
      if (r.pose_valid) estimate.Add(r.t_ns, r.T_M_I);
    }
    EvalOptions eval;
    eval.alignment = AlignmentType::kPosYaw;
    return EvaluateTrajectory(truth, estimate, eval).ate.translation_m.rmse;
  };
  SECTION("calibrated rig") {
    VioFilter filter(rig, 0, FilterOptions());
    const double ate = run(&filter);
    INFO("ATE rmse " << ate << " m");
    CHECK(ate < 0.15);
  }
  SECTION("a 2 degree extrinsic rotation error is refined online") {
    SensorRig wrong = rig;
    const Transformation& T_true = rig.cameras[0].T_I_C;
    wrong.cameras[0].T_I_C = Transformation(
        T_true.rotation() * ExpSO3(Eigen::Vector3d(0.3, 0.5, 0.8).normalized() * 2.0 * M_PI / 180),
        T_true.translation());
    FilterOptions options;
    options.estimate_extrinsics = true;
    VioFilter filter(wrong, 0, options);
    const double ate = run(&filter);
    const double error_deg =
        AngleBetween(filter.state().q_I_C, T_true.rotation()) * 180.0 / M_PI;
    INFO("ATE rmse " << ate << " m, extrinsic rotation error " << error_deg << " deg (from 2)");
    CHECK(ate < 0.15);
    CHECK(error_deg < 1.0);
  }
  SECTION("a 10 ms error of the camera time offset is estimated online") {
    // The images were taken at t_cam (offset 0); a rig that says -10 ms needs td = +10 ms.
    SensorRig wrong = rig;
    wrong.cameras[0].time_offset_ns = -10'000'000;
    FilterOptions options;
    options.estimate_time_offset = true;
    VioFilter filter(wrong, 0, options);
    const double ate = run(&filter);
    INFO("ATE rmse " << ate << " m, td " << filter.state().td * 1e3 << " ms (true 10 ms)");
    CHECK(ate < 0.15);
    CHECK(std::abs(filter.state().td - 0.010) < 0.003);
    std::filesystem::remove_all(dir);  // the last section
  }
}

}  // namespace
}  // namespace vilma::estimator
