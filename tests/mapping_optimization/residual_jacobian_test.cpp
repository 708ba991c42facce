// Every residual's analytic (or tangent-autodiff) Jacobian against central differences on the
// tangent space of its blocks (PoseManifold for poses, Euclidean otherwise).
#include <catch2/catch.hpp>

#include <memory>
#include <random>

#include "mapstore/synthetic_map.h"
#include "vilma/mapping/optimization/inertial_residual.h"
#include "vilma/mapping/optimization/pose_manifold.h"
#include "vilma/mapping/optimization/reprojection_residual.h"

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
  const Transformation T(Eigen::Quaterniond(n(rng), n(rng), n(rng), n(rng)).normalized(),
                         Eigen::Vector3d(n(rng), n(rng), n(rng)) * scale);
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
      const Eigen::Vector3d p_C(0.5 * n(rng), 0.3 * n(rng), 4.0 + n(rng) * 0.5);
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
      s.omega_I = Eigen::Vector3d(0.3 + 0.1 * n(rng), -0.2 + 0.1 * n(rng), 0.1 * n(rng));
      s.a_I = Eigen::Vector3d(0.5 * n(rng), 0.5 * n(rng), 9.81 + 0.5 * n(rng));
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

}  // namespace
}  // namespace vilma::mapping
