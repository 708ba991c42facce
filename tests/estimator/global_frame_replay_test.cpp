#include "vilma/estimator/global_frame_replay.h"

#include <Eigen/Cholesky>
#include <Eigen/Geometry>
#include <catch2/catch.hpp>
#include <cmath>
#include <random>

namespace vilma::estimator {
namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr int64_t kFrameNs = 50'000'000;  // 20 Hz

// A tilted, turning IMU path in M and, every `every` frames, a noisy result T_G_I with an
// anisotropic body covariance (so that its rotation into VILMA_LOC's global frame matters).
struct Run {
  std::vector<OdometrySample> odometry;
  std::vector<LocalizationSample> localizations;
  std::vector<Matrix6d> covariance_I;  // per localization, as the localizer gave it
};

Matrix6d BodyCovariance() {
  Matrix6d L = Matrix6d::Zero();
  L.diagonal() << 0.02, 0.01, 0.03, 0.2 * kDeg, 0.4 * kDeg, 0.3 * kDeg;
  L(1, 0) = 0.005;
  L(5, 3) = 0.1 * kDeg;
  return L * L.transpose();
}

Run MakeRun(const Transformation& T_G_M, int frames, int every, uint32_t seed) {
  Run run;
  std::mt19937 rng(seed);
  std::normal_distribution<double> n(0.0, 1.0);
  const Matrix6d C_I = BodyCovariance();
  const Eigen::LLT<Matrix6d> llt(C_I);
  for (int k = 0; k < frames; ++k) {
    OdometrySample o;
    o.t_ns = 1'000'000'000 + k * kFrameNs;
    o.tracked = true;
    o.T_M_I = Transformation(
        Eigen::Quaterniond(Eigen::AngleAxisd(0.05 * k, Eigen::Vector3d(0.1, 0.2, 1.0).normalized())),
        Eigen::Vector3d(0.1 * k, 0.02 * k, 1.0));
    run.odometry.push_back(o);
    if (k % every != 0) continue;
    Vector6d w;
    for (int i = 0; i < 6; ++i) w(i) = n(rng);
    LocalizationSample l;
    l.t_ns = o.t_ns;
    l.ok = true;
    l.inliers = 50;
    l.T_G_I = T_G_M * o.T_M_I * Transformation::Exp(llt.matrixL() * w);
    Matrix6d A = Matrix6d::Zero();
    A.block<3, 3>(0, 0) = l.T_G_I.rotation().toRotationMatrix();
    A.block<3, 3>(3, 3) = A.block<3, 3>(0, 0);
    l.covariance_G = A * C_I * A.transpose();  // as vilma-estimatord publishes it
    run.localizations.push_back(l);
    run.covariance_I.push_back(C_I);
  }
  return run;
}

TEST_CASE("T_G_M replay equals the estimator fed as the daemon feeds it",
          "[estimator][localization]") {
  const Transformation T_G_M(Eigen::Quaterniond(Eigen::AngleAxisd(0.8, Eigen::Vector3d::UnitZ())),
                             Eigen::Vector3d(2.0, -1.0, 0.5));
  const Run run = MakeRun(T_G_M, 200, 10, 7u);
  for (const bool random_walk : {true, false}) {
    GlobalFrameReplayOptions options;
    if (!random_walk) {
      options.global_frame.drift_position_m_per_sqrt_s = 0.0;
      options.global_frame.drift_yaw_deg_per_sqrt_s = 0.0;
    }
    const GlobalFrameReplayResult r = ReplayGlobalFrame(run.odometry, run.localizations, options);
    // The daemon's order: at each frame its result (body covariance), then T_G_M T_M_I.
    GlobalFrameEstimator direct(options.global_frame);
    std::size_t next = 0, pose = 0;
    double max_dp = 0.0, max_dq = 0.0;
    for (const OdometrySample& o : run.odometry) {
      if (next < run.localizations.size() && run.localizations[next].t_ns == o.t_ns) {
        direct.Update(run.localizations[next].T_G_I, run.covariance_I[next], o.T_M_I, o.t_ns);
        ++next;
      }
      if (!direct.initialized()) continue;
      REQUIRE(pose < r.poses.size());
      CHECK(r.poses[pose].t_ns == o.t_ns);
      const Transformation expected = direct.T_G_M() * o.T_M_I;
      max_dp = std::max(max_dp, (r.poses[pose].T_G_I.translation() - expected.translation()).norm());
      max_dq = std::max(max_dq, AngleBetween(r.poses[pose].T_G_I.rotation(), expected.rotation()));
      ++pose;
    }
    INFO((random_walk ? "random walk" : "forgetting factor") << ": " << max_dp << " m, " << max_dq
                                                            << " rad");
    CHECK(pose == r.poses.size());
    CHECK(r.poses.size() == 200 - 10);  // from the second result (min_consistent_results 2)
    CHECK(max_dp < 1e-12);
    CHECK(max_dq < 1e-12);
    CHECK(r.attempts == 20);
    CHECK(r.accepted == 20);
    // And the fused T_G_M is the truth up to the noise.
    const Transformation last = r.poses.back().T_G_I * run.odometry.back().T_M_I.inverse();
    CHECK((last.translation() - T_G_M.translation()).norm() < 0.05);
  }
}

TEST_CASE("T_G_M replay: failed and weak results are not fused, a filter reset starts T_G_M again",
          "[estimator][localization]") {
  const Transformation T_G_M(Eigen::Quaterniond(Eigen::AngleAxisd(-0.3, Eigen::Vector3d::UnitZ())),
                             Eigen::Vector3d(0.0, 4.0, 0.0));
  Run run = MakeRun(T_G_M, 100, 10, 11u);
  run.localizations[1].ok = false;     // frame 10: the localizer found no pose
  run.localizations[2].inliers = 12;   // frame 20: below min_inliers
  // Frames 50-54: the filter resets and re-initializes (not tracked), a new M frame.
  for (int k = 50; k < 55; ++k) run.odometry[static_cast<std::size_t>(k)].tracked = false;
  // A result stamped between frames (not in a daemon log): counted, not used.
  LocalizationSample stray = run.localizations[3];
  stray.t_ns += kFrameNs / 2;
  run.localizations.insert(run.localizations.begin() + 4, stray);
  GlobalFrameReplayOptions options;
  const GlobalFrameReplayResult r = ReplayGlobalFrame(run.odometry, run.localizations, options);
  CHECK(r.failed == 1);
  CHECK(r.rejected_inliers == 1);
  // The stray result and frame 50's (not tracked: the daemon never queries such a frame).
  CHECK(r.unmatched == 2);
  // Attempts at the tracked frames 0, 10, 20, 30, 40, 60, 70, 80, 90.
  CHECK(r.attempts == 9);
  CHECK(r.m_frame_resets == 1);
  CHECK(r.accepted == 7);
  // Initialized at frame 30 (results 0 and 30), dropped at 50, again at 70 (60 and 70):
  // frames 30-49 and 70-99.
  CHECK(r.poses.size() == 20 + 30);
  CHECK(r.poses.front().t_ns == run.odometry[30].t_ns);
  CHECK(r.poses[20].t_ns == run.odometry[70].t_ns);
}

}  // namespace
}  // namespace vilma::estimator
