#include "vilma/estimator/vi_alignment.h"

#include <catch2/catch.hpp>
#include <Eigen/Eigenvalues>
#include <algorithm>
#include <cmath>
#include <random>

#include "test_random.h"
#include "vilma/core/geometry.h"
#include "vilma/estimator/filter_state.h"

namespace vilma::estimator {
namespace {

constexpr double kG = 9.81;
constexpr double kDeg = 3.14159265358979323846 / 180.0;

// A moving start: 1 s of IMU at 200 Hz with biases, 21 frames at 20 Hz, 60 points in front of
// the first camera. The true poses come from the preintegration of the samples with the true
// biases, so the noise-free problem is exactly consistent with the model.
struct Scenario {
  AlignmentInput input;
  Eigen::Vector3d v_I0, g_I0, b_g, b_a;
  std::vector<Eigen::Vector3d> p_I0_f;
};

Scenario MakeScenario(double bearing_noise_rad, unsigned seed,
                      const Eigen::Vector3d& b_g = Eigen::Vector3d(0.004, -0.02, 0.077),
                      const Eigen::Vector3d& b_a = Eigen::Vector3d(-0.02, 0.06, 0.03)) {
  Scenario s;
  s.b_g = b_g;
  s.b_a = b_a;
  // EuRoC-like camera: looks along -z of... any rotation will do; this one is cam0's T_B_C.
  Eigen::Matrix3d R_I_C;
  R_I_C << 0.0148655, -0.9998809, 0.0041403, 0.9995572, 0.0149672, 0.0257155, -0.0257744,
      0.0037562, 0.9996607;
  s.input.T_I_C = Transformation(Eigen::Quaterniond(R_I_C).normalized(),
                                 Eigen::Vector3d(-0.0216, -0.0647, 0.0098));
  s.input.gravity_magnitude = kG;
  // Gravity in I0: tilted 20 deg away from -x of I (EuRoC's IMU x axis points up).
  s.g_I0 = kG * (ExpSO3(Eigen::Vector3d(0.0, 0.35, 0.1)) * Eigen::Vector3d(-1, 0, 0));
  s.v_I0 = Eigen::Vector3d(0.1, 0.4, -0.3);
  const int64_t t0 = 5'000'000'000;
  for (int i = 0; i <= 210; ++i) {
    const double t = 0.005 * i;
    ImuSample m;
    m.t_ns = t0 - 25'000'000 + static_cast<int64_t>(i) * 5'000'000;
    const Eigen::Vector3d omega(0.3 * std::sin(2.0 * t), 0.25 * std::cos(1.3 * t),
                                0.4 * std::sin(1.7 * t + 0.5));
    // Specific force: minus gravity (roughly, as seen while rotating) plus a swing.
    const Eigen::Vector3d accel(0.8 * std::sin(3.0 * t), 1.2 * std::cos(2.5 * t),
                                -0.9 * std::sin(2.0 * t));
    m.omega_I = omega + b_g;
    m.a_I = -s.g_I0 + accel + b_a;
    s.input.imu.push_back(m);
  }
  for (int k = 0; k <= 20; ++k) s.input.frame_t_ns.push_back(t0 + k * 50'000'000);
  const std::vector<PreintegratedImu> pre = PreintegrateImu(s.input.imu, s.input.frame_t_ns,
                                                            b_g, b_a);
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  std::normal_distribution<double> noise(0.0, 1.0);
  const int features = 60;
  for (int f = 0; f < features; ++f) {
    // z, y, x: the order GCC drew them in (tests/test_random.h).
    const double z = 4.5 + 1.5 * uni(rng);
    const double y = 1.5 * uni(rng);
    const double x = 2.0 * uni(rng);
    const Eigen::Vector3d p_C0(x, y, z);
    s.p_I0_f.push_back(s.input.T_I_C * p_C0);
  }
  s.input.num_features = features;
  for (int k = 0; k < static_cast<int>(pre.size()); ++k) {
    const double t = pre[static_cast<std::size_t>(k)].dt_s;
    const Eigen::Vector3d p_Ik = s.v_I0 * t + 0.5 * t * t * s.g_I0 + pre[static_cast<std::size_t>(k)].alpha;
    const Transformation T_I0_Ik(pre[static_cast<std::size_t>(k)].q_0_k, p_Ik);
    const Transformation T_C_I0 = (T_I0_Ik * s.input.T_I_C).inverse();
    for (int f = 0; f < features; ++f) {
      const Eigen::Vector3d p_C = T_C_I0 * s.p_I0_f[static_cast<std::size_t>(f)];
      if (p_C.z() < 0.5 || std::abs(p_C.x() / p_C.z()) > 0.8 || std::abs(p_C.y() / p_C.z()) > 0.6) {
        continue;
      }
      AlignmentObservation o;
      o.feature = f;
      o.frame = k;
      const Eigen::Vector2d d = vilma::testing::DrawVector2([&] { return noise(rng); });
      o.bearing_C = BearingBoxPlus(p_C.normalized(), bearing_noise_rad * d);
      s.input.observations.push_back(o);
    }
  }
  return s;
}

double AngleDeg(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b)) / kDeg;
}

}  // namespace

