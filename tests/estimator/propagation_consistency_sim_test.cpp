// Consistency of the filter's IMU propagation with the simulator's IMU noise (issue 17, session
// 35; docs/estimator-stereo-history.md "Stereo and noisy IMUs: the consistency checks"). The filter
// is started at the true state (pose, velocity and the true biases, zero covariance) on a simulated
// trajectory and propagated without updates exactly as VioFilter::Propagate does it (the
// midpoint of each IMU interval, PropagateMean + PropagateCovariance with the rig's densities),
// over many independent draws of the simulated IMU (white noise and bias random walk). The
// spread of the errors against the truth must match the propagated covariance: the mean NEES
// of each 3-DoF block (position, velocity, attitude, gyro bias, accelerometer bias) is ~3 and the
// error variance per axis matches the covariance's diagonal. A unit error in the white noise
// (sigma_c vs sigma_c / sqrt(dt)) or in the random walk (sigma^2 dt) of either the simulator or
// the filter shows as a NEES off by a factor of dt or 1/dt.
#include <Eigen/Core>
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "vilma/core/geometry.h"
#include "vilma/core/rig.h"
#include "vilma/estimator/filter_state.h"
#include "vilma/estimator/propagation.h"
#include "vilma/sim/imu_sim.h"
#include "vilma/sim/random.h"
#include "vilma/sim/trajectory.h"
#include "vilma/sim/world.h"

