#include "vilma/sim/imu_sim.h"

#include <catch2/catch.hpp>
#include <cmath>
#include <iostream>

#include "vilma/core/geometry.h"
#include "vilma/core/imu.h"

using Eigen::Vector3d;
using vilma::ImuSample;
using vilma::sim::ImuSimOptions;
using vilma::sim::ImuSimResult;
using vilma::sim::Rng;

namespace {

constexpr int64_t kT0 = 1600000000000000000;

vilma::ImuState StateFrom(const vilma::GroundTruthState& g) {
  vilma::ImuState s;
  s.t_ns = g.t_ns;
  s.p_W_I = g.p_W_I;
  s.q_W_I = g.q_W_I;
  s.v_W = g.v_W;
  s.b_g = g.b_g;
  s.b_a = g.b_a;
  return s;
}

// Overlapping Allan deviation of the (rate) samples x at cluster size m samples.
double AllanDeviation(const std::vector<double>& x, int m) {
  // Integrate to theta, then sigma^2 = sum (theta_{k+2m} - 2 theta_{k+m} + theta_k)^2 /
  // (2 tau^2 (N - 2m)) with tau = m dt; here dt = 1 (caller scales).
  std::vector<double> theta(x.size() + 1, 0.0);
  for (size_t i = 0; i < x.size(); ++i) theta[i + 1] = theta[i] + x[i];
  double sum = 0.0;
  const size_t n = theta.size();
  for (size_t k = 0; k + 2 * m < n; ++k) {
    const double d = theta[k + 2 * m] - 2 * theta[k + m] + theta[k];
    sum += d * d;
  }
  return std::sqrt(sum / (2.0 * m * m * (n - 2 * m)));
}

double StdDev(const std::vector<double>& x) {
  double mean = 0.0;
  for (double v : x) mean += v;
  mean /= x.size();
  double s = 0.0;
  for (double v : x) s += (v - mean) * (v - mean);
  return std::sqrt(s / (x.size() - 1));
}

}  // namespace

TEST_CASE("noise-free IMU integrates back to the ground truth", "[sim][imu]") {
  const vilma::sim::World world = vilma::sim::MakePresetWorld("room", 1);
  vilma::sim::TrajectoryOptions o;
  o.duration_s = 40.0;
  const vilma::sim::Trajectory traj = vilma::sim::GenerateTrajectory(world, o, 3);
  Rng rng(1);
  const ImuSimResult r = vilma::sim::SimulateImu(traj, kT0, 40.0, ImuSimOptions::NoiseFree(), &rng);
  REQUIRE(r.samples.size() == 8001);
  // From the first state (static start, then motion) and from the middle of the motion.
  for (int start : {0, 2000, 5000}) {
    const int end = start + 2000;  // 10 s at 200 Hz
    const auto& g0 = r.ground_truth[start];
    const auto& g1 = r.ground_truth[end];
    const std::vector<ImuSample> samples(r.samples.begin() + start, r.samples.begin() + end + 1);
    const vilma::ImuState s = vilma::IntegrateImu(StateFrom(g0), samples, g1.t_ns);
    const double dp = (s.p_W_I - g1.p_W_I).norm();
    const double dv = (s.v_W - g1.v_W).norm();
    const double dq = vilma::AngleBetween(s.q_W_I, g1.q_W_I);
    std::cout << "[sim imu] noise-free integration over 10 s from sample " << start
              << ": position error " << dp * 1e3 << " mm, velocity error " << dv * 1e3
              << " mm/s, rotation error " << dq * 1e6 << " urad\n";
    CHECK(dp < 1e-3);
    CHECK(dv < 1e-3);
    CHECK(dq < 1e-4);
  }
}

TEST_CASE("static IMU measures gravity in the body frame plus biases", "[sim][imu]") {
  const vilma::Transformation T_W_I(vilma::ExpSO3(Vector3d(0.2, -0.1, 0.5)), Vector3d(1, 2, 3));
  const auto traj = vilma::sim::MakeStaticTrajectory(T_W_I, 5.0);
  ImuSimOptions o = ImuSimOptions::NoiseFree();
  o.initial_gyro_bias_sigma = 0.01;
  o.initial_accel_bias_sigma = 0.1;
  Rng rng(2);
  const ImuSimResult r = vilma::sim::SimulateImu(traj, kT0, 5.0, o, &rng);
  const Vector3d f_I = T_W_I.rotation().conjugate() * Vector3d(0, 0, 9.81);
  for (size_t i = 0; i < r.samples.size(); i += 97) {
    CHECK((r.samples[i].a_I - r.ground_truth[i].b_a - f_I).norm() < 1e-9);
    CHECK((r.samples[i].omega_I - r.ground_truth[i].b_g).norm() < 1e-9);
  }
  CHECK(r.ground_truth[0].b_a.norm() > 0.0);
  CHECK(r.samples[1].t_ns - r.samples[0].t_ns == 5000000);
}

