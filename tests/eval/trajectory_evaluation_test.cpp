#include "vilma/eval/trajectory_evaluation.h"

#include <catch2/catch.hpp>
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <nlohmann/json.hpp>

#include "vilma/core/error.h"
#include "vilma/eval/alignment_json.h"

namespace vilma {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Two turns of a circle of radius 5 m at 10 Hz, 40 s (62.7 m), heading along the path.
Trajectory Circle() {
  Trajectory t;
  for (int i = 0; i < 400; ++i) {
    const double a = 2.0 * kPi * i / 200.0;
    t.Add(int64_t{1000000000} + int64_t{i} * 100000000,
          Transformation(Eigen::Quaterniond(Eigen::AngleAxisd(a + kPi / 2, Eigen::Vector3d::UnitZ())),
                         Eigen::Vector3d(5.0 * std::cos(a), 5.0 * std::sin(a), 1.0)));
  }
  return t;
}

// The circle seen from a world E yawed by 40 deg and shifted, each position off by +-2 cm in z.
Trajectory Estimate(const Trajectory& gt) {
  const Transformation T_E_G(
      Eigen::Quaterniond(Eigen::AngleAxisd(40.0 * kPi / 180.0, Eigen::Vector3d::UnitZ())),
      Eigen::Vector3d(3.0, -2.0, 0.5));
  Trajectory est;
  for (std::size_t i = 0; i < gt.size(); ++i) {
    const Transformation& T = gt.T_W_B[i];
    const Eigen::Vector3d p = T.translation() + Eigen::Vector3d(0, 0, i % 2 == 0 ? 0.02 : -0.02);
    est.Add(gt.t_ns[i], T_E_G * Transformation(T.rotation(), p));
  }
  return est;
}

struct Dir {
  std::string path;
  Dir() {
    path = (std::filesystem::temp_directory_path() /
            ("vilma_trajectory_evaluation_test_" + std::to_string(::getpid())))
               .string();
    std::filesystem::create_directories(path);
  }
  ~Dir() {
    std::error_code ignored;
    std::filesystem::remove_all(path, ignored);
  }
};

TrajectoryEvalOptions Options(const Dir& dir) {
  TrajectoryEvalOptions o;
  o.gt_path = dir.path + "/gt.csv";
  o.est_path = dir.path + "/est.txt";
  const Trajectory gt = Circle();
  WriteTrajectoryFile(o.gt_path, gt, TrajectoryFormat::kEuroc);
  WriteTrajectoryFile(o.est_path, Estimate(gt), TrajectoryFormat::kTum);
  o.eval.segment_lengths_m = {10.0, 500.0};
  o.eval.within_m = {0.019, 0.021};
  return o;
}

TEST_CASE("TrajectoryEvalOptions::Validate names the field", "[eval]") {
  TrajectoryEvalOptions o;
  CHECK(o.Validate() == "gt_path: expected a ground-truth trajectory file");
  o.gt_path = "gt";
  CHECK(o.Validate() == "est_path: expected an estimated trajectory file");
  o.est_path = "est";
  CHECK(o.Validate().empty());
  o.eval.alignment = AlignmentType::kFixed;
  CHECK(o.Validate() == "align_from_path: expected a file exactly when the alignment is fixed");
  o.align_from_path = "a.json";
  CHECK(o.Validate().empty());
  o.eval.segment_lengths_m = {0.0};
  CHECK(o.Validate() == "segment_lengths_m: expected lengths > 0 [m]");
  CHECK_THROWS_AS(ReadTrajectoryEvalInputs(o), std::invalid_argument);
}

TEST_CASE("a file evaluation: counts, result, brief and full report", "[eval]") {
  Dir dir;
  const TrajectoryEvalOptions o = Options(dir);
  const TrajectoryEvalInputs in = ReadTrajectoryEvalInputs(o);
  CHECK(in.gt_read.format == TrajectoryFormat::kEuroc);
  CHECK(in.est_read.format == TrajectoryFormat::kTum);
  CHECK(in.read_time_s >= 0.0);
  const TrajectoryEvalSummary s = EvaluateTrajectoryInputs(o, in);
  CHECK(s.gt_poses == 400);
  CHECK(s.est_poses == 400);
  CHECK(s.matched_poses == 400);
  CHECK(s.result.alignment.type == AlignmentType::kPosYaw);
  // posyaw removes the 40 deg yaw and the shift; the alternating +-2 cm in z stays.
  CHECK(s.result.ate.translation_m.rmse == Approx(0.02).margin(1e-6));
  CHECK(s.result.ate.rotation_deg.rmse < 1e-6);
  REQUIRE(s.result.within.size() == 2);
  CHECK(s.result.within[0].poses == 0);
  CHECK(s.result.within[1].poses == 400);
  CHECK(s.evaluate_time_s >= 0.0);

  const std::string brief = s.BriefReport();
  CHECK(brief.find('\n') == std::string::npos);
  CHECK_THAT(brief, Catch::StartsWith("ATE 0.0200 m / 0.000 deg rmse (posyaw), RPE@10.00m "));
  CHECK_THAT(brief, Catch::Contains(", 400 of 400 poses matched, read "));

  const std::string full = s.FullReport();
  CHECK_THAT(full, Catch::StartsWith("ground truth:  " + o.gt_path + " (euroc, 400 poses)\n"
                                     "estimate:      " + o.est_path + " (tum, 400 poses)\n"
                                     "matched poses: 400 (max dt 0.01 s, evo rule)\n"
                                     "alignment:     posyaw  rotation vector [deg] ("));
  // S_G_E = T_E_G^-1: yaw -40 deg, p = -Rz(-40 deg) (3, -2, 0.5).
  CHECK_THAT(full, Catch::Contains(", -40.000)  translation [m] (-1.0126, 3.4605, -0.5000)\n"
                                   "gt path:       62.672 m\n\n"));
  CHECK_THAT(full, Catch::Contains("ATE translation [m]:  rmse 0.0200  mean 0.0200  median "
                                   "0.0200  max 0.0200\n"));
  CHECK_THAT(full, Catch::Contains("within 0.019 m: 0 / 400 poses (0.0 %)\n"
                                   "within 0.021 m: 400 / 400 poses (100.0 %)\n"));
  CHECK_THAT(full, Catch::Contains("   500.000       0       0.0000       0.0000        0.000    "
                                   "    0.000       0.0000  (path shorter than the segment)\n"));
  // Deterministic: no times in the full report.
  CHECK(EvaluateTrajectoryInputs(o, in).FullReport() == full);
}

TEST_CASE("the JSON of an evaluation is valid and its alignment reads back", "[eval]") {
  Dir dir;
  TrajectoryEvalOptions o = Options(dir);
  o.eval.alignment = AlignmentType::kSe3;
  const TrajectoryEvalSummary s = EvaluateTrajectoryInputs(o, ReadTrajectoryEvalInputs(o));
  std::ostringstream out;
  WriteTrajectoryEvalJson(out, s);
  const nlohmann::json j = nlohmann::json::parse(out.str());
  CHECK(j["schema_version"] == 1);
  CHECK(j["matched_poses"] == 400);
  CHECK(j["alignment"] == "se3");
  CHECK(j["alignment_from"].is_null());
  CHECK(j["ground_truth"]["format"] == "euroc");
  CHECK(j["estimate"]["poses"] == 400);
  CHECK(j["association"]["rule"] == "evo");
  CHECK(j["ate"]["translation_rmse_m"].get<double>() == Approx(0.02).margin(1e-6));
  REQUIRE(j["rpe"].size() == 2);
  CHECK(j["rpe"][1]["pairs"] == 0);
  REQUIRE(j["within"].size() == 2);
  CHECK(j["within"][1]["fraction"] == 1.0);

  // --align-from: the written transform applied to the same estimate gives the same errors.
  const std::string json_path = dir.path + "/a.json";
  std::ofstream(json_path) << out.str();
  const Alignment read = ReadAlignmentJson(json_path);
  CHECK(read.type == AlignmentType::kFixed);
  CHECK((read.T_G_E.translation() - s.result.alignment.T_G_E.translation()).norm() < 1e-8);
  TrajectoryEvalOptions fixed = o;
  fixed.eval.alignment = AlignmentType::kFixed;
  fixed.align_from_path = json_path;
  const TrajectoryEvalSummary f = EvaluateTrajectoryInputs(fixed, ReadTrajectoryEvalInputs(fixed));
  CHECK(f.result.alignment.type == AlignmentType::kFixed);
  CHECK(f.result.ate.translation_m.rmse == Approx(s.result.ate.translation_m.rmse).epsilon(1e-6));
  CHECK_THAT(f.FullReport(), Catch::Contains("alignment:     fixed (from " + json_path + ")"));
}

TEST_CASE("file evaluation errors name the files", "[eval]") {
  Dir dir;
  TrajectoryEvalOptions o = Options(dir);
  // A KITTI file (no stamps) with fewer poses than the other file.
  Trajectory kitti = Circle();
  kitti.t_ns.resize(10);
  kitti.T_W_B.resize(10);
  o.est_path = dir.path + "/est.kitti";
  WriteTrajectoryFile(o.est_path, kitti, TrajectoryFormat::kKitti);
  const TrajectoryEvalInputs in = ReadTrajectoryEvalInputs(o);
  CHECK_THROWS_WITH(EvaluateTrajectoryInputs(o, in),
                    o.est_path + ": expected 400 poses like " + o.gt_path +
                        " (a KITTI file has no time stamps, so poses are associated by index), "
                        "got 10");
  // No stamp within max_dt: the evaluation's error behind "EST vs GT: ".
  Trajectory late = Circle();
  for (auto& t : late.t_ns) t += 50000000;
  o.est_path = dir.path + "/late.txt";
  WriteTrajectoryFile(o.est_path, late, TrajectoryFormat::kTum);
  CHECK_THROWS_WITH(EvaluateTrajectoryInputs(o, ReadTrajectoryEvalInputs(o)),
                    Catch::StartsWith(o.est_path + " vs " + o.gt_path + ": "));
  // A missing alignment file fails before the trajectories are read.
  o.eval.alignment = AlignmentType::kFixed;
  o.align_from_path = dir.path + "/none.json";
  o.gt_path = dir.path + "/none.csv";
  CHECK_THROWS_WITH(ReadTrajectoryEvalInputs(o),
                    o.align_from_path + ": expected a readable JSON file");
}

}  // namespace
}  // namespace vilma
