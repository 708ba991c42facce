// IMU model: samples, continuous-time noise densities (Kalibr / EuRoC convention), gravity.
// Measurement model (body frame I, world frame W with gravity g_W = (0, 0, -g)):
//   omega_meas = omega_I + b_g + n_g,        n_g ~ N(0, sigma_g^2 / dt)
//   a_meas     = R_W_I^T (a_W - g_W) + b_a + n_a,  n_a ~ N(0, sigma_a^2 / dt)
//   d b_g / dt = n_bg, n_bg ~ N(0, sigma_bg^2)  (random walk)   likewise b_a.
#pragma once

#include <Eigen/Core>
#include <Eigen/Geometry>
#include <cstdint>
#include <string>
#include <vector>

namespace vilma {

// Standard gravity magnitude used by default (EuRoC and Kalibr use 9.81).
constexpr double kDefaultGravityMagnitude = 9.81;

struct ImuSample {
  int64_t t_ns = 0;                                      // sample time [ns]
  Eigen::Vector3d omega_I = Eigen::Vector3d::Zero();     // angular velocity [rad/s]
  Eigen::Vector3d a_I = Eigen::Vector3d::Zero();         // specific force [m/s^2]
};

struct ImuNoise {
  double gyroscope_noise_density = 1.6968e-04;      // [rad/s/sqrt(Hz)] (EuRoC ADIS16448)
  double gyroscope_random_walk = 1.9393e-05;        // [rad/s^2/sqrt(Hz)]
  double accelerometer_noise_density = 2.0000e-3;   // [m/s^2/sqrt(Hz)]
  double accelerometer_random_walk = 3.0000e-3;     // [m/s^3/sqrt(Hz)]

  // Empty if valid, else which density is wrong (all must be finite and >= 0).
  std::string Validate() const;
};

// Navigation state of the IMU in a gravity-aligned world frame W.
struct ImuState {
  int64_t t_ns = 0;
  Eigen::Quaterniond q_W_I = Eigen::Quaterniond::Identity();
  Eigen::Vector3d p_W_I = Eigen::Vector3d::Zero();
  Eigen::Vector3d v_W = Eigen::Vector3d::Zero();
  Eigen::Vector3d b_g = Eigen::Vector3d::Zero();  // gyroscope bias [rad/s]
  Eigen::Vector3d b_a = Eigen::Vector3d::Zero();  // accelerometer bias [m/s^2]
};

// Strapdown integration of `samples` (sorted by time, starting at or before state.t_ns) up to
// `t_end_ns`, with biases held constant, by fourth-order Runge-Kutta on the linearly
// interpolated measurements. Gravity g_W = (0, 0, -gravity_magnitude).
ImuState IntegrateImu(const ImuState& start, const std::vector<ImuSample>& samples,
                      int64_t t_end_ns, double gravity_magnitude = kDefaultGravityMagnitude);

// Linear interpolation of a sample at t_ns between two samples a.t_ns <= t_ns <= b.t_ns.
ImuSample InterpolateImu(const ImuSample& a, const ImuSample& b, int64_t t_ns);

}  // namespace vilma