TEST_CASE("white noise: sample std and Allan deviation match the densities", "[sim][imu]") {
  const auto traj = vilma::sim::MakeStaticTrajectory(
      vilma::Transformation(Eigen::Quaterniond(vilma::sim::Trajectory::R_L_I()), Vector3d::Zero()),
      10.0);
  ImuSimOptions o;
  o.add_bias_random_walk = false;
  o.initial_gyro_bias_sigma = 0.0;
  o.initial_accel_bias_sigma = 0.0;
  const double seconds = 2000.0;
  Rng rng(3);
  const ImuSimResult r = vilma::sim::SimulateImu(traj, kT0, seconds, o, &rng);
  const double dt = 1.0 / o.rate_hz;
  const Vector3d f_I = traj.Evaluate(0).T_W_I.rotation().conjugate() * Vector3d(0, 0, 9.81);
  for (int axis = 0; axis < 3; ++axis) {
    std::vector<double> g, a;
    for (const ImuSample& s : r.samples) {
      g.push_back(s.omega_I[axis]);
      a.push_back(s.a_I[axis] - f_I[axis]);
    }
    const double sg = StdDev(g) * std::sqrt(dt) / o.noise.gyroscope_noise_density;
    const double sa = StdDev(a) * std::sqrt(dt) / o.noise.accelerometer_noise_density;
    // ADEV at tau = 1 s equals the density for white noise: sigma(tau) = N / sqrt(tau).
    const int m = static_cast<int>(o.rate_hz);
    const double ag = AllanDeviation(g, m) / o.noise.gyroscope_noise_density;
    const double aa = AllanDeviation(a, m) / o.noise.accelerometer_noise_density;
    std::cout << "[sim imu] axis " << axis << ": std/expected gyro " << sg << " accel " << sa
              << ", ADEV(1 s)/density gyro " << ag << " accel " << aa << "\n";
    CHECK(std::abs(sg - 1.0) < 0.02);
    CHECK(std::abs(sa - 1.0) < 0.02);
    CHECK(std::abs(ag - 1.0) < 0.1);
    CHECK(std::abs(aa - 1.0) < 0.1);
  }
}

TEST_CASE("bias random walk grows as random_walk * sqrt(T)", "[sim][imu]") {
  const auto traj = vilma::sim::MakeStaticTrajectory(vilma::Transformation(), 10.0);
  ImuSimOptions o;
  o.add_white_noise = false;
  const double seconds = 4000.0, T = 10.0;
  Rng rng(4);
  const ImuSimResult r = vilma::sim::SimulateImu(traj, kT0, seconds, o, &rng);
  const int step = static_cast<int>(T * o.rate_hz);
  std::vector<double> dg, da;
  for (size_t k = 0; k + step < r.ground_truth.size(); k += step) {
    for (int axis = 0; axis < 3; ++axis) {
      dg.push_back(r.ground_truth[k + step].b_g[axis] - r.ground_truth[k].b_g[axis]);
      da.push_back(r.ground_truth[k + step].b_a[axis] - r.ground_truth[k].b_a[axis]);
    }
  }
  const double rg = StdDev(dg) / (o.noise.gyroscope_random_walk * std::sqrt(T));
  const double ra = StdDev(da) / (o.noise.accelerometer_random_walk * std::sqrt(T));
  std::cout << "[sim imu] bias increment std over " << T << " s / (rw sqrt(T)): gyro " << rg
            << " accel " << ra << " (" << dg.size() << " increments)\n";
  CHECK(std::abs(rg - 1.0) < 0.1);
  CHECK(std::abs(ra - 1.0) < 0.1);
  // The measurements carry the bias: sample = truth + b.
  CHECK((r.samples.back().omega_I - r.ground_truth.back().b_g).norm() < 1e-12);
}
