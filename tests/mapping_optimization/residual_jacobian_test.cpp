// Every residual's analytic (or tangent-autodiff) Jacobian against central differences on the
// tangent space of its blocks (PoseManifold for poses, Euclidean otherwise).
#include <catch2/catch.hpp>

#include <cmath>
#include <memory>
#include <random>

#include "mapstore/synthetic_map.h"
#include "test_random.h"
#include "vilma/mapping/optimization/inertial_residual.h"
#include "vilma/mapping/optimization/pose_manifold.h"
#include "vilma/mapping/optimization/reprojection_residual.h"
#include "vilma/mapping/optimization/time_offset_residual.h"

namespace vilma::mapping {
namespace {

// Checks cost's Jacobians at `blocks` (sizes `ambient`, tangent sizes `tangent`; 7 -> pose).
void CheckJacobians(const ceres::CostFunction& cost, std::vector<std::vector<double>> blocks,
                    double tolerance) {
  const int m = cost.num_residuals();
  const auto& sizes = cost.parameter_block_sizes();
  std::vector<double*> params;
  for (auto& b : blocks) params.push_back(b.data());
  std::vector<std::vector<double>> jac(blocks.size());
  std::vector<double*> jac_ptr;
  for (std::size_t b = 0; b < blocks.size(); ++b) {
    jac[b].assign(static_cast<std::size_t>(m * sizes[b]), 0.0);
    jac_ptr.push_back(jac[b].data());
  }
  Eigen::VectorXd r0(m);
  REQUIRE(cost.Evaluate(params.data(), r0.data(), jac_ptr.data()));
  const PoseManifold pose;
  for (std::size_t b = 0; b < blocks.size(); ++b) {
    const int tangent = sizes[b] == 7 ? 6 : sizes[b];
    for (int k = 0; k < tangent; ++k) {
      const double h = 1e-6;
      Eigen::VectorXd rp(m), rm(m);
      for (const double sign : {1.0, -1.0}) {
        std::vector<std::vector<double>> moved = blocks;
        if (sizes[b] == 7) {
          double delta[6] = {};
          delta[k] = sign * h;
          pose.Plus(blocks[b].data(), delta, moved[b].data());
        } else {
          moved[b][k] += sign * h;
        }
        std::vector<double*> p;
        for (auto& mb : moved) p.push_back(mb.data());
        REQUIRE(cost.Evaluate(p.data(), sign > 0 ? rp.data() : rm.data(), nullptr));
      }
      const Eigen::VectorXd numeric = (rp - rm) / (2 * h);
      Eigen::VectorXd analytic(m);
      for (int i = 0; i < m; ++i) analytic[i] = jac[b][static_cast<std::size_t>(i * sizes[b] + k)];
      INFO("block " << b << " tangent " << k << "\nanalytic " << analytic.transpose()
                    << "\nnumeric  " << numeric.transpose());
      CHECK((analytic - numeric).norm() <= tolerance * std::max(1.0, numeric.norm()));
    }
    if (sizes[b] == 7) {  // the lift convention: the 7th column is zero
      for (int i = 0; i < m; ++i) CHECK(jac[b][static_cast<std::size_t>(i * 7 + 6)] == 0.0);
    }
  }
}

std::vector<double> Pose(std::mt19937_64& rng, double scale) {
  std::normal_distribution<double> n(0.0, 1.0);
  const auto draw = [&] { return n(rng); };
  // The translation first, then the rotation: the order GCC drew them in (tests/test_random.h).
  const Eigen::Vector3d p = vilma::testing::DrawVector3(draw) * scale;
  const Transformation T(vilma::testing::DrawQuaternion(draw).normalized(), p);
  std::vector<double> b(7);
  PoseToBlock(T, b.data());
  return b;
}

TEST_CASE("Reprojection Jacobians (pose, landmark, baseframe, extrinsics) match differences") {
  const SensorRig rig = mapstore::testing::TestRig();
  Camera equidistant(752, 480, Eigen::Vector4d(460, 458, 370, 250), DistortionModel::kEquidistant,
                     Eigen::Vector4d(0.01, -0.02, 0.003, -0.001));
  std::mt19937_64 rng(11);
  std::normal_distribution<double> n(0.0, 1.0);
  for (const Camera* camera : {&rig.cameras[0].camera, static_cast<const Camera*>(&equidistant)}) {
    for (int trial = 0; trial < 5; ++trial) {
      const std::vector<double> T_M_I = Pose(rng, 2.0), T_G_M = Pose(rng, 2.0),
                                T_I_C = Pose(rng, 0.1);
      // A landmark 3-6 m in front of the camera.
      const Transformation T_G_C =
          BlockToPose(T_G_M.data()) * BlockToPose(T_M_I.data()) * BlockToPose(T_I_C.data());
      // z, y, x: the order GCC drew them in (tests/test_random.h).
      const double z = 4.0 + n(rng) * 0.5;
      const double y = 0.3 * n(rng);
      const double x = 0.5 * n(rng);
      const Eigen::Vector3d p_C(x, y, z);
      const Eigen::Vector3d p_G = T_G_C * p_C;
      const ReprojectionCostFunction cost(camera, Eigen::Vector2d(300, 200), 1.5);
      CheckJacobians(cost, {T_M_I, {p_G.x(), p_G.y(), p_G.z()}, T_G_M, T_I_C}, 1e-5);
    }
  }
}

TEST_CASE("Reprojection residual behind the camera is zero with zero Jacobians") {
  const SensorRig rig = mapstore::testing::TestRig();
  std::vector<double> I(7, 0.0);
  I[6] = 1.0;
  std::vector<double> p_G = {0, 0, -2};  // behind: the camera looks along +z with T_I_C = I
  const ReprojectionCostFunction cost(&rig.cameras[0].camera, Eigen::Vector2d(300, 200), 1.0);
  double r[2];
  std::vector<double> j0(14), j1(6), j2(14), j3(14);
  double* jac[4] = {j0.data(), j1.data(), j2.data(), j3.data()};
  const double* params[4] = {I.data(), p_G.data(), I.data(), I.data()};
  REQUIRE(cost.Evaluate(params, r, jac));
  CHECK(r[0] == 0.0);
  CHECK(r[1] == 0.0);
  for (double v : j1) CHECK(v == 0.0);
}

TEST_CASE("Inertial Jacobians match differences, also for a long edge") {
  std::mt19937_64 rng(17);
  std::normal_distribution<double> n(0.0, 1.0);
  for (const int samples : {11, 601}) {
    std::vector<ImuSample> imu;
    for (int k = 0; k < samples; ++k) {
      ImuSample s;
      s.t_ns = 1'000'000'000LL + k * 5'000'000LL;
      // Each vector z, y, x: the order GCC drew them in (tests/test_random.h).
      const double omega_z = 0.1 * n(rng);
      const double omega_y = -0.2 + 0.1 * n(rng);
      const double omega_x = 0.3 + 0.1 * n(rng);
      s.omega_I = Eigen::Vector3d(omega_x, omega_y, omega_z);
      const double a_z = 9.81 + 0.5 * n(rng);
      const double a_y = 0.5 * n(rng);
      const double a_x = 0.5 * n(rng);
      s.a_I = Eigen::Vector3d(a_x, a_y, a_z);
      imu.push_back(s);
    }
    const ImuPreintegration pre(imu, ImuNoise{}, Eigen::Vector3d(0.001, 0, -0.002),
                                Eigen::Vector3d(0.01, 0.02, 0));
    const InertialCostFunction cost(&pre, 9.81);
    for (int trial = 0; trial < 3; ++trial) {
      std::vector<double> sb_i(9), sb_j(9);
      for (int k = 0; k < 9; ++k) {
        sb_i[k] = (k < 3 ? 1.0 : k < 6 ? 0.003 : 0.05) * n(rng);
        sb_j[k] = (k < 3 ? 1.0 : k < 6 ? 0.003 : 0.05) * n(rng);
      }
      CheckJacobians(cost, {Pose(rng, 3.0), sb_i, Pose(rng, 3.0), sb_j}, 2e-5);
    }
  }
}

TEST_CASE("Inertial residual is zero at states consistent with the preintegration") {
  std::vector<ImuSample> imu;
  for (int k = 0; k < 21; ++k) {
    ImuSample s;
    s.t_ns = k * 5'000'000LL;
    s.omega_I = Eigen::Vector3d(0.2, -0.1, 0.3);
    s.a_I = Eigen::Vector3d(0.3, 0.1, 9.81);
    imu.push_back(s);
  }
  const Eigen::Vector3d bg(0.001, 0.002, 0.0), ba(0.01, 0.0, -0.02);
  const ImuPreintegration pre(imu, ImuNoise{}, bg, ba);
  const InertialCostFunction cost(&pre, 9.81);
  const Transformation T_i(ExpSO3(Eigen::Vector3d(0.1, -0.2, 0.7)), Eigen::Vector3d(1, 2, 3));
  const Eigen::Vector3d v_i(0.5, -0.3, 0.1), g(0, 0, -9.81);
  const double dt = pre.dt_s();
  const Transformation T_j(T_i.rotation() * pre.delta_R(),
                           T_i.translation() + v_i * dt + 0.5 * g * dt * dt +
                               T_i.rotation() * pre.delta_p());
  const Eigen::Vector3d v_j = v_i + g * dt + T_i.rotation() * pre.delta_v();
  std::vector<double> pi(7), pj(7), si(9), sj(9);
  PoseToBlock(T_i, pi.data());
  PoseToBlock(T_j, pj.data());
  for (int k = 0; k < 3; ++k) {
    si[k] = v_i[k];
    sj[k] = v_j[k];
    si[3 + k] = sj[3 + k] = bg[k];
    si[6 + k] = sj[6 + k] = ba[k];
  }
  const double* params[4] = {pi.data(), si.data(), pj.data(), sj.data()};
  CHECK(cost.RawResidual(params).norm() < 1e-9);
}

TEST_CASE("Time-offset reprojection Jacobians (pose, speed/bias, landmark, baseframe, extrinsics, "
          "offset) match differences") {
  const SensorRig rig = mapstore::testing::TestRig();
  std::mt19937_64 rng(23);
  std::normal_distribution<double> n(0.0, 1.0);
  for (int trial = 0; trial < 8; ++trial) {
    const std::vector<double> T_M_I = Pose(rng, 2.0), T_G_M = Pose(rng, 2.0),
                              T_I_C = Pose(rng, 0.1);
    std::vector<double> speed_bias(9);
    for (int k = 0; k < 9; ++k) speed_bias[k] = (k < 3 ? 1.5 : k < 6 ? 0.05 : 0.1) * n(rng);
    const Eigen::Vector3d omega_m = vilma::testing::DrawVector3([&] { return 2.0 * n(rng); });
    const std::vector<double> delta = {0.02 * n(rng)};
    const Transformation T_G_C =
        BlockToPose(T_G_M.data()) * BlockToPose(T_M_I.data()) * BlockToPose(T_I_C.data());
    const double y = 0.3 * n(rng);  // y before x, as GCC drew them (tests/test_random.h)
    const double x = 0.4 * n(rng);
    const Eigen::Vector3d p_G = T_G_C * Eigen::Vector3d(x, y, 3.0);
    const TimeOffsetReprojectionCostFunction cost(&rig.cameras[0].camera,
                                                  Eigen::Vector2d(300, 200), 1.5, omega_m);
    CheckJacobians(cost, {T_M_I, speed_bias, {p_G.x(), p_G.y(), p_G.z()}, T_G_M, T_I_C, delta},
                   1e-5);
  }
}

TEST_CASE("Time-offset reprojection: zero offset is the plain residual, the offset finds the "
          "pose at the exposure time") {
  const SensorRig rig = mapstore::testing::TestRig();
  const Camera& camera = rig.cameras[0].camera;
  std::vector<double> T_M_I(7), T_G_M(7), T_I_C(7);
  PoseToBlock(Transformation(ExpSO3(Eigen::Vector3d(0.1, 0.2, -0.3)), Eigen::Vector3d(1, 0, 0)),
              T_M_I.data());
  PoseToBlock(Transformation(), T_G_M.data());
  PoseToBlock(rig.cameras[0].T_I_C, T_I_C.data());
  const Eigen::Vector3d v_M(0.8, -0.4, 0.2), omega_I(0.5, -1.2, 0.9), b_g(0.01, -0.02, 0.005);
  std::vector<double> speed_bias = {v_M.x(), v_M.y(), v_M.z(), b_g.x(), b_g.y(), b_g.z(), 0, 0, 0};
  const Transformation T_M_C = BlockToPose(T_M_I.data()) * rig.cameras[0].T_I_C;
  const Eigen::Vector3d p_G = T_M_C * Eigen::Vector3d(0.3, -0.2, 2.5);

  // δ = 0: the same residual as ReprojectionCostFunction.
  const Eigen::Vector2d uv(310, 190);
  std::vector<double> zero = {0.0};
  double r_plain[2], r_offset[2];
  const double* plain[4] = {T_M_I.data(), p_G.data(), T_G_M.data(), T_I_C.data()};
  REQUIRE(ReprojectionCostFunction(&camera, uv, 1.0).Evaluate(plain, r_plain, nullptr));
  const double* shifted[6] = {T_M_I.data(), speed_bias.data(), p_G.data(), T_G_M.data(),
                              T_I_C.data(), zero.data()};
  REQUIRE(TimeOffsetReprojectionCostFunction(&camera, uv, 1.0, omega_I + b_g)
              .Evaluate(shifted, r_offset, nullptr));
  CHECK(std::abs(r_plain[0] - r_offset[0]) < 1e-12);
  CHECK(std::abs(r_plain[1] - r_offset[1]) < 1e-12);

  // The pixel seen from the body pose 7 ms later (constant v and ω): the residual at δ = 7 ms
  // is zero, and not at δ = 0.
  const double dt = 0.007;
  const Transformation T_M_I_later(
      BlockToPose(T_M_I.data()).rotation() * ExpSO3(omega_I * dt),
      BlockToPose(T_M_I.data()).translation() + v_M * dt);
  Eigen::Vector2d uv_later;
  REQUIRE(camera.Project((T_M_I_later * rig.cameras[0].T_I_C).inverse() * p_G, &uv_later) ==
          Camera::ProjectionResult::kValid);
  std::vector<double> later = {dt};
  const TimeOffsetReprojectionCostFunction cost(&camera, uv_later, 1.0, omega_I + b_g);
  const double* at_later[6] = {T_M_I.data(), speed_bias.data(), p_G.data(), T_G_M.data(),
                               T_I_C.data(), later.data()};
  REQUIRE(cost.Evaluate(at_later, r_offset, nullptr));
  CHECK(std::hypot(r_offset[0], r_offset[1]) < 1e-9);
  REQUIRE(cost.Evaluate(shifted, r_offset, nullptr));
  CHECK(std::hypot(r_offset[0], r_offset[1]) > 1.0);
}

}  // namespace
}  // namespace vilma::mapping
