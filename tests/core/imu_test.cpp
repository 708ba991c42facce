#include "vilma/core/imu.h"

#include <catch2/catch.hpp>
#include <cmath>

#include "vilma/core/geometry.h"

namespace vilma {
namespace {

// Samples of a body that rotates at constant rate omega_I about a fixed axis while its
// position follows p(t) = p0 + v0 t + 1/2 a_W t^2 (constant world acceleration).
std::vector<ImuSample> ConstantMotionSamples(const ImuState& start, const Eigen::Vector3d& omega_I,
                                             const Eigen::Vector3d& a_W, double g, double rate_hz,
                                             double duration_s) {
  std::vector<ImuSample> samples;
  const int n = static_cast<int>(duration_s * rate_hz) + 1;
  for (int k = 0; k < n; ++k) {
    const double t = k / rate_hz;
    const Eigen::Quaterniond q_W_I = start.q_W_I * ExpSO3(omega_I * t);
    ImuSample s;
    s.t_ns = start.t_ns + static_cast<int64_t>(std::llround(t * 1e9));
    s.omega_I = omega_I + start.b_g;
    s.a_I = q_W_I.conjugate() * (a_W - Eigen::Vector3d(0, 0, -g)) + start.b_a;
    samples.push_back(s);
  }
  return samples;
}

TEST_CASE("IMU integration follows constant rotation and acceleration", "[imu]") {
  ImuState start;
  start.t_ns = 1000000000;
  start.q_W_I = ExpSO3(Eigen::Vector3d(0.1, -0.4, 0.7));
  start.p_W_I = Eigen::Vector3d(1, 2, 3);
  start.v_W = Eigen::Vector3d(0.5, -0.2, 0.1);
  start.b_g = Eigen::Vector3d(0.01, -0.02, 0.005);
  start.b_a = Eigen::Vector3d(-0.1, 0.05, 0.2);
  const Eigen::Vector3d omega_I(0.3, -0.5, 1.2);
  const Eigen::Vector3d a_W(0.2, -0.1, 0.3);
  const double duration = 10.0;
  const auto samples = ConstantMotionSamples(start, omega_I, a_W, 9.81, 200.0, duration);

  const ImuState end = IntegrateImu(start, samples, samples.back().t_ns, 9.81);
  const Eigen::Vector3d p_expected =
      start.p_W_I + start.v_W * duration + 0.5 * a_W * duration * duration;
  const Eigen::Quaterniond q_expected = start.q_W_I * ExpSO3(omega_I * duration);
  CHECK((end.p_W_I - p_expected).norm() < 1e-3);
  // Linear interpolation between 200 Hz samples of the rotating specific force (|a| ~ 10,
  // |omega| ~ 1.3 rad/s) biases the mean acceleration by ~h^2/12 |omega|^2 |a| ~ 3e-5 m/s^2,
  // i.e. ~3e-4 m/s over 10 s: the bound is the model's, not the integrator's.
  CHECK((end.v_W - (start.v_W + a_W * duration)).norm() < 5e-4);
  CHECK(AngleBetween(end.q_W_I, q_expected) < 1e-6);
  CHECK(end.t_ns == samples.back().t_ns);
}

TEST_CASE("IMU integration of a static IMU stays put, between samples too", "[imu]") {
  ImuState start;
  start.t_ns = 0;
  const auto samples =
      ConstantMotionSamples(start, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), 9.81, 200, 2);
  // End between two samples (interpolated) and start between samples.
  ImuState mid = start;
  mid.t_ns = 2500000;
  const ImuState end = IntegrateImu(mid, samples, 1502500000, 9.81);
  CHECK(end.p_W_I.norm() < 1e-9);
  CHECK(end.v_W.norm() < 1e-9);
  // A wrong gravity magnitude makes it fall: 1/2 dg t^2.
  const ImuState falling = IntegrateImu(start, samples, 1000000000, 9.80);
  CHECK(falling.p_W_I.z() == Approx(0.5 * 0.01).epsilon(1e-6));
}

TEST_CASE("IMU integration refuses intervals the samples do not cover", "[imu]") {
  ImuState start;
  const auto samples =
      ConstantMotionSamples(start, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero(), 9.81, 200, 1);
  CHECK_THROWS_AS(IntegrateImu(start, samples, 2000000000), std::invalid_argument);
  ImuState before = start;
  before.t_ns = -1;
  CHECK_THROWS_AS(IntegrateImu(before, samples, 1000), std::invalid_argument);
}

TEST_CASE("ImuNoise validation names the bad density", "[imu]") {
  ImuNoise noise;
  CHECK(noise.Validate().empty());
  noise.accelerometer_random_walk = -1;
  CHECK_THAT(noise.Validate(), Catch::Contains("accelerometer_random_walk"));
  noise = ImuNoise();
  noise.gyroscope_noise_density = std::nan("");
  CHECK_THAT(noise.Validate(), Catch::Contains("gyroscope_noise_density"));
}

}  // namespace
}  // namespace vilma
