#include "vilma/core/imu.h"

#include <cmath>
#include <stdexcept>

#include "vilma/core/geometry.h"

namespace vilma {

std::string ImuNoise::Validate() const {
  const struct {
    const char* name;
    double value;
  } fields[] = {{"gyroscope_noise_density", gyroscope_noise_density},
                {"gyroscope_random_walk", gyroscope_random_walk},
                {"accelerometer_noise_density", accelerometer_noise_density},
                {"accelerometer_random_walk", accelerometer_random_walk}};
  for (const auto& f : fields) {
    if (!std::isfinite(f.value) || f.value < 0.0) {
      return std::string(f.name) + ": expected a finite number >= 0, got " +
             std::to_string(f.value);
    }
  }
  return "";
}

ImuSample InterpolateImu(const ImuSample& a, const ImuSample& b, int64_t t_ns) {
  if (b.t_ns == a.t_ns) return a;
  const double alpha = static_cast<double>(t_ns - a.t_ns) / static_cast<double>(b.t_ns - a.t_ns);
  ImuSample s;
  s.t_ns = t_ns;
  s.omega_I = (1.0 - alpha) * a.omega_I + alpha * b.omega_I;
  s.a_I = (1.0 - alpha) * a.a_I + alpha * b.a_I;
  return s;
}

namespace {

// Time derivative of the navigation state (q as a 4-vector w, x, y, z):
//   q_dot = 1/2 q (x) [0, omega],  p_dot = v,  v_dot = R(q) a + g_W.
struct Derivative {
  Eigen::Vector4d q_dot;
  Eigen::Vector3d p_dot;
  Eigen::Vector3d v_dot;
};

Derivative StateDerivative(const Eigen::Vector4d& q_wxyz, const Eigen::Vector3d& v_W,
                           const Eigen::Vector3d& omega_I, const Eigen::Vector3d& a_I,
                           const Eigen::Vector3d& g_W) {
  const Eigen::Quaterniond q(q_wxyz[0], q_wxyz[1], q_wxyz[2], q_wxyz[3]);
  const Eigen::Quaterniond omega_q(0.0, omega_I.x(), omega_I.y(), omega_I.z());
  const Eigen::Quaterniond q_dot = q * omega_q;  // not normalized: a tangent, halved below
  Derivative d;
  d.q_dot << 0.5 * q_dot.w(), 0.5 * q_dot.x(), 0.5 * q_dot.y(), 0.5 * q_dot.z();
  d.p_dot = v_W;
  // The quaternion is not unit inside the RK stages; rotate with its normalized version.
  d.v_dot = q.normalized() * a_I + g_W;
  return d;
}

}  // namespace

ImuState IntegrateImu(const ImuState& start, const std::vector<ImuSample>& samples,
                      int64_t t_end_ns, double gravity_magnitude) {
  if (t_end_ns < start.t_ns) throw std::invalid_argument("IntegrateImu: t_end before start");
  if (t_end_ns == start.t_ns) return start;
  if (samples.size() < 2 || samples.front().t_ns > start.t_ns || samples.back().t_ns < t_end_ns) {
    throw std::invalid_argument("IntegrateImu: samples do not cover the integration interval");
  }
  const Eigen::Vector3d g_W(0.0, 0.0, -gravity_magnitude);

  ImuState state = start;
  Eigen::Vector4d q(state.q_W_I.w(), state.q_W_I.x(), state.q_W_I.y(), state.q_W_I.z());
  std::size_t i = 0;
  while (i + 1 < samples.size() && samples[i + 1].t_ns <= state.t_ns) ++i;

  int64_t t_ns = state.t_ns;
  while (t_ns < t_end_ns) {
    while (samples[i + 1].t_ns <= t_ns) ++i;
    const int64_t t1_ns = std::min(samples[i + 1].t_ns, t_end_ns);
    const double h = static_cast<double>(t1_ns - t_ns) * 1e-9;
    // Measurements are linear in time between samples: evaluate them at the RK4 nodes.
    const ImuSample m0 = InterpolateImu(samples[i], samples[i + 1], t_ns);
    const ImuSample m1 = InterpolateImu(samples[i], samples[i + 1], t1_ns);
    const Eigen::Vector3d w0 = m0.omega_I - state.b_g, w1 = m1.omega_I - state.b_g;
    const Eigen::Vector3d a0 = m0.a_I - state.b_a, a1 = m1.a_I - state.b_a;
    const Eigen::Vector3d wm = 0.5 * (w0 + w1), am = 0.5 * (a0 + a1);

    const Eigen::Vector3d p = state.p_W_I, v = state.v_W;
    const Derivative k1 = StateDerivative(q, v, w0, a0, g_W);
    const Derivative k2 =
        StateDerivative(q + 0.5 * h * k1.q_dot, v + 0.5 * h * k1.v_dot, wm, am, g_W);
    const Derivative k3 =
        StateDerivative(q + 0.5 * h * k2.q_dot, v + 0.5 * h * k2.v_dot, wm, am, g_W);
    const Derivative k4 = StateDerivative(q + h * k3.q_dot, v + h * k3.v_dot, w1, a1, g_W);

    q += h / 6.0 * (k1.q_dot + 2.0 * k2.q_dot + 2.0 * k3.q_dot + k4.q_dot);
    q.normalize();
    state.p_W_I = p + h / 6.0 * (k1.p_dot + 2.0 * k2.p_dot + 2.0 * k3.p_dot + k4.p_dot);
    state.v_W = v + h / 6.0 * (k1.v_dot + 2.0 * k2.v_dot + 2.0 * k3.v_dot + k4.v_dot);
    t_ns = t1_ns;
  }
  state.t_ns = t_end_ns;
  state.q_W_I = Eigen::Quaterniond(q[0], q[1], q[2], q[3]);
  return state;
}

}  // namespace vilma
