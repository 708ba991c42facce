// Variance component estimation (variance_components.h, optvi --ba_estimate_noise_scales) on
// simulated maps whose noise is known: the IMU drawn with k times the densities the rig declares
// (the estimated gyroscope and accelerometer white-noise scales recover k, the keypoint noise's
// stays 1), or exactly as declared (every estimated scale stays near 1).
#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>

#include "mapping_optimization/simulated_vi_map.h"
#include "vilma/mapping/optimization/vi_optimization.h"

namespace vilma::mapping {
namespace {

using testing::MakeSimulatedViMap;
using testing::SimulatedViMap;

// A 60 s map with a vertex every 0.5 s: 1 px keypoint noise (the keypoints' declared sigma)
// and the IMU drawn with its white densities times k (random walk and turn-on biases as
// declared). With 0.1 s edges the IMU's residuals have almost no redundancy (its relative poses
// are ~10x more precise than 1 px images': ~10 of 3,000 rows), so its noise cannot be seen in
// them; over 0.5 s the IMU's position error (t^1.5) is of the images' size.
SimulatedViMap NoisyMap(double k, uint64_t seed) {
  sim::ImuSimOptions imu;  // the rig's densities (EuRoC's, as mapstore::testing::TestRig)
  imu.noise.gyroscope_noise_density *= k;
  imu.noise.accelerometer_noise_density *= k;
  return MakeSimulatedViMap(60.0, 0.1, seed, &imu, 100);
}

ViOptimizationOptions Estimating() {
  ViOptimizationOptions o;
  o.evaluate_quality = false;
  o.ba_estimate_noise_scales = true;
  o.ba_noise_scale_rounds = 6;
  o.keypoint_sigma_px = 0.1;
  return o;
}

TEST_CASE("noise scales: IMU white noise 3x the declared densities is recovered") {
  SimulatedViMap s = NoisyMap(3.0, 21);
  const ViOptimizationSummary summary = OptimizeViMap(Estimating(), &s.map);
  INFO(summary.FullReport());
  REQUIRE(summary.noise_factors.size() >= 2);
  const NoiseFactors& first = summary.noise_factors.front();
  // The first solve (declared noise): the white-noise components' variance factors well above
  // 1 (not 9: at wrong weights the factor is a step towards the fixed point).
  REQUIRE(first.estimated[1]);
  REQUIRE(first.estimated[2]);
  CHECK(first.factor[1] > 3.0);
  CHECK(first.factor[2] > 3.0);
  // At the fixed point the scales are the noise's: 3 for both white densities, 1 for pixels.
  // (Seeds 21 / 31 / 41: gyroscope 2.99 / 3.20 / 3.01, accelerometer 2.51 / 2.81 / 2.51 with
  // a redundancy of ~160 of 720 rows, keypoints 0.97 / 0.97 / 0.98.)
  const NoiseScales& last = summary.noise_scales.back();
  CHECK(last.sigma[1] == Approx(3.0).epsilon(0.2));
  CHECK(last.sigma[2] == Approx(3.0).epsilon(0.2));
  CHECK(last.sigma[0] == Approx(1.0).epsilon(0.05));
  // Redundancies add up to rows - unknowns (Hutchinson's estimate: to a few percent).
  double redundancy = 0.0, rows = 0.0;
  for (int k = 0; k < NoiseFactors::kCount; ++k) {
    redundancy += first.redundancy[k];
    rows += first.rows[k];
  }
  CHECK(redundancy == Approx(rows - first.unknowns).epsilon(0.03));
}

TEST_CASE("noise scales: an IMU and keypoints as declared keep every scale near 1") {
  SimulatedViMap s = NoisyMap(1.0, 22);
  const ViOptimizationSummary summary = OptimizeViMap(Estimating(), &s.map);
  INFO(summary.FullReport());
  const NoiseFactors& first = summary.noise_factors.front();
  CHECK(first.factor[0] == Approx(1.0).epsilon(0.1));
  CHECK(first.factor[1] == Approx(1.0).epsilon(0.3));
  CHECK(first.factor[2] == Approx(1.0).epsilon(0.3));
  // Seeds 22 / 32 / 42 / 52: gyroscope 0.86 / 0.94 / 0.91 / 0.83, accelerometer 1.09 / 0.95 /
  // 0.95 / 0.90, keypoints 0.99 / 0.98 / 0.98 / 0.99 (the IMU's redundancy is a few hundred of
  // 720 rows: ~6 % per sigma of spread, and the gyroscope's scale comes out ~10 % low).
  const NoiseScales& last = summary.noise_scales.back();
  CHECK(last.sigma[0] == Approx(1.0).epsilon(0.05));
  CHECK(last.sigma[1] == Approx(1.0).epsilon(0.2));
  CHECK(last.sigma[2] == Approx(1.0).epsilon(0.2));
  // The random walks are weakly determined over 20 s; they stay within the bound.
  CHECK(last.sigma[3] <= 30.0);
  CHECK(last.sigma[4] <= 30.0);
}

TEST_CASE("noise scales: the IMU's datasheet is a floor (ba_noise_scale_imu_min)") {
  // An IMU as declared, its components alone estimated (keypoints as declared): the estimates
  // scatter around 1, and without the floor the gyroscope's lands below it (seed 22: 0.86 with
  // the keypoints estimated too). With the floor (the default) no IMU scale drops below the
  // rig's densities, and a factor that pushes a scale against the floor moves nothing, so the
  // iteration stops without spending its rounds on it.
  ViOptimizationOptions o = Estimating();
  o.ba_noise_scale_visual = false;
  o.ba_noise_scale_imu_min = 0.0;
  SimulatedViMap free_map = NoisyMap(1.0, 22);
  const ViOptimizationSummary without = OptimizeViMap(o, &free_map.map);
  INFO(without.FullReport());
  double lowest = 1.0;
  for (int k = 1; k < NoiseFactors::kCount; ++k) {
    lowest = std::min(lowest, without.noise_scales.back().sigma[k]);
  }
  CHECK(lowest < 0.95);

  o.ba_noise_scale_imu_min = ViOptimizationOptions().ba_noise_scale_imu_min;
  REQUIRE(o.ba_noise_scale_imu_min == 1.0);
  SimulatedViMap floored_map = NoisyMap(1.0, 22);
  const ViOptimizationSummary with = OptimizeViMap(o, &floored_map.map);
  INFO(with.FullReport());
  for (const NoiseScales& scales : with.noise_scales) {
    CHECK(scales.sigma[0] == 1.0);  // the keypoints as declared
    for (int k = 1; k < NoiseFactors::kCount; ++k) CHECK(scales.sigma[k] >= 1.0);
  }
  CHECK(with.noise_scales.back().sigma[1] == Approx(1.0).epsilon(0.2));
  CHECK(with.noise_scales.back().sigma[2] == Approx(1.0).epsilon(0.2));
  CHECK(with.noise_scales.size() < without.noise_scales.size());

  o.ba_noise_scale_imu_min = -1.0;
  CHECK_THROWS_WITH(OptimizeViMap(o, &floored_map.map), Catch::Contains("ba_noise_scale_imu_min"));
  o.ba_noise_scale_imu_min = 1.0;
  o.ba_noise_scale_probes = 0;
  CHECK_THROWS_WITH(OptimizeViMap(o, &floored_map.map), Catch::Contains("ba_noise_scale_probes"));
}

TEST_CASE("noise scales: options checked, and a cancel leaves the map untouched") {
  SimulatedViMap s = NoisyMap(1.0, 23);
  ViOptimizationOptions o = Estimating();
  o.inertial = false;
  CHECK_THROWS_WITH(OptimizeViMap(o, &s.map), Catch::Contains("ba_estimate_noise_scales"));
  o = Estimating();
  o.ba_noise_scale_rounds = 0;
  CHECK_THROWS_WITH(OptimizeViMap(o, &s.map), Catch::Contains("ba_noise_scale_rounds"));
  o = Estimating();
  o.ba_noise_scale_max = 0.5;
  CHECK_THROWS_WITH(OptimizeViMap(o, &s.map), Catch::Contains("ba_noise_scale_max"));

  class CancelInSecondSolve : public ProgressObserver {
   public:
    void Begin(const std::string&, std::size_t) override { ++solves_; }
    void Advance(std::size_t) override {}
    bool CancelRequested() const override { return solves_ >= 2; }

   private:
    int solves_ = 0;
  } cancel;
  const auto v = s.map.VertexChain(s.map.mission_ids()[0])[5];
  const Eigen::Vector3d before = s.map.vertex(v).T_M_I.translation();
  // Start away from the optimum so that the first solve moves the vertices.
  s.map.vertex(v).T_M_I =
      Transformation(s.map.vertex(v).T_M_I.rotation(), before + Eigen::Vector3d(0.02, 0.0, 0.0));
  const Eigen::Vector3d moved = s.map.vertex(v).T_M_I.translation();
  o = Estimating();
  o.ba_noise_scale_tolerance = 1e-9;  // never converged: a second solve follows
  CHECK_THROWS_AS(OptimizeViMap(o, &s.map, {}, &cancel), Cancelled);
  CHECK(s.map.vertex(v).T_M_I.translation() == moved);
}

}  // namespace
}  // namespace vilma::mapping
