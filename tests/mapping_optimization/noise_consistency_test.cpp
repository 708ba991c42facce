// The inertial residual's weights against the simulator's IMU noise (issue 12, street): at the
// true states the whitened residual of every IMU edge must be unit normal, r = U (x_true) with
// UᵀU = Σ⁻¹: mean 0, mean square 1 per component. A mismatch (a density used as a discrete
// sigma, a missing dt, a wrong random-walk scaling, a gravity or bias convention that differs
// from the simulator's) shows up here as a mean square far from 1 or a mean far from 0, and
// in optvi as an optimum pulled off the truth. The street trajectory is the one where optvi's
// optimum lay farthest from the truth (docs/optimization.md "Street").
#include <catch2/catch.hpp>

#include <cmath>
#include <vector>

#include "vilma/core/geometry.h"
#include "vilma/mapping/optimization/imu_preintegration.h"
#include "vilma/mapping/optimization/inertial_residual.h"
#include "vilma/mapping/optimization/pose_manifold.h"
#include "vilma/sim/imu_sim.h"
#include "vilma/sim/random.h"
#include "vilma/sim/world.h"

namespace vilma::mapping {
namespace {

struct BlockStats {
  Eigen::Matrix<double, 15, 1> sum = Eigen::Matrix<double, 15, 1>::Zero();
  Eigen::Matrix<double, 15, 1> sum_sq = Eigen::Matrix<double, 15, 1>::Zero();
  int n = 0;
  // Mean and mean square over the three components of residual block b (R v p bg ba).
  double Mean(int b) const { return sum.segment<3>(3 * b).sum() / (3.0 * n); }
  double MeanSquare(int b) const { return sum_sq.segment<3>(3 * b).sum() / (3.0 * n); }
};

// Whitened inertial residuals at the truth over edges of `samples_per_edge` IMU intervals.
BlockStats WhitenedAtTruth(const char* world_name, double seconds, int samples_per_edge,
                           uint64_t seed) {
  const sim::World world = sim::MakePresetWorld(world_name, 1);
  sim::TrajectoryOptions t;
  t.duration_s = seconds + 1.0;
  t.static_start_s = 0.5;
  const sim::Trajectory trajectory = sim::GenerateTrajectory(world, t, seed);
  const sim::ImuSimOptions o;  // white noise, bias random walk, turn-on biases
  sim::Rng rng(seed);
  const sim::ImuSimResult imu = sim::SimulateImu(trajectory, 1'000'000'000LL, seconds, o, &rng);
  BlockStats stats;
  const std::size_t step = static_cast<std::size_t>(samples_per_edge);
  for (std::size_t i = 0; i + step < imu.samples.size(); i += step) {
    const GroundTruthState& a = imu.ground_truth[i];
    const GroundTruthState& b = imu.ground_truth[i + step];
    const std::vector<ImuSample> samples(imu.samples.begin() + static_cast<long>(i),
                                         imu.samples.begin() + static_cast<long>(i + step + 1));
    const ImuPreintegration pre(samples, o.noise, a.b_g, a.b_a);
    const InertialCostFunction cost(&pre, o.gravity_magnitude);
    std::vector<double> pi(7), pj(7), si(9), sj(9);
    PoseToBlock(Transformation(a.q_W_I, a.p_W_I), pi.data());
    PoseToBlock(Transformation(b.q_W_I, b.p_W_I), pj.data());
    for (int k = 0; k < 3; ++k) {
      si[k] = a.v_W[k];
      si[3 + k] = a.b_g[k];
      si[6 + k] = a.b_a[k];
      sj[k] = b.v_W[k];
      sj[3 + k] = b.b_g[k];
      sj[6 + k] = b.b_a[k];
    }
    const double* params[4] = {pi.data(), si.data(), pj.data(), sj.data()};
    Eigen::Matrix<double, 15, 1> r;
    REQUIRE(cost.Evaluate(params, r.data(), nullptr));
    stats.sum += r;
    stats.sum_sq += r.cwiseAbs2();
    ++stats.n;
  }
  return stats;
}

void CheckUnitNormal(const BlockStats& s) {
  // n edges x 3 components: the mean of N(0, 1) has sigma 1/sqrt(3n), the mean square of
  // chi2(1) sqrt(2/(3n)); with n >= 500 the bounds below are more than 4 sigma wide.
  // (REQUIRE, not CHECK: glog, through Ceres, defines a CHECK that aborts.)
  REQUIRE(s.n >= 500);
  const char* names[5] = {"rotation", "velocity", "position", "gyro bias", "accel bias"};
  for (int b = 0; b < 5; ++b) {
    INFO(names[b] << ": mean " << s.Mean(b) << ", mean square " << s.MeanSquare(b) << " over "
                  << s.n << " edges");
    REQUIRE(std::abs(s.Mean(b)) < 0.12);
    REQUIRE(s.MeanSquare(b) > 0.85);
    REQUIRE(s.MeanSquare(b) < 1.15);
  }
}

TEST_CASE("Inertial residuals at the simulator's truth are unit normal: street, 0.1 s edges") {
  CheckUnitNormal(WhitenedAtTruth("street", 60.0, 20, 3));
}

TEST_CASE("Inertial residuals at the simulator's truth are unit normal: room, 1 s edges") {
  // Keyframed maps: edges of 200 samples (the bias drifts inside them).
  CheckUnitNormal(WhitenedAtTruth("room", 600.0, 200, 4));
}

}  // namespace
}  // namespace vilma::mapping