TEST_CASE("minimizing a quadratic on a sphere: the global minimum, also indefinite and hard") {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  auto cost = [](const Eigen::Matrix3d& A, const Eigen::Vector3d& b, const Eigen::Vector3d& g) {
    return g.dot(A * g) - 2.0 * b.dot(g);
  };
  for (int trial = 0; trial < 30; ++trial) {
    Eigen::Matrix3d M;
    for (int i = 0; i < 9; ++i) M(i / 3, i % 3) = uni(rng);
    Eigen::Matrix3d A = M + M.transpose();  // indefinite in general
    if (trial % 3 == 0) A = M * M.transpose();
    Eigen::Vector3d b = vilma::testing::DrawVector3([&] { return uni(rng); });
    b *= (trial % 2 == 0) ? 5.0 : 0.2;
    if (trial == 1) {  // hard case: b orthogonal to the smallest eigenvector
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(A);
      b -= eig.eigenvectors().col(0) * eig.eigenvectors().col(0).dot(b);
      b *= 0.01;
    }
    const double radius = 2.0;
    const Eigen::Vector3d g = MinimizeQuadraticOnSphere(A, b, radius);
    INFO("trial " << trial);
    REQUIRE(g.allFinite());
    CHECK(std::abs(g.norm() - radius) < 1e-9);
    // No sampled point of the sphere is better.
    double best = 1e300;
    for (int i = 0; i <= 200; ++i) {
      for (int j = 0; j < 400; ++j) {
        const double th = 3.14159265358979 * i / 200.0, ph = 2 * 3.14159265358979 * j / 400.0;
        const Eigen::Vector3d p = radius * Eigen::Vector3d(std::sin(th) * std::cos(ph),
                                                           std::sin(th) * std::sin(ph), std::cos(th));
        best = std::min(best, cost(A, b, p));
      }
    }
    CHECK(cost(A, b, g) <= best + 1e-9);
    CHECK(cost(A, b, g) > best - 0.05 * (1.0 + std::abs(best)));
  }
}

TEST_CASE("alignment residual Jacobian matches central differences") {
  const Scenario s = MakeScenario(0.0, 1);
  const Eigen::Vector3d b_g = s.b_g + Eigen::Vector3d(0.01, -0.01, 0.02);
  const Eigen::Vector3d b_a = s.b_a + Eigen::Vector3d(0.05, 0.02, -0.03);
  const Eigen::Vector3d u = s.g_I0.normalized();
  const Eigen::Vector3d v = s.v_I0 + Eigen::Vector3d(0.02, -0.01, 0.03);
  int checked = 0;
  for (const AlignmentObservation& o : s.input.observations) {
    if (o.frame != 17 || o.feature % 7 != 0) continue;
    auto residual = [&](const Eigen::Matrix<double, 14, 1>& d) {
      const std::vector<PreintegratedImu> pre = PreintegrateImu(
          s.input.imu, s.input.frame_t_ns, b_g + d.segment<3>(kAlignBg), b_a + d.segment<3>(kAlignBa));
      Eigen::Vector2d r;
      REQUIRE(AlignmentResidual(v + d.segment<3>(kAlignV), BearingBoxPlus(u, d.segment<2>(kAlignG)),
                                kG, pre[17], s.input.T_I_C,
                                s.p_I0_f[static_cast<std::size_t>(o.feature)] + d.tail<3>() +
                                    Eigen::Vector3d(0.01, 0.02, -0.01),
                                o.bearing_C, &r, nullptr));
      return r;
    };
    const std::vector<PreintegratedImu> pre = PreintegrateImu(s.input.imu, s.input.frame_t_ns, b_g, b_a);
    Eigen::Vector2d r;
    Eigen::Matrix<double, 2, 14> J;
    REQUIRE(AlignmentResidual(v, u, kG, pre[17], s.input.T_I_C,
                              s.p_I0_f[static_cast<std::size_t>(o.feature)] + Eigen::Vector3d(0.01, 0.02, -0.01),
                              o.bearing_C, &r, &J));
    CHECK((r - residual(Eigen::Matrix<double, 14, 1>::Zero())).norm() < 1e-15);
    Eigen::Matrix<double, 2, 14> J_num;
    const double h = 1e-6;
    for (int j = 0; j < 14; ++j) {
      Eigen::Matrix<double, 14, 1> d = Eigen::Matrix<double, 14, 1>::Zero();
      d(j) = h;
      J_num.col(j) = (residual(d) - residual(-d)) / (2 * h);
    }
    INFO("feature " << o.feature << "\nJ\n" << J << "\nnumeric\n" << J_num);
    CHECK((J - J_num).norm() < 1e-6 * (1.0 + J.norm()));
    ++checked;
  }
  CHECK(checked >= 3);
}

