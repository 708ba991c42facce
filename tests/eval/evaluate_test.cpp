#include "vilma/eval/evaluate.h"

#include <catch2/catch.hpp>

#include <cmath>
#include <fstream>
#include <random>
#include <string>

#include "vilma/core/error.h"
#include "test_skip.h"
#include "test_random.h"
#include "eval/test_trajectories.h"

namespace vilma {
namespace {

using namespace eval_test;  // NOLINT: the shared test trajectories

EvalOptions Options(AlignmentType type) {
  EvalOptions o;
  o.alignment = type;
  return o;
}

}  // namespace

TEST_CASE("SE3 and Sim3 alignment recover a known transformation", "[eval]") {
  const Trajectory gt = MakeLoop();
  const Transformation T_E_G(ExpSO3(Eigen::Vector3d(0.3, -0.2, 1.1)), Eigen::Vector3d(4, -7, 2));
  SECTION("se3") {
    const Trajectory est = Transform(gt, T_E_G, 1.0);
    const EvalResult r = EvaluateTrajectory(gt, est, Options(AlignmentType::kSe3));
    CHECK(r.association.size() == gt.size());
    CHECK(r.alignment.scale == 1.0);
    const Transformation T_G_E = T_E_G.inverse();
    CHECK((r.alignment.T_G_E.translation() - T_G_E.translation()).norm() < 1e-9);
    CHECK(AngleBetween(r.alignment.T_G_E.rotation(), T_G_E.rotation()) < 1e-9);
    CHECK(r.ate.translation_m.rmse < 1e-9);
    CHECK(r.ate.rotation_deg.rmse < 1e-6);
    for (const auto& e : r.rpe) CHECK(e.translation_m.rmse < 1e-9);
  }
  SECTION("sim3") {
    const double s_E = 0.4;  // the estimate is 0.4 times too small -> recovered scale 2.5
    const Trajectory est = Transform(gt, T_E_G, s_E);
    const EvalResult r = EvaluateTrajectory(gt, est, Options(AlignmentType::kSim3));
    CHECK(r.alignment.scale == Approx(1.0 / s_E).epsilon(1e-12));
    CHECK(AngleBetween(r.alignment.T_G_E.rotation(), T_E_G.rotation().conjugate()) < 1e-9);
    CHECK(r.ate.translation_m.rmse < 1e-9);
    CHECK(r.ate.rotation_deg.rmse < 1e-6);
    // SE3 cannot fix the scale.
    const EvalResult se3 = EvaluateTrajectory(gt, est, Options(AlignmentType::kSe3));
    CHECK(se3.ate.translation_m.rmse > 1.0);
  }
}

TEST_CASE("posyaw removes yaw + translation but not roll", "[eval]") {
  const Trajectory gt = MakeLoop();
  const Transformation yaw_only(Rz(0.8), Eigen::Vector3d(1, 2, 3));
  const EvalResult ok =
      EvaluateTrajectory(gt, Transform(gt, yaw_only, 1.0), Options(AlignmentType::kPosYaw));
  CHECK(ok.ate.translation_m.rmse < 1e-9);
  CHECK(ok.ate.rotation_deg.rmse < 1e-6);
  CHECK(AngleBetween(ok.alignment.T_G_E.rotation(), Rz(-0.8)) < 1e-9);

  // A 5 deg roll of the whole estimate (a wrong gravity direction) is observable for VIO:
  // posyaw must leave it in the error. Every pose's rotation error is the angle of
  // Rz(theta) Rx(5 deg), which is >= 5 deg (cos(a/2) = cos(theta/2) cos(2.5 deg)).
  const Transformation roll(Rx(5.0 * kDeg), Eigen::Vector3d::Zero());
  const Trajectory rolled = Transform(gt, roll, 1.0);
  const EvalResult posyaw = EvaluateTrajectory(gt, rolled, Options(AlignmentType::kPosYaw));
  CHECK(posyaw.ate.rotation_deg.min >= 5.0 - 1e-9);
  CHECK(posyaw.ate.rotation_deg.max - posyaw.ate.rotation_deg.min < 1e-9);  // constant
  CHECK(posyaw.ate.translation_m.rmse > 0.05);
  const EvalResult se3 = EvaluateTrajectory(gt, rolled, Options(AlignmentType::kSe3));
  CHECK(se3.ate.rotation_deg.rmse < 1e-6);
  CHECK(se3.ate.translation_m.rmse < 1e-9);
}

TEST_CASE("roll/pitch error: a tilt of the estimate's world, blind to yaw", "[eval]") {
  const Trajectory gt = MakeLoop();
  // Yaw of the whole estimate: no roll/pitch error even without any alignment.
  const Trajectory yawed = Transform(gt, Transformation(Rz(0.8), Eigen::Vector3d(1, 2, 3)), 1.0);
  const EvalResult none = EvaluateTrajectory(gt, yawed, Options(AlignmentType::kNone));
  CHECK(none.ate.rotation_deg.min > 40.0);
  CHECK(none.ate.roll_pitch_deg.max < 1e-6);
  // A 5 deg roll of the world, then the yaw: the gravity axis seen in the body is 5 deg off at
  // every pose, with or without the posyaw alignment (which cannot remove a roll).
  const Trajectory tilted =
      Transform(gt, Transformation(Rz(0.8) * Rx(5.0 * kDeg), Eigen::Vector3d::Zero()), 1.0);
  for (AlignmentType type : {AlignmentType::kNone, AlignmentType::kPosYaw}) {
    const EvalResult r = EvaluateTrajectory(gt, tilted, Options(type));
    REQUIRE(r.ate.roll_pitch_errors_deg.size() == gt.size());
    CHECK(r.ate.roll_pitch_deg.min == Approx(5.0).margin(1e-6));
    CHECK(r.ate.roll_pitch_deg.max == Approx(5.0).margin(1e-6));
  }
  // One pose pitched by 2 deg in its body frame about an axis perpendicular to its gravity axis.
  Trajectory one = gt;
  const Eigen::Vector3d z_B = one.T_W_B[7].rotation().conjugate() * Eigen::Vector3d::UnitZ();
  const Eigen::Vector3d axis_B = z_B.unitOrthogonal();
  one.T_W_B[7] = Transformation(
      one.T_W_B[7].rotation() * Eigen::Quaterniond(Eigen::AngleAxisd(2.0 * kDeg, axis_B)),
      one.T_W_B[7].translation());
  const EvalResult r = EvaluateTrajectory(gt, one, Options(AlignmentType::kNone));
  CHECK(r.ate.roll_pitch_errors_deg[7] == Approx(2.0).margin(1e-9));
  CHECK(r.ate.roll_pitch_errors_deg[6] < 1e-9);
  CHECK(r.ate.roll_pitch_deg.max == Approx(2.0).margin(1e-9));
}

TEST_CASE("align first: the yaw + translation of the first matched pose", "[eval]") {
  const Trajectory gt = MakeLoop();
  const Transformation T_G_E(Rz(0.8), Eigen::Vector3d(1.5, -2.0, 0.3));
  const Trajectory clean = Transform(gt, T_G_E.inverse(), 1.0);
  CHECK(MinimumPosesForAlignment(AlignmentType::kFirst) == 1);
  AlignmentType parsed = AlignmentType::kNone;
  CHECK(ParseAlignmentType("first", &parsed));
  CHECK(parsed == AlignmentType::kFirst);
  CHECK(std::string(AlignmentTypeName(AlignmentType::kFirst)) == "first");
  CHECK_FALSE(ParseAlignmentType("first-se3", &parsed));

  // Position noise n_k in G on every pose: p_E_k = T_E_G (p_G_k + n_k). The first pose fixes
  // R_G_E exactly (orientations are clean) and p_G_E' = p_G_E - n_0, so the aligned positions
  // are p_G_k + n_k - n_0: the ATE of pose k is exactly |n_k - n_0|.
  std::mt19937 rng(3);
  std::normal_distribution<double> noise(0.0, 0.05);
  std::vector<Eigen::Vector3d> n(gt.size());
  for (auto& x : n) x = vilma::testing::DrawVector3([&] { return noise(rng); });
  SECTION("noise-free first pose: the exact transform") {
    n[0].setZero();
  }
  SECTION("noisy first pose: the first pose's transform") {
    REQUIRE(n[0].norm() > 0.01);
  }
  Trajectory est = gt;
  for (std::size_t k = 0; k < gt.size(); ++k) {
    est.T_W_B[k] = T_G_E.inverse() * Transformation(gt.T_W_B[k].rotation(),
                                                    gt.T_W_B[k].translation() + n[k]);
  }
  const EvalResult r = EvaluateTrajectory(gt, est, Options(AlignmentType::kFirst));
  CHECK(r.alignment.type == AlignmentType::kFirst);
  CHECK(r.alignment.scale == 1.0);
  CHECK(AngleBetween(r.alignment.T_G_E.rotation(), Rz(0.8)) < 1e-12);
  CHECK((r.alignment.T_G_E.translation() - (T_G_E.translation() - n[0])).norm() < 1e-12);
  REQUIRE(r.ate.translation_errors_m.size() == gt.size());
  CHECK(r.ate.translation_errors_m[0] < 1e-12);
  double worst = 0.0;
  for (std::size_t k = 0; k < gt.size(); ++k) {
    worst = std::max(worst, std::abs(r.ate.translation_errors_m[k] - (n[k] - n[0]).norm()));
  }
  CHECK(worst < 1e-12);
  CHECK(r.ate.rotation_deg.max < 1e-6);

  // Not a fit over the whole trajectory: posyaw spreads the error instead, so its first pose
  // is off and its RMSE is lower.
  const EvalResult posyaw = EvaluateTrajectory(gt, est, Options(AlignmentType::kPosYaw));
  CHECK(posyaw.ate.translation_m.rmse < r.ate.translation_m.rmse);
}

TEST_CASE("align first keeps growing drift that a whole-trajectory fit would hide", "[eval]") {
  // Estimate = gt scaled 1.02 about the first position (scale drift from the start), in a
  // yawed world. first: the error of pose k is exactly 0.02 |p_k - p_0|.
  const Trajectory gt = MakeLoop();
  const Eigen::Vector3d p0 = gt.T_W_B[0].translation();
  Trajectory drifted = gt;
  for (auto& T : drifted.T_W_B) {
    T = Transformation(T.rotation(), p0 + 1.02 * (T.translation() - p0));
  }
  const Trajectory est = Transform(drifted, Transformation(Rz(-2.5), Eigen::Vector3d(3, 3, 0)),
                                   1.0);
  const EvalResult r = EvaluateTrajectory(gt, est, Options(AlignmentType::kFirst));
  double worst = 0.0;
  for (std::size_t k = 0; k < gt.size(); ++k) {
    const double expected = 0.02 * (gt.T_W_B[k].translation() - p0).norm();
    worst = std::max(worst, std::abs(r.ate.translation_errors_m[k] - expected));
  }
  CHECK(worst < 1e-9);
  CHECK(r.ate.translation_m.max > 0.2);
}

TEST_CASE("align first: a roll/pitch of the estimate's world stays in the error", "[eval]") {
  // R_G_E = Rz(yaw) S or S Rz(yaw), S a 5 deg tilt about the horizontal axis at 30 deg (a wrong
  // gravity direction). The yaw must come out exactly and every rotation error is the tilt.
  const Trajectory gt = MakeLoop();
  const Eigen::Vector3d axis(std::cos(30.0 * kDeg), std::sin(30.0 * kDeg), 0.0);
  const Eigen::Quaterniond S(Eigen::AngleAxisd(5.0 * kDeg, axis));
  const double yaw = -1.9;
  for (const Eigen::Quaterniond& R_G_E : {Rz(yaw) * S, S * Rz(yaw)}) {
    const Transformation T_G_E(R_G_E, Eigen::Vector3d(-4, 2, 1));
    const Trajectory est = Transform(gt, T_G_E.inverse(), 1.0);
    const EvalResult r = EvaluateTrajectory(gt, est, Options(AlignmentType::kFirst));
    CHECK(AngleBetween(r.alignment.T_G_E.rotation(), Rz(yaw)) < 1e-12);
    CHECK(r.ate.translation_errors_m[0] < 1e-12);
    CHECK(r.ate.rotation_deg.min == Approx(5.0).epsilon(1e-9));
    CHECK(r.ate.rotation_deg.max == Approx(5.0).epsilon(1e-9));
    CHECK(r.ate.translation_m.max > 0.1);  // the tilt moves the later positions
  }
}

TEST_CASE("align first uses the first MATCHED pose, one match is enough", "[eval]") {
  const Trajectory gt = MakeLoop(50);
  const Transformation T_G_E(Rz(0.4), Eigen::Vector3d(1, 2, 3));
  Trajectory est;
  // An unmatched, wildly wrong pose before the others (0.5 s before the first gt stamp).
  est.Add(gt.t_ns[0] - 500000000, Transformation(Rz(2.0), Eigen::Vector3d(100, 0, 0)));
  const Trajectory moved = Transform(gt, T_G_E.inverse(), 1.0);
  for (std::size_t k = 3; k < moved.size(); ++k) est.Add(moved.t_ns[k], moved.T_W_B[k]);
  const EvalResult r = EvaluateTrajectory(gt, est, Options(AlignmentType::kFirst));
  CHECK(r.association.size() == 47);
  CHECK(AngleBetween(r.alignment.T_G_E.rotation(), Rz(0.4)) < 1e-12);
  CHECK((r.alignment.T_G_E.translation() - T_G_E.translation()).norm() < 1e-12);
  CHECK(r.ate.translation_m.max < 1e-12);

  Trajectory one;
  one.Add(moved.t_ns[10], moved.T_W_B[10]);
  const EvalResult single = EvaluateTrajectory(gt, one, Options(AlignmentType::kFirst));
  CHECK(single.association.size() == 1);
  CHECK(single.ate.translation_m.max < 1e-12);
  CHECK_THROWS_AS(AlignPositions(AlignmentType::kFirst, {Eigen::Vector3d::Zero()},
                                 {Eigen::Vector3d::Zero()}),
                  std::invalid_argument);
}

TEST_CASE("align fixed: the given S_G_E is applied as is, nothing fitted", "[eval]") {
  CHECK(MinimumPosesForAlignment(AlignmentType::kFixed) == 0);
  AlignmentType parsed = AlignmentType::kNone;
  CHECK(ParseAlignmentType("fixed", &parsed));
  CHECK(parsed == AlignmentType::kFixed);
  CHECK(std::string(AlignmentTypeName(AlignmentType::kFixed)) == "fixed");

  const Trajectory gt = MakeLoop();
  const Transformation T_G_E(Rz(0.8) * Rx(0.01), Eigen::Vector3d(1.5, -2.0, 0.3));
  const double s = 1.25;
  const Trajectory est = Transform(gt, T_G_E.inverse(), 1.0);
  EvalOptions o = Options(AlignmentType::kFixed);
  // The exact transform: zero error, and the given transform comes back unchanged.
  o.fixed_alignment.T_G_E = T_G_E;
  const EvalResult exact = EvaluateTrajectory(gt, est, o);
  CHECK(exact.alignment.type == AlignmentType::kFixed);
  CHECK(exact.alignment.scale == 1.0);
  CHECK(AngleBetween(exact.alignment.T_G_E.rotation(), T_G_E.rotation()) < 1e-12);
  CHECK(exact.ate.translation_m.max < 1e-12);
  CHECK(exact.ate.rotation_deg.max < 1e-6);

  // A transform off by a known translation d: nothing is fitted, so every pose is off by
  // exactly |d| (a fit would remove it: se3 gives ~0).
  const Eigen::Vector3d d(0.3, -0.4, 0.0);
  o.fixed_alignment.T_G_E = Transformation(T_G_E.rotation(), T_G_E.translation() + d);
  const EvalResult shifted = EvaluateTrajectory(gt, est, o);
  CHECK(shifted.ate.translation_m.min == Approx(0.5).epsilon(1e-12));
  CHECK(shifted.ate.translation_m.max == Approx(0.5).epsilon(1e-12));
  CHECK(EvaluateTrajectory(gt, est, Options(AlignmentType::kSe3)).ate.translation_m.max < 1e-9);

  // The scale is applied too: p_G = s R p_E + t with p_E from a world scaled by 1/s.
  const Trajectory scaled = Transform(gt, T_G_E.inverse(), 1.0 / s);
  o.fixed_alignment.scale = s;
  // Transform() scales after rotating: p_E = (1/s)(R_E_G p_G) + t_E_G, so S_G_E has the
  // translation -s R_G_E t_E_G.
  const Transformation T_E_G = T_G_E.inverse();
  o.fixed_alignment.T_G_E =
      Transformation(T_G_E.rotation(), -s * (T_G_E.rotation() * T_E_G.translation()));
  const EvalResult with_scale = EvaluateTrajectory(gt, scaled, o);
  CHECK(with_scale.alignment.scale == s);
  CHECK(with_scale.ate.translation_m.max < 1e-9);

  // Invalid given transforms are option errors.
  o.fixed_alignment.scale = 0.0;
  CHECK_FALSE(o.Validate().empty());
  CHECK_THROWS_AS(EvaluateTrajectory(gt, scaled, o), std::invalid_argument);
  o.fixed_alignment.scale = 1.0;
  o.fixed_alignment.T_G_E = Transformation(Rz(0.1), Eigen::Vector3d(std::nan(""), 0.0, 0.0));
  CHECK(o.Validate() == "fixed_alignment.translation: expected finite values [m]");
  // The same values are fine for the other alignments, which do not use them.
  o.alignment = AlignmentType::kPosYaw;
  CHECK(o.Validate().empty());
  CHECK_THROWS_AS(
      AlignPositions(AlignmentType::kFixed, {Eigen::Vector3d::Zero()}, {Eigen::Vector3d::Zero()}),
      std::invalid_argument);
}

TEST_CASE("within counts: known per-pose errors, the boundary is within", "[eval]") {
  const std::vector<WithinCount> c =
      CountWithin({0.1, 0.5, std::nextafter(0.5, 1.0), 1.0, 2.0}, {0.5, 0.0, 1.0, 10.0});
  REQUIRE(c.size() == 4);
  CHECK(c[0].distance_m == 0.5);
  CHECK(c[0].poses == 2);
  CHECK(c[0].matched_poses == 5);
  CHECK(c[0].fraction == 0.4);
  CHECK(c[1].poses == 0);
  CHECK(c[2].poses == 4);
  CHECK(c[3].poses == 5);
  CHECK(c[3].fraction == 1.0);
  CHECK(CountWithin({}, {0.5})[0].fraction == 0.0);

  // 30 poses on a line with a known offset each: errors 0, 0.25, 0.5, 0.75, 1.0 (exact in
  // binary) repeating, so within 0.5 m: 18 of 30.
  Trajectory gt, est;
  for (int k = 0; k < 30; ++k) {
    const int64_t t = int64_t{k} * 100000000;
    gt.Add(t, Transformation(Eigen::Quaterniond::Identity(), Eigen::Vector3d(k, 0.0, 0.0)));
    est.Add(t, Transformation(Eigen::Quaterniond::Identity(),
                              Eigen::Vector3d(k, 0.25 * (k % 5), 0.0)));
  }
  EvalOptions options = Options(AlignmentType::kNone);
  options.within_m = {0.5, 0.49, 1.0};
  const EvalResult r = EvaluateTrajectory(gt, est, options);
  REQUIRE(r.within.size() == 3);
  CHECK(r.ate.translation_m.max == 1.0);
  CHECK(r.within[0].poses == 18);
  CHECK(r.within[0].matched_poses == 30);
  CHECK(r.within[0].fraction == Approx(0.6).epsilon(1e-15));
  CHECK(r.within[1].poses == 12);
  CHECK(r.within[2].poses == 30);
  CHECK(EvaluateTrajectory(gt, est, Options(AlignmentType::kNone)).within.empty());

  options.within_m = {0.5, -0.1};
  CHECK(options.Validate() == "within_m: expected distances >= 0 [m]");
  CHECK_THROWS_AS(EvaluateTrajectory(gt, est, options), std::invalid_argument);
  options.within_m = {std::nan("")};
  CHECK_FALSE(options.Validate().empty());
}

TEST_CASE("a known constant offset gives a known ATE", "[eval]") {
  const Trajectory gt = MakeLoop();
  const Transformation offset(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0.3, 0.0, -0.4));
  const Trajectory est = Transform(gt, offset, 1.0);
  const EvalResult none = EvaluateTrajectory(gt, est, Options(AlignmentType::kNone));
  CHECK(none.alignment.type == AlignmentType::kNone);
  CHECK(none.ate.translation_m.rmse == Approx(0.5).epsilon(1e-12));
  CHECK(none.ate.translation_m.mean == Approx(0.5).epsilon(1e-12));
  CHECK(none.ate.translation_m.median == Approx(0.5).epsilon(1e-12));
  CHECK(none.ate.translation_m.max == Approx(0.5).epsilon(1e-12));
  CHECK(none.ate.rotation_deg.max < 1e-6);
  // Relative poses do not see a constant world offset.
  for (const auto& e : none.rpe) CHECK(e.translation_m.max < 1e-9);
  // Any alignment removes it.
  CHECK(EvaluateTrajectory(gt, est, Options(AlignmentType::kPosYaw)).ate.translation_m.rmse <
        1e-9);
}

