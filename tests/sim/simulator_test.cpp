#include "vilma/sim/simulator.h"

#include <catch2/catch.hpp>
#include <cstdlib>
#include <filesystem>

#include "vilma/core/asl_dataset.h"
#include "vilma/core/rig.h"
#include "vilma/core/time.h"

using vilma::sim::SimOptions;
using vilma::sim::Simulator;

namespace {
SimOptions Short(int session, uint64_t seed) {
  SimOptions o;
  o.world = "room";
  o.seconds = 6.0;
  o.session = session;
  o.seed = seed;
  o.stereo = true;
  return o;
}
}  // namespace

TEST_CASE("same seed gives identical output, sessions differ", "[sim][simulator]") {
  Simulator a(Short(0, 9)), b(Short(0, 9)), s1(Short(1, 9));
  REQUIRE(a.imu().samples.size() == b.imu().samples.size());
  for (size_t i = 0; i < a.imu().samples.size(); ++i) {
    REQUIRE(a.imu().samples[i].a_I == b.imu().samples[i].a_I);
    REQUIRE(a.imu().samples[i].omega_I == b.imu().samples[i].omega_I);
  }
  cv::Mat ia, ib, is;
  for (int cam = 0; cam < 2; ++cam) {
    a.RenderFrame(cam, 100, &ia);
    b.RenderFrame(cam, 100, &ib);
    CHECK(cv::norm(ia, ib, cv::NORM_INF) == 0.0);
  }
  // Session 1: the same world (same frame W) ...
  REQUIRE(a.world().quads.size() == s1.world().quads.size());
  for (size_t i = 0; i < a.world().quads.size(); ++i)
    CHECK(a.world().quads[i].origin_W == s1.world().quads[i].origin_W);
  // ... another start, path, lighting, IMU noise and clock.
  CHECK((a.imu().ground_truth[0].p_W_I - s1.imu().ground_truth[0].p_W_I).norm() > 0.3);
  CHECK(a.render_options().gain != s1.render_options().gain);
  CHECK(a.imu().samples[0].omega_I != s1.imu().samples[0].omega_I);
  CHECK(s1.start_time_ns() > a.start_time_ns());
  s1.RenderFrame(0, 100, &is);
  a.RenderFrame(0, 100, &ia);
  CHECK(cv::norm(ia, is, cv::NORM_L1) / ia.total() > 5.0);
}

TEST_CASE("time offset: frame t_cam shows the world at t_cam + offset", "[sim][simulator]") {
  SimOptions o = Short(0, 3);
  o.camera_time_offset_ns = 7000000;
  Simulator sim(o);
  CHECK(sim.rig().cameras[0].time_offset_ns == 7000000);
  const int64_t t = sim.frame_time_ns(90);
  const auto s = sim.trajectory().Evaluate(vilma::NsToSeconds(t + 7000000 - sim.start_time_ns()));
  const vilma::Transformation expected = s.T_W_I * sim.rig().cameras[0].T_I_C;
  const vilma::Transformation got = sim.T_W_C(0, t);
  CHECK((got.translation() - expected.translation()).norm() < 1e-12);
}

TEST_CASE("writes a readable ASL dataset with rig and ground truth", "[sim][simulator]") {
  const std::string dir = std::filesystem::temp_directory_path() / "vilma_sim_dataset_test";
  std::filesystem::remove_all(dir);
  SimOptions o = Short(0, 4);
  o.seconds = 2.0;
  Simulator sim(o);
  const vilma::sim::DatasetSummary s = sim.WriteDataset(dir);
  CHECK(s.num_frames == 41);
  CHECK(s.num_images == 82);
  CHECK(s.num_imu_samples == 401);
  const vilma::AslDataset d = vilma::AslDataset::Open(dir);
  REQUIRE(d.cameras().size() == 2);
  CHECK(d.cameras()[0].frames.size() == 41);
  CHECK(d.cameras()[1].frames.size() == 41);
  CHECK(d.imu().size() == 401);
  REQUIRE(d.ground_truth().size() == 401);
  CHECK((d.ground_truth()[200].p_W_I - sim.imu().ground_truth[200].p_W_I).norm() < 1e-6);
  const cv::Mat image = vilma::AslDataset::LoadImage(d.cameras()[1].frames[3].image_path);
  CHECK(image.cols == 752);
  CHECK(image.rows == 480);
  const vilma::SensorRig rig = vilma::LoadSensorRig(dir + "/rig.yaml");
  REQUIRE(rig.cameras.size() == 2);
  CHECK(rig.cameras[0].camera.fx() == Approx(458.654));
  CHECK((rig.cameras[1].T_I_C.translation() - sim.rig().cameras[1].T_I_C.translation()).norm() < 1e-9);
  const vilma::SensorRig euroc = vilma::ImportEurocRig(dir);
  CHECK(euroc.cameras.size() == 2);
  CHECK(std::filesystem::exists(dir + "/sim.yaml"));
  std::filesystem::remove_all(dir);
}