TEST_CASE("linear alignment recovers velocity and gravity exactly without noise") {
  const Scenario s = MakeScenario(0.0, 2);
  const std::vector<PreintegratedImu> pre =
      PreintegrateImu(s.input.imu, s.input.frame_t_ns, s.b_g, s.b_a);
  AlignmentSolution solution;
  std::string why;
  REQUIRE(SolveLinearAlignment(s.input, pre, &solution, &why));
  CHECK((solution.v_I0 - s.v_I0).norm() < 1e-7);
  CHECK((solution.g_I0 - s.g_I0).norm() < 1e-7);
  CHECK(solution.unconstrained_gravity_norm == Approx(kG).epsilon(1e-8));
  for (std::size_t f = 0; f < s.p_I0_f.size(); ++f) {
    if (solution.feature_valid[f]) CHECK((solution.p_I0_f[f] - s.p_I0_f[f]).norm() < 1e-6);
  }
}

TEST_CASE("linear alignment with bearing noise and unknown biases: bounded error, refinement "
          "recovers the gyro bias") {
  for (unsigned seed : {3u, 4u, 5u}) {
    const Scenario s = MakeScenario(1.0 / 450.0, seed);  // 1 px
    const std::vector<PreintegratedImu> pre = PreintegrateImu(
        s.input.imu, s.input.frame_t_ns, Eigen::Vector3d::Zero(), Eigen::Vector3d::Zero());
    AlignmentSolution solution;
    std::string why;
    REQUIRE(SolveLinearAlignment(s.input, pre, &solution, &why));
    const double linear_tilt = AngleDeg(solution.g_I0, s.g_I0);
    INFO("seed " << seed << ": linear tilt error " << linear_tilt << " deg, v error "
                 << (solution.v_I0 - s.v_I0).norm());
    CHECK(std::abs(solution.g_I0.norm() - kG) < 1e-9);
    CHECK(linear_tilt < 20.0);  // biases ignored (4.4 deg/s gyro bias): a rough start
    AlignmentOptions options;
    options.bearing_sigma = 1.0 / 450.0;
    REQUIRE(RefineAlignment(s.input, options, &solution, &why));
    const double tilt = AngleDeg(solution.g_I0, s.g_I0);
    INFO("refined: tilt " << tilt << " deg, v error " << (solution.v_I0 - s.v_I0).norm()
                          << " b_g error " << (solution.b_g - s.b_g).norm() << " b_a error "
                          << (solution.b_a - s.b_a).transpose() << " sigma tilt "
                          << std::sqrt(solution.covariance.block<2, 2>(kAlignG, kAlignG)
                                           .eigenvalues().real().maxCoeff()) / kDeg
                          << " deg");
    CHECK(tilt < 1.0);  // 1 s, 1 px: the covariance says ~0.65 deg (1 sigma)
    CHECK(tilt < linear_tilt);
    CHECK((solution.v_I0 - s.v_I0).norm() < 0.05);
    CHECK((solution.b_g - s.b_g).norm() < 0.005);
    CHECK(solution.rms_inlier_rad < 1.3 / 450.0);
    CHECK(solution.inliers > 0.95 * solution.observations_used);
    // The covariance is consistent with the error (a 4-sigma bound on the tangent of u).
    const double sigma_tilt =
        std::sqrt(solution.covariance.block<2, 2>(kAlignG, kAlignG).eigenvalues().real().maxCoeff());
    CHECK(tilt * kDeg < 3.0 * sigma_tilt);
  }
}

TEST_CASE("alignment fails with a reason without translation") {
  Scenario s = MakeScenario(0.0, 6);
  s.input.num_features = 2;  // too few points
  s.input.observations.erase(
      std::remove_if(s.input.observations.begin(), s.input.observations.end(),
                     [](const AlignmentObservation& o) { return o.feature >= 2; }),
      s.input.observations.end());
  const std::vector<PreintegratedImu> pre =
      PreintegrateImu(s.input.imu, s.input.frame_t_ns, s.b_g, s.b_a);
  AlignmentSolution solution;
  std::string why;
  CHECK_FALSE(SolveLinearAlignment(s.input, pre, &solution, &why));
  CHECK(why.find("features") != std::string::npos);
}

}  // namespace vilma::estimator
