#include "vilma/estimator/imu_preintegration.h"

#include <catch2/catch.hpp>
#include <cmath>

#include "vilma/core/geometry.h"

namespace vilma::estimator {
namespace {

// 1.2 s of smooth, strongly varying IMU at 200 Hz.
std::vector<ImuSample> MakeImu() {
  std::vector<ImuSample> samples;
  for (int i = 0; i <= 240; ++i) {
    const double t = 0.005 * i;
    ImuSample s;
    s.t_ns = 1'000'000'000 + static_cast<int64_t>(i) * 5'000'000;
    s.omega_I = Eigen::Vector3d(0.6 * std::sin(1.1 * t), -0.4 * std::cos(0.7 * t) + 0.2,
                                0.5 * std::sin(1.7 * t + 0.3));
    s.a_I = Eigen::Vector3d(1.5 * std::sin(2.0 * t), 0.8 * std::cos(1.5 * t) - 0.3,
                            9.81 + 0.7 * std::sin(t));
    samples.push_back(s);
  }
  return samples;
}

const std::vector<int64_t> kFrames = {1'002'500'000, 1'050'000'000, 1'403'000'000,
                                      2'000'000'000, 2'150'000'000};

}  // namespace

TEST_CASE("preintegration bias Jacobians match central differences") {
  const std::vector<ImuSample> imu = MakeImu();
  const Eigen::Vector3d b_g(0.01, -0.03, 0.08), b_a(0.1, -0.2, 0.05);
  const std::vector<PreintegratedImu> pre = PreintegrateImu(imu, kFrames, b_g, b_a);
  REQUIRE(pre.size() == kFrames.size());
  CHECK(pre[0].dt_s == 0.0);
  CHECK(pre[0].alpha.norm() == 0.0);
  const double h = 1e-5;
  for (std::size_t k = 1; k < kFrames.size(); ++k) {
    CHECK(pre[k].dt_s == Approx(static_cast<double>(kFrames[k] - kFrames[0]) * 1e-9));
    Eigen::Matrix3d dR_g, da_g, da_a, db_g, db_a;
    for (int j = 0; j < 3; ++j) {
      const Eigen::Vector3d e = Eigen::Vector3d::Unit(j) * h;
      const PreintegratedImu gp = PreintegrateImu(imu, kFrames, b_g + e, b_a)[k];
      const PreintegratedImu gm = PreintegrateImu(imu, kFrames, b_g - e, b_a)[k];
      const PreintegratedImu ap = PreintegrateImu(imu, kFrames, b_g, b_a + e)[k];
      const PreintegratedImu am = PreintegrateImu(imu, kFrames, b_g, b_a - e)[k];
      // Right perturbation: Log(R^T R(b + e)) / h.
      dR_g.col(j) = (LogSO3(pre[k].q_0_k.conjugate() * gp.q_0_k) -
                     LogSO3(pre[k].q_0_k.conjugate() * gm.q_0_k)) / (2 * h);
      da_g.col(j) = (gp.alpha - gm.alpha) / (2 * h);
      db_g.col(j) = (gp.beta - gm.beta) / (2 * h);
      da_a.col(j) = (ap.alpha - am.alpha) / (2 * h);
      db_a.col(j) = (ap.beta - am.beta) / (2 * h);
      // The rotation does not depend on the accelerometer bias.
      CHECK(LogSO3(ap.q_0_k.conjugate() * am.q_0_k).norm() < 1e-12);
    }
    INFO("frame " << k);
    CHECK((dR_g - pre[k].d_R_d_bg).norm() < 1e-7);
    CHECK((da_g - pre[k].d_alpha_d_bg).norm() < 1e-7);
    CHECK((db_g - pre[k].d_beta_d_bg).norm() < 1e-7);
    CHECK((da_a - pre[k].d_alpha_d_ba).norm() < 1e-7);
    CHECK((db_a - pre[k].d_beta_d_ba).norm() < 1e-7);
    CHECK(pre[k].d_R_d_bg.norm() > 0.01);  // not trivially zero
  }
  // A wrong Jacobian would be caught: the rotation block is not the alpha block.
  CHECK((pre[3].d_R_d_bg - pre[3].d_alpha_d_bg).norm() > 1e-3);
}

TEST_CASE("preintegration predicts the strapdown integration of core") {
  // p_k = p_0 + R_W_I0 (v_0 t + g t^2/2 + alpha), v_k = R_W_I0 (v_0 + g t + beta) with v_0, g
  // in I0, against IntegrateImu (RK4) from a tilted start.
  const std::vector<ImuSample> imu = MakeImu();
  const Eigen::Vector3d b_g(0.01, -0.03, 0.08), b_a(0.1, -0.2, 0.05);
  ImuState start;
  start.t_ns = kFrames[0];
  start.q_W_I = ExpSO3(Eigen::Vector3d(0.2, -0.1, 0.7));
  start.p_W_I = Eigen::Vector3d(1, 2, 3);
  start.v_W = Eigen::Vector3d(0.3, -0.5, 0.1);
  start.b_g = b_g;
  start.b_a = b_a;
  const std::vector<PreintegratedImu> pre = PreintegrateImu(imu, kFrames, b_g, b_a);
  const Eigen::Matrix3d R_W_I0 = start.q_W_I.toRotationMatrix();
  const Eigen::Vector3d g_I0 = R_W_I0.transpose() * Eigen::Vector3d(0, 0, -9.81);
  const Eigen::Vector3d v_I0 = R_W_I0.transpose() * start.v_W;
  for (std::size_t k = 1; k < kFrames.size(); ++k) {
    const ImuState end = IntegrateImu(start, imu, kFrames[k], 9.81);
    const double t = pre[k].dt_s;
    const Eigen::Vector3d p =
        start.p_W_I + R_W_I0 * (v_I0 * t + 0.5 * t * t * g_I0 + pre[k].alpha);
    const Eigen::Vector3d v = R_W_I0 * (v_I0 + g_I0 * t + pre[k].beta);
    INFO("frame " << k << " t " << t);
    CHECK((p - end.p_W_I).norm() < 2e-4);
    CHECK((v - end.v_W).norm() < 2e-4);
    CHECK(AngleBetween(start.q_W_I * pre[k].q_0_k, end.q_W_I) < 1e-5);
  }
}

}  // namespace vilma::estimator
