#include "vilma/sim/imu_sim.h"

#include <cmath>
#include <stdexcept>

namespace vilma {
namespace sim {

std::string ImuSimOptions::Validate() const {
  if (!(rate_hz > 0.0 && rate_hz <= 100000.0)) return "rate_hz: expected (0, 100000]";
  const std::string e = noise.Validate();
  if (!e.empty()) return "noise: " + e;
  if (!(initial_gyro_bias_sigma >= 0.0) || !(initial_accel_bias_sigma >= 0.0))
    return "initial bias sigmas: expected >= 0";
  if (!(gravity_magnitude > 0.0)) return "gravity_magnitude: expected > 0";
  return "";
}

ImuSimOptions ImuSimOptions::NoiseFree() {
  ImuSimOptions o;
  o.add_white_noise = false;
  o.add_bias_random_walk = false;
  o.initial_gyro_bias_sigma = 0.0;
  o.initial_accel_bias_sigma = 0.0;
  return o;
}

ImuSimResult SimulateImu(const Trajectory& trajectory, int64_t t0_ns, double duration_s,
                         const ImuSimOptions& options, Rng* rng) {
  const std::string error = options.Validate();
  if (!error.empty()) throw std::invalid_argument("ImuSimOptions: " + error);
  const double dt = 1.0 / options.rate_hz;
  const Eigen::Vector3d g_W(0.0, 0.0, -options.gravity_magnitude);
  const double sigma_g = options.noise.gyroscope_noise_density / std::sqrt(dt);
  const double sigma_a = options.noise.accelerometer_noise_density / std::sqrt(dt);
  const double sigma_bg = options.noise.gyroscope_random_walk * std::sqrt(dt);
  const double sigma_ba = options.noise.accelerometer_random_walk * std::sqrt(dt);
  // Draws in a fixed order (x, y, z): argument evaluation order is unspecified in C++.
  auto normal3 = [rng](double sigma) {
    Eigen::Vector3d n;
    for (int i = 0; i < 3; ++i) n[i] = rng->Normal(0.0, sigma);
    return n;
  };
  Eigen::Vector3d b_g = normal3(options.initial_gyro_bias_sigma);
  Eigen::Vector3d b_a = normal3(options.initial_accel_bias_sigma);

  ImuSimResult result;
  const int64_t num = static_cast<int64_t>(std::floor(duration_s * options.rate_hz + 1e-9)) + 1;
  result.samples.reserve(num);
  result.ground_truth.reserve(num);
  for (int64_t k = 0; k < num; ++k) {
    // Integer nanosecond stamps; the trajectory is evaluated exactly at the stamp.
    const int64_t t_ns = t0_ns + static_cast<int64_t>(std::llround(k * 1e9 / options.rate_hz));
    const double t_s = static_cast<double>(t_ns - t0_ns) * 1e-9;
    const TrajectoryState s = trajectory.Evaluate(t_s);
    const Eigen::Matrix3d R_W_I = s.T_W_I.rotationMatrix();
    ImuSample sample;
    sample.t_ns = t_ns;
    sample.omega_I = s.omega_I + b_g;
    sample.a_I = R_W_I.transpose() * (s.a_W - g_W) + b_a;
    if (options.add_white_noise) {
      sample.omega_I += normal3(sigma_g);
      sample.a_I += normal3(sigma_a);
    }
    GroundTruthState gt;
    gt.t_ns = t_ns;
    gt.p_W_I = s.T_W_I.translation();
    gt.q_W_I = s.T_W_I.rotation();
    gt.v_W = s.v_W;
    gt.b_g = b_g;
    gt.b_a = b_a;
    result.samples.push_back(sample);
    result.ground_truth.push_back(gt);
    if (options.add_bias_random_walk) {
      b_g += normal3(sigma_bg);
      b_a += normal3(sigma_ba);
    }
  }
  return result;
}

}  // namespace sim
}  // namespace vilma