namespace vilma::estimator {
namespace {

constexpr int kBlocks = 5;  // p, v, theta, b_g, b_a
const char* const kBlockNames[kBlocks] = {"position", "velocity", "attitude", "gyro bias",
                                          "accel bias"};
constexpr int kBlockIndex[kBlocks] = {kIdxP, kIdxV, kIdxQ, kIdxBg, kIdxBa};

struct DrawResult {
  Eigen::Matrix<double, 15, 1> error;  // truth (-) estimate: dp, dv, dtheta (right), db_g, db_a
  Eigen::Matrix<double, 15, 15> P;
};

// One IMU draw: the filter from the true state at `t_start_s`, propagated `horizon_s`.
DrawResult PropagateDraw(const sim::Trajectory& trajectory, const sim::ImuSimOptions& imu_options,
                         uint64_t seed, double t_start_s, double horizon_s) {
  sim::Rng rng(seed);
  const int64_t t0_ns = 1000000000;
  const sim::ImuSimResult imu =
      sim::SimulateImu(trajectory, t0_ns, t_start_s + horizon_s + 0.1, imu_options, &rng);
  const auto k0 = static_cast<std::size_t>(std::llround(t_start_s * imu_options.rate_hz));
  const auto k1 = k0 + static_cast<std::size_t>(std::llround(horizon_s * imu_options.rate_hz));
  REQUIRE(k1 < imu.samples.size());
  const GroundTruthState& g0 = imu.ground_truth[k0];
  FilterState x;
  x.t_ns = g0.t_ns;
  x.p_M_I = g0.p_W_I;
  x.v_M = g0.v_W;
  x.q_M_I = g0.q_W_I;
  x.b_g = g0.b_g;
  x.b_a = g0.b_a;
  Eigen::MatrixXd P = Eigen::MatrixXd::Zero(x.dim(), x.dim());
  PropagationNoise noise;
  noise.gyro_noise_density = imu_options.noise.gyroscope_noise_density;
  noise.accel_noise_density = imu_options.noise.accelerometer_noise_density;
  noise.gyro_random_walk = imu_options.noise.gyroscope_random_walk;
  noise.accel_random_walk = imu_options.noise.accelerometer_random_walk;
  PropagationJacobians J;
  J.Resize(0);
  PropagationWorkspace work;
  for (std::size_t k = k0; k < k1; ++k) {
    // VioFilter::Propagate: the measurement interpolated at the interval's midpoint.
    const double dt = 1e-9 * static_cast<double>(imu.samples[k + 1].t_ns - imu.samples[k].t_ns);
    PropagateMean(0.5 * (imu.samples[k].omega_I + imu.samples[k + 1].omega_I),
                  0.5 * (imu.samples[k].a_I + imu.samples[k + 1].a_I), dt, 9.81, &x, &J);
    PropagateCovariance(J, noise, dt, x.features, &P, &work);
  }
  const GroundTruthState& g1 = imu.ground_truth[k1];
  DrawResult r;
  r.error.segment<3>(0) = g1.p_W_I - x.p_M_I;
  r.error.segment<3>(3) = g1.v_W - x.v_M;
  r.error.segment<3>(6) = LogSO3(x.q_M_I.conjugate() * g1.q_W_I);
  r.error.segment<3>(9) = g1.b_g - x.b_g;
  r.error.segment<3>(12) = g1.b_a - x.b_a;
  for (int a = 0; a < kBlocks; ++a) {
    for (int b = 0; b < kBlocks; ++b) {
      r.P.block<3, 3>(3 * a, 3 * b) = P.block<3, 3>(kBlockIndex[a], kBlockIndex[b]);
    }
  }
  return r;
}

TEST_CASE("IMU-only propagation: the error spread over IMU draws matches the covariance (NEES)") {
  const std::string world_name = GENERATE(std::string("street"), std::string("room"));
  const double horizon_s = GENERATE(1.0, 5.0);
  const sim::World world = sim::MakePresetWorld(world_name, 1);
  sim::TrajectoryOptions topt;
  topt.duration_s = 20.0;
  topt.static_start_s = 1.0;
  const sim::Trajectory trajectory = sim::GenerateTrajectory(world, topt, 11);
  sim::ImuSimOptions imu_options;  // the simulator's defaults (EuRoC ADIS16448 densities)
  imu_options.gravity_magnitude = 9.81;
  const int draws = 400;
  double nees_block[kBlocks] = {0, 0, 0, 0, 0};
  double nees_all = 0.0;
  Eigen::Matrix<double, 15, 1> error_var = Eigen::Matrix<double, 15, 1>::Zero();
  Eigen::Matrix<double, 15, 1> p_diag = Eigen::Matrix<double, 15, 1>::Zero();
  for (int d = 0; d < draws; ++d) {
    const DrawResult r =
        PropagateDraw(trajectory, imu_options, sim::DeriveSeed(77, d), 4.0, horizon_s);
    for (int b = 0; b < kBlocks; ++b) {
      const Eigen::Vector3d e = r.error.segment<3>(3 * b);
      nees_block[b] += e.dot(r.P.block<3, 3>(3 * b, 3 * b).ldlt().solve(e)) / draws;
    }
    nees_all += r.error.dot(r.P.ldlt().solve(r.error)) / draws;
    error_var += r.error.cwiseAbs2() / draws;
    p_diag += r.P.diagonal() / draws;
  }
  {
    sim::ImuSimOptions exact = sim::ImuSimOptions::NoiseFree();
    exact.gravity_magnitude = 9.81;
    const DrawResult r = PropagateDraw(trajectory, exact, 1, 4.0, horizon_s);
    std::printf(
        "%s, %.0f s, exact IMU: error p (%+.2e %+.2e %+.2e) m, v (%+.2e %+.2e %+.2e) m/s, "
        "theta (%+.2e %+.2e %+.2e) rad\n",
        world_name.c_str(), horizon_s, r.error[0], r.error[1], r.error[2], r.error[3], r.error[4],
        r.error[5], r.error[6], r.error[7], r.error[8]);
  }
  std::printf("%s, %.0f s without updates, %d IMU draws: NEES (3 = consistent)", world_name.c_str(),
              horizon_s, draws);
  for (int b = 0; b < kBlocks; ++b) std::printf(" %s %.2f,", kBlockNames[b], nees_block[b]);
  std::printf(" all 15: %.2f\n  error variance / covariance per axis:", nees_all);
  for (int i = 0; i < 15; ++i) std::printf(" %.2f", error_var[i] / p_diag[i]);
  std::printf("\n");
  // Mean of `draws` chi^2_3 variables: std sqrt(6 / 400) = 0.12; a units error is a factor of
  // 200 (dt = 5 ms), a lost factor 2 is 6 or 1.5.
  for (int b = 0; b < kBlocks; ++b) {
    INFO(world_name << ", " << horizon_s << " s: NEES of the " << kBlockNames[b] << " block "
                    << nees_block[b]);
    CHECK(nees_block[b] > 2.5);
    CHECK(nees_block[b] < 3.5);
  }
  CHECK(nees_all > 15.0 - 1.5);
  CHECK(nees_all < 15.0 + 1.5);
  for (int i = 0; i < 15; ++i) {
    INFO("axis " << i << ": error variance / covariance " << error_var[i] / p_diag[i]);
    CHECK(error_var[i] / p_diag[i] > 0.7);
    CHECK(error_var[i] / p_diag[i] < 1.4);
  }
}

}  // namespace
}  // namespace vilma::estimator
