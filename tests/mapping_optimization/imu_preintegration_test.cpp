// IMU preintegration against the simulator's noise-free IMU; bias correction vs re-integration;
// long edges; bad input.
#include <catch2/catch.hpp>

#include "vilma/core/geometry.h"
#include "vilma/mapping/optimization/imu_preintegration.h"
#include "vilma/sim/imu_sim.h"
#include "vilma/sim/random.h"
#include "vilma/sim/world.h"

namespace vilma::mapping {
namespace {

struct SimulatedImu {
  sim::ImuSimResult imu;
  double gravity = kDefaultGravityMagnitude;
};

SimulatedImu Simulate(double seconds, double rate_hz = 200.0) {
  const sim::World world = sim::MakePresetWorld("room", 1);
  sim::TrajectoryOptions t;
  t.duration_s = seconds + 1.0;
  t.static_start_s = 0.5;
  const sim::Trajectory trajectory = sim::GenerateTrajectory(world, t, 5);
  sim::ImuSimOptions o = sim::ImuSimOptions::NoiseFree();
  o.rate_hz = rate_hz;
  sim::Rng rng(1);
  SimulatedImu s;
  s.imu = sim::SimulateImu(trajectory, 1'000'000'000LL, seconds, o, &rng);
  return s;
}

// The end state from the start state and the deltas (Forster eq. 33).
void Predict(const GroundTruthState& a, const ImuPreintegration& pre, double g,
             Eigen::Quaterniond* q, Eigen::Vector3d* v, Eigen::Vector3d* p) {
  const Eigen::Vector3d gravity(0, 0, -g);
  const double dt = pre.dt_s();
  *q = a.q_W_I * pre.delta_R();
  *v = a.v_W + gravity * dt + a.q_W_I * pre.delta_v();
  *p = a.p_W_I + a.v_W * dt + 0.5 * gravity * dt * dt + a.q_W_I * pre.delta_p();
}

TEST_CASE("Preintegration over 10 s of noise-free simulated IMU reaches the true end state") {
  const SimulatedImu s = Simulate(10.0);
  const auto& samples = s.imu.samples;
  REQUIRE(samples.size() >= 2000);
  const ImuPreintegration pre(samples, ImuNoise{}, Eigen::Vector3d::Zero(),
                              Eigen::Vector3d::Zero());
  CHECK(pre.dt_s() == Approx(1e-9 * (samples.back().t_ns - samples.front().t_ns)));
  Eigen::Quaterniond q;
  Eigen::Vector3d v, p;
  Predict(s.imu.ground_truth.front(), pre, s.gravity, &q, &v, &p);
  const GroundTruthState& b = s.imu.ground_truth.back();
  const double position_error = (p - b.p_W_I).norm();
  const double rotation_error_deg = AngleBetween(q, b.q_W_I) * 180.0 / M_PI;
  WARN("10 s preintegration at 200 Hz: position error " << position_error * 1000 << " mm, "
       << "velocity " << (v - b.v_W).norm() * 1000 << " mm/s, rotation " << rotation_error_deg
       << " deg");
  CHECK(position_error < 0.001);
  CHECK((v - b.v_W).norm() < 0.0005);
  CHECK(rotation_error_deg < 0.01);
}

TEST_CASE("First-order bias correction agrees with re-integration to second order") {
  const SimulatedImu s = Simulate(1.0);
  const Eigen::Vector3d bg0(0.002, -0.001, 0.003), ba0(0.05, -0.02, 0.03);
  ImuPreintegration pre(s.imu.samples, ImuNoise{}, bg0, ba0);
  for (const double scale : {1.0, 0.5}) {
    const Eigen::Vector3d dbg = Eigen::Vector3d(1e-3, 2e-3, -1e-3) * scale;
    const Eigen::Vector3d dba = Eigen::Vector3d(2e-2, -1e-2, 1e-2) * scale;
    ImuPreintegration again(s.imu.samples, ImuNoise{}, bg0 + dbg, ba0 + dba);
    const double eR = AngleBetween(pre.CorrectedDeltaR(bg0 + dbg), again.delta_R());
    const double ev = (pre.CorrectedDeltaV(bg0 + dbg, ba0 + dba) - again.delta_v()).norm();
    const double ep = (pre.CorrectedDeltaP(bg0 + dbg, ba0 + dba) - again.delta_p()).norm();
    // Without the correction the error is first order in the bias change.
    const double ep_uncorrected = (pre.delta_p() - again.delta_p()).norm();
    CHECK(ep < 0.05 * ep_uncorrected);
    CHECK(ev < 0.05 * (pre.delta_v() - again.delta_v()).norm());
    CHECK(eR < 0.05 * AngleBetween(pre.delta_R(), again.delta_R()));
  }
  CHECK(pre.NeedsReintegration(bg0 + Eigen::Vector3d(0.01, 0, 0), ba0, PreintegrationOptions{}));
  CHECK_FALSE(pre.NeedsReintegration(bg0, ba0, PreintegrationOptions{}));
  pre.Reintegrate(bg0 + Eigen::Vector3d(0.01, 0, 0), ba0);
  CHECK_FALSE(
      pre.NeedsReintegration(bg0 + Eigen::Vector3d(0.01, 0, 0), ba0, PreintegrationOptions{}));
}

TEST_CASE("A long edge (5 s, 1000 samples) equals its parts composed") {
  const SimulatedImu s = Simulate(5.0);
  const auto& all = s.imu.samples;
  REQUIRE(all.size() >= 1000);
  const std::size_t mid = all.size() / 2;
  const std::vector<ImuSample> first(all.begin(), all.begin() + mid + 1);
  const std::vector<ImuSample> second(all.begin() + mid, all.end());
  const Eigen::Vector3d bg(0.001, 0, 0), ba(0, 0.02, 0);
  const ImuPreintegration whole(all, ImuNoise{}, bg, ba);
  const ImuPreintegration a(first, ImuNoise{}, bg, ba), b(second, ImuNoise{}, bg, ba);
  // ΔR_ik = ΔR_ij ΔR_jk, Δv_ik = Δv_ij + ΔR_ij Δv_jk, Δp_ik = Δp_ij + Δv_ij Δt_jk + ΔR_ij Δp_jk.
  CHECK(AngleBetween(whole.delta_R(), a.delta_R() * b.delta_R()) < 1e-9);
  CHECK((whole.delta_v() - (a.delta_v() + a.delta_R() * b.delta_v())).norm() < 1e-9);
  CHECK((whole.delta_p() - (a.delta_p() + a.delta_v() * b.dt_s() + a.delta_R() * b.delta_p()))
            .norm() < 1e-9);
  // The covariance grows with time and stays symmetric positive definite.
  CHECK(whole.covariance().trace() > a.covariance().trace());
  CHECK(Eigen::LLT<Eigen::Matrix<double, 9, 9>>(whole.covariance()).info() == Eigen::Success);
}

TEST_CASE("The covariance's four noise components add up to it and scale with their density") {
  const SimulatedImu s = Simulate(2.0);
  const std::vector<ImuSample> samples(s.imu.samples.begin(), s.imu.samples.begin() + 201);
  ImuNoise noise;  // EuRoC's densities
  const ImuPreintegration pre(samples, noise, Eigen::Vector3d(0.01, -0.02, 0.005),
                              Eigen::Vector3d(0.1, 0.05, -0.2));
  const auto parts = pre.NoiseComponents();
  const Eigen::Matrix<double, 15, 15> sum = parts[0] + parts[1] + parts[2] + parts[3];
  // Equal but for the 1e-12 floor on the covariance of [δφ, δv, δp].
  CHECK((sum - pre.full_covariance()).cwiseAbs().maxCoeff() < 2e-12);
  // Each part is that density's alone: the gyroscope's white noise times 3 -> its part times 9.
  noise.gyroscope_noise_density *= 3.0;
  const ImuPreintegration scaled(samples, noise, pre.gyro_bias(), pre.accel_bias());
  const auto scaled_parts = scaled.NoiseComponents();
  CHECK((scaled_parts[0] - 9.0 * parts[0]).norm() < 1e-9 * parts[0].norm());
  for (int k = 1; k < 4; ++k) CHECK((scaled_parts[k] - parts[k]).norm() == 0.0);
  // The gyroscope's white noise reaches δφ; the accelerometer's does not.
  CHECK(parts[0].block<3, 3>(0, 0).trace() > 0.0);
  CHECK(parts[1].block<3, 3>(0, 0).norm() == 0.0);
}

TEST_CASE("Preintegration refuses bad samples") {
  ImuSample s0, s1;
  s1.t_ns = 5'000'000;
  const Eigen::Vector3d z = Eigen::Vector3d::Zero();
  CHECK_THROWS_WITH(ImuPreintegration({s0}, ImuNoise{}, z, z), Catch::Contains("at least 2"));
  CHECK_THROWS_WITH(ImuPreintegration({s1, s0}, ImuNoise{}, z, z),
                    Catch::Contains("strictly increasing"));
  s1.a_I.x() = std::nan("");
  CHECK_THROWS_WITH(ImuPreintegration({s0, s1}, ImuNoise{}, z, z), Catch::Contains("not finite"));
}

}  // namespace
}  // namespace vilma::mapping