TEST_CASE("ATE of white position noise is sigma * sqrt(3)", "[eval]") {
  const Trajectory gt = MakeLoop(4000);
  Trajectory est = gt;
  std::mt19937 rng(42);
  std::normal_distribution<double> noise(0.0, 0.02);
  for (auto& T : est.T_W_B) {
    T = Transformation(T.rotation(),
                       T.translation() + vilma::testing::DrawVector3([&] { return noise(rng); }));
  }
  const EvalResult r = EvaluateTrajectory(gt, est, Options(AlignmentType::kSe3));
  // E|n|^2 = 3 sigma^2; 12000 samples -> relative standard error of the RMSE ~0.5 %.
  CHECK(r.ate.translation_m.rmse == Approx(0.02 * std::sqrt(3.0)).epsilon(0.02));
  CHECK(r.ate.rotation_deg.rmse < 0.05);  // the fit's rotation error is tiny, not zero
}

TEST_CASE("RPE of constant-rate drift along a straight line", "[eval]") {
  // 201 poses 0.5 m apart along x (exact in binary: path lengths are exact).
  Trajectory gt;
  for (int i = 0; i <= 200; ++i) {
    gt.Add(int64_t{i} * 100000000, Transformation(Eigen::Quaterniond::Identity(),
                                                   Eigen::Vector3d(0.5 * i, 0.0, 0.0)));
  }
  EvalOptions options = Options(AlignmentType::kNone);
  options.segment_lengths_m = {10.0, 50.0, 150.0};

  SECTION("scale drift: 2 % of distance") {
    Trajectory est = gt;
    for (auto& T : est.T_W_B) T = Transformation(T.rotation(), 1.02 * T.translation());
    const EvalResult r = EvaluateTrajectory(gt, est, options);
    REQUIRE(r.rpe.size() == 3);
    CHECK(r.gt_path_length_m == 100.0);
    CHECK(r.rpe[0].length_m == 10.0);
    CHECK(r.rpe[0].pairs == 181);  // starts 0..180 reach +20 steps
    CHECK(r.rpe[0].translation_m.rmse == Approx(0.2).epsilon(1e-9));
    CHECK(r.rpe[0].translation_percent.mean == Approx(2.0).epsilon(1e-9));
    CHECK(r.rpe[0].translation_percent.median == Approx(2.0).epsilon(1e-9));
    CHECK(r.rpe[0].rotation_deg.max < 1e-9);
    CHECK(r.rpe[1].pairs == 101);
    CHECK(r.rpe[1].translation_m.rmse == Approx(1.0).epsilon(1e-9));
    CHECK(r.rpe[1].translation_percent.rmse == Approx(2.0).epsilon(1e-9));
    // Longer than the 100 m path: no pairs, all zeros.
    CHECK(r.rpe[2].length_m == 150.0);
    CHECK(r.rpe[2].pairs == 0);
    CHECK(r.rpe[2].translation_m.rmse == 0.0);
  }
  SECTION("heading drift: 0.1 deg per metre") {
    const double rate = 0.1 * kDeg;  // [rad/m]
    Trajectory est = gt;
    for (auto& T : est.T_W_B) T = Transformation(Rz(rate * T.translation().x()), T.translation());
    const EvalResult r = EvaluateTrajectory(gt, est, options);
    // (R_gt_i^T R_gt_j)^T (R_est_i^T R_est_j) = Rz(rate d): 1 deg over 10 m, 5 deg over 50 m.
    CHECK(r.rpe[0].rotation_deg.rmse == Approx(1.0).epsilon(1e-9));
    CHECK(r.rpe[0].rotation_deg.min == Approx(1.0).epsilon(1e-9));
    CHECK(r.rpe[1].rotation_deg.rmse == Approx(5.0).epsilon(1e-9));
  }
}

