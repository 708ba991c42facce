#include "vilma/estimator/imu_preintegration.h"

#include <algorithm>

#include "vilma/core/geometry.h"

namespace vilma::estimator {
namespace {

// Measurement at t: linear interpolation, held constant outside the samples.
void MeasurementAt(const std::vector<ImuSample>& samples, int64_t t, Eigen::Vector3d* omega,
                   Eigen::Vector3d* a) {
  if (samples.empty()) {
    omega->setZero();
    a->setZero();
    return;
  }
  auto it = std::upper_bound(samples.begin(), samples.end(), t,
                             [](int64_t v, const ImuSample& s) { return v < s.t_ns; });
  if (it == samples.begin()) {
    *omega = it->omega_I;
    *a = it->a_I;
  } else if (it == samples.end()) {
    *omega = samples.back().omega_I;
    *a = samples.back().a_I;
  } else {
    const ImuSample s = InterpolateImu(*(it - 1), *it, t);
    *omega = s.omega_I;
    *a = s.a_I;
  }
}

// One piece of length dt with bias-corrected rates omega and specific force a. The specific
// force is rotated with the attitude at the middle of the piece, R_m = R Exp(omega dt / 2)
// (second order; the start attitude would leave 7 mm/s per second at 0.6 rad/s), and every
// Jacobian is the exact derivative of this step:
//   R_m(bg + d) = R Exp(J d) Exp((omega - d) dt / 2) ~ R_m Exp(J_m d),
//   J_m = Exp(omega dt / 2)^T J - Jr(omega dt / 2) dt / 2,   d(R_m a) / d bg = -R_m [a]x J_m.
void Step(const Eigen::Vector3d& omega, const Eigen::Vector3d& a, double dt,
          PreintegratedImu* p) {
  const Eigen::Vector3d half_phi = 0.5 * dt * omega;
  const Eigen::Matrix3d half_R = ExpSO3(half_phi).toRotationMatrix();
  const Eigen::Matrix3d R_m = p->q_0_k.toRotationMatrix() * half_R;
  const Eigen::Matrix3d J_m = half_R.transpose() * p->d_R_d_bg -
                              RightJacobianSO3(half_phi) * (0.5 * dt);
  const Eigen::Matrix3d d_Ra_d_bg = -R_m * Skew(a) * J_m;
  const double dt2 = 0.5 * dt * dt;
  p->d_alpha_d_bg += p->d_beta_d_bg * dt + d_Ra_d_bg * dt2;
  p->d_alpha_d_ba += p->d_beta_d_ba * dt - R_m * dt2;
  p->d_beta_d_bg += d_Ra_d_bg * dt;
  p->d_beta_d_ba -= R_m * dt;
  // R' = R Exp(omega dt): R'(bg + d) ~ R' Exp(Exp(omega dt)^T J d - Jr(omega dt) dt d).
  const Eigen::Vector3d phi = omega * dt;
  const Eigen::Quaterniond dq = ExpSO3(phi);
  p->d_R_d_bg = dq.toRotationMatrix().transpose() * p->d_R_d_bg - RightJacobianSO3(phi) * dt;
  const Eigen::Vector3d Ra = R_m * a;
  p->alpha += p->beta * dt + Ra * dt2;
  p->beta += Ra * dt;
  p->q_0_k = (p->q_0_k * dq).normalized();
}

}  // namespace

std::vector<PreintegratedImu> PreintegrateImu(const std::vector<ImuSample>& samples,
                                              const std::vector<int64_t>& frame_t_ns,
                                              const Eigen::Vector3d& b_g,
                                              const Eigen::Vector3d& b_a) {
  std::vector<PreintegratedImu> result;
  if (frame_t_ns.empty()) return result;
  result.reserve(frame_t_ns.size());
  PreintegratedImu p;
  result.push_back(p);
  int64_t t = frame_t_ns.front();
  auto next_sample = std::upper_bound(samples.begin(), samples.end(), t,
                                      [](int64_t v, const ImuSample& s) { return v < s.t_ns; });
  for (std::size_t k = 1; k < frame_t_ns.size(); ++k) {
    const int64_t t_frame = frame_t_ns[k];
    while (t < t_frame) {
      while (next_sample != samples.end() && next_sample->t_ns <= t) ++next_sample;
      const int64_t t1 = next_sample == samples.end() ? t_frame
                                                      : std::min(next_sample->t_ns, t_frame);
      Eigen::Vector3d omega, a;
      MeasurementAt(samples, t + (t1 - t) / 2, &omega, &a);
      Step(omega - b_g, a - b_a, static_cast<double>(t1 - t) * 1e-9, &p);
      t = t1;
    }
    p.dt_s = static_cast<double>(t_frame - frame_t_ns.front()) * 1e-9;  // no rounding drift
    result.push_back(p);
  }
  return result;
}

}  // namespace vilma::estimator
