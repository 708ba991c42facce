// IMU simulation from a trajectory's exact derivatives (imu.h measurement model):
//   omega_meas = omega_I + b_g + n_g,                a_meas = R_W_I^T (a_W - g_W) + b_a + n_a,
//   n ~ N(0, density^2 / dt) per axis (discrete white noise of a continuous density),
//   b_{k+1} = b_k + N(0, random_walk^2 dt) (discrete Wiener process), g_W = (0, 0, -g).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <string>
#include <vector>

#include "vilma/core/asl_dataset.h"
#include "vilma/core/imu.h"
#include "vilma/sim/random.h"
#include "vilma/sim/trajectory.h"

namespace vilma {
namespace sim {

struct ImuSimOptions {
  double rate_hz = 200.0;
  ImuNoise noise;                  // densities (default: EuRoC ADIS16448)
  bool add_white_noise = true;     // false: exact measurements (plus biases)
  bool add_bias_random_walk = true;
  // Initial biases drawn per axis from N(0, sigma^2) (ADIS16448-like turn-on biases).
  double initial_gyro_bias_sigma = 0.003;   // [rad/s]
  double initial_accel_bias_sigma = 0.05;   // [m/s^2]
  double gravity_magnitude = kDefaultGravityMagnitude;  // [m/s^2]

  std::string Validate() const;
  // Everything exact: no noise, no random walk, zero biases (for tests).
  static ImuSimOptions NoiseFree();
};

struct ImuSimResult {
  std::vector<ImuSample> samples;
  // Ground truth at every IMU sample: pose, velocity and the true biases (EuRoC layout).
  std::vector<GroundTruthState> ground_truth;
};

// Samples at t0_ns + k / rate for k = 0 .. while <= t0_ns + duration; trajectory time
// t_s = (t_ns - t0_ns) * 1e-9.
ImuSimResult SimulateImu(const Trajectory& trajectory, int64_t t0_ns, double duration_s,
                         const ImuSimOptions& options, Rng* rng);

}  // namespace sim
}  // namespace vilma