TEST_CASE("too few matches is an input error that says why", "[eval]") {
  const Trajectory gt = MakeLoop(20);
  Trajectory est = MakeLoop(20);
  for (auto& t : est.t_ns) t += 5000000000;  // another clock: no stamp within 10 ms
  CHECK_THROWS_AS(EvaluateTrajectory(gt, est, EvalOptions{}), InputError);
  CHECK_THROWS_WITH(EvaluateTrajectory(gt, est, EvalOptions{}),
                    "expected at least 2 matched poses for alignment 'posyaw', got 0 of 20 "
                    "estimate poses (max_dt 0.01 s; do the two files use the same clock?)");
  CHECK_THROWS_AS(AlignUmeyama({Eigen::Vector3d::Zero()}, {Eigen::Vector3d::Zero()}, false),
                  std::invalid_argument);
  EvalOptions bad;
  bad.segment_lengths_m = {10.0, -1.0};
  CHECK_THROWS_AS(EvaluateTrajectory(gt, gt, bad), std::invalid_argument);
}

TEST_CASE("EuRoC V1_01 re-estimated ground truth vs the original (TUM)", "[eval]") {
  const std::string dir = std::string(VILMA_SHARED_DATA_DIR) + "/euroc_V1_01_micro";
  std::ifstream probe(dir + "/V1_01_easy_gt_original_tum.txt");
  if (!probe) {
    VILMA_SKIP("shared data not found at " << dir);
  }
  const Trajectory gt = ReadTrajectoryFile(dir + "/mav0/state_groundtruth_estimate0/data.csv");
  const Trajectory est = ReadTrajectoryFile(dir + "/V1_01_easy_gt_original_tum.txt");
  const EvalResult r = EvaluateTrajectory(gt, est, EvalOptions{});
  // The same motion, two estimates of it: nearly every 20 Hz gt pose finds a 200 Hz partner.
  CHECK(r.association.size() > 2800);
  CHECK(r.gt_path_length_m > 50.0);
  CHECK(r.ate.translation_m.rmse < 0.05);  // measured ~1-2 cm, see docs/evaluation.md
  CHECK(r.rpe.size() == 5);
  CHECK(r.rpe[0].pairs > 0);
}

}  // namespace vilma
