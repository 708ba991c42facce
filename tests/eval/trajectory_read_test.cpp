// Reading other systems' trajectory files (core/src/trajectory_read.cpp): quirks detected and
// reported, repeated stamps dropped (the first pose kept), and the ATE on such files against
// values computed by hand, with evo's association rule deciding where it matters.
#include <catch2/catch.hpp>
#include <cmath>
#include <fstream>
#include <sstream>
#include <string>

#include "core/test_data.h"
#include "vilma/core/error.h"
#include "vilma/eval/trajectory.h"
#include "vilma/eval/evaluate.h"

namespace vilma {
namespace {

Trajectory Read(const std::string& text, const std::string& name,
                TrajectoryReadReport* report = nullptr) {
  std::istringstream in(text);
  return ReadTrajectory(in, name, report);
}

std::string ReadError(const std::string& text, const std::string& name) {
  try {
    Read(text, name);
  } catch (const InputError& e) {
    return e.what();
  }
  return "<no error>";
}

EvalOptions NoAlignment(AssociationRule rule) {
  EvalOptions o;
  o.alignment = AlignmentType::kNone;  // evo_ape's default (no -a)
  o.segment_lengths_m = {1.0};
  o.association.rule = rule;
  return o;
}

}  // namespace

TEST_CASE("ParseNanoseconds: integers exact, decimals rounded, exponent through double",
          "[trajectory]") {
  int64_t t = 0;
  REQUIRE(ParseNanoseconds("1403715273262142976", &t));
  CHECK(t == 1403715273262142976);
  REQUIRE(ParseNanoseconds("1403715273262142976.500000", &t));
  CHECK(t == 1403715273262142977);
  REQUIRE(ParseNanoseconds("1403715273262142976.4", &t));
  CHECK(t == 1403715273262142976);
  REQUIRE(ParseNanoseconds("1.40372e+18", &t));  // ORB-SLAM3 with 6 significant digits
  CHECK(t == 1403720000000000000);
  REQUIRE(ParseNanoseconds("-5", &t));
  CHECK(t == -5);
  CHECK_FALSE(ParseNanoseconds("", &t));
  CHECK_FALSE(ParseNanoseconds(".", &t));
  CHECK_FALSE(ParseNanoseconds("12x", &t));
  CHECK_FALSE(ParseNanoseconds("99999999999999999999", &t));  // beyond int64
}

TEST_CASE("ORB-SLAM-style TUM file: nanosecond stamps, a repeated stamp keeps the first pose",
          "[trajectory]") {
  const std::string text =
      "1403715274000000000 0 0 0 0 0 0 1\n"
      "1403715274050000000 1 0 0 0 0 0 1\n"
      "1403715274050000000 9 9 9 0 0 0 1\n"  // repeated: dropped
      "1403715274100000000 2 0 0 0 0 0 1\n";
  TrajectoryReadReport report;
  const Trajectory t = Read(text, "orb.txt", &report);
  REQUIRE(t.size() == 3);
  CHECK(t.format == TrajectoryFormat::kTum);
  CHECK(t.t_ns[1] == 1403715274050000000);
  CHECK(t.T_W_B[1].translation() == Eigen::Vector3d(1, 0, 0));  // the first of the two
  CHECK(t.t_ns[2] == 1403715274100000000);
  CHECK(report.poses == 3);
  CHECK(report.stamp_unit == StampUnit::kNanoseconds);
  REQUIRE(report.repeated_stamps.size() == 1);
  CHECK(report.repeated_stamps[0].line == 3);
  CHECK(report.repeated_stamps[0].first_line == 2);
  CHECK(TrajectoryReadSummary(report) ==
        "read orb.txt: 3 poses, format TUM (t x y z qx qy qz qw), stamps in nanoseconds (> "
        "1e12), space-separated, 1 repeated stamp dropped");
  CHECK(TrajectoryReadWarnings(report) ==
        std::vector<std::string>{"orb.txt: line 3: repeated time stamp 1403715274050000000 "
                                 "(first at line 2): dropped"});
}

TEST_CASE("many repeated stamps: five warnings and a summary line", "[trajectory]") {
  std::string text = "0.0 0 0 0 0 0 0 1\n";
  for (int i = 1; i <= 4; ++i) {
    const std::string stamp = std::to_string(i) + ".5";
    text += stamp + " 0 0 0 0 0 0 1\n" + stamp + " 1 1 1 0 0 0 1\n" + stamp + " 2 2 2 0 0 0 1\n";
  }
  // Lines: 1; 2-4 (1.5 x3), 5-7, 8-10, 11-13: 8 repeats at lines 3, 4, 6, 7, 9, 10, 12, 13.
  TrajectoryReadReport report;
  const Trajectory t = Read(text, "many.txt", &report);
  CHECK(t.size() == 5);
  const std::vector<std::string> w = TrajectoryReadWarnings(report);
  REQUIRE(w.size() == 6);
  CHECK(w[0] == "many.txt: line 3: repeated time stamp 1.5 (first at line 2): dropped");
  CHECK(w[1] == "many.txt: line 4: repeated time stamp 1.5 (first at line 2): dropped");
  CHECK(w[4] == "many.txt: line 9: repeated time stamp 3.5 (first at line 8): dropped");
  CHECK(w[5] == "many.txt: 3 more repeated time stamps dropped (lines 10, 12, 13)");
  CHECK(TrajectoryReadSummary(report).find(", 8 repeated stamps dropped") != std::string::npos);
}

TEST_CASE("quirks: BOM, header row without '#', commas and spaces, trailing commas, CRLF",
          "[trajectory]") {
  // A CSV in TUM order (the header names qw last), stamps in seconds, Windows line ends.
  const std::string text =
      "\xEF\xBB\xBFtimestamp, tx, ty, tz, qx, qy, qz, qw\r\n"
      "1403715274.000, 1, 2, 3, 0, 0, 0, 1,\r\n"
      "\r\n"
      "1403715274.100, 1, 2, 3, 0, 0, 0.7071068, 0.7071068,\r\n"
      "# end\r\n";
  TrajectoryReadReport report;
  const Trajectory t = Read(text, "q.csv", &report);
  REQUIRE(t.size() == 2);
  CHECK(t.format == TrajectoryFormat::kTum);
  CHECK(t.t_ns[0] == 1403715274000000000);
  CHECK(t.t_ns[1] == 1403715274100000000);
  // x y z w = 0 0 .707 .707: 90 deg about z (read w-first it would be 90 deg about x).
  CHECK((t.T_W_B[1].rotation() * Eigen::Vector3d::UnitX() - Eigen::Vector3d::UnitY()).norm() <
        1e-6);
  CHECK(report.crlf_lines == 5);
  CHECK(TrajectoryReadSummary(report) ==
        "read q.csv: 2 poses, format TUM (t x y z qx qy qz qw) from the header, stamps in "
        "seconds (decimals <= 1e12), mixed separators (comma, space), 1 header line (1 without "
        "'#'), 1 comment line, 1 blank line, CRLF line ends, UTF-8 byte order mark, trailing "
        "separator on 2 lines");
  CHECK(TrajectoryReadWarnings(report).empty());
}

TEST_CASE("quirks: EuRoC state CSV, tabs, w-first header in a whitespace file", "[trajectory]") {
  TrajectoryReadReport report;
  const Trajectory euroc = Read(
      "#timestamp [ns],p_RS_R_x [m],p_RS_R_y [m],p_RS_R_z [m],q_RS_w [],q_RS_x [],q_RS_y [],"
      "q_RS_z [],v_x,v_y,v_z\n"
      "5,1,2,3,1,0,0,0,9,9,9\n7,1,2,3,1,0,0,0,9,9,9\n",
      "gt.csv", &report);
  CHECK(euroc.format == TrajectoryFormat::kEuroc);
  CHECK(euroc.t_ns[1] == 7);
  CHECK(TrajectoryReadSummary(report) ==
        "read gt.csv: 2 poses, format EuRoC (t p_xyz q_wxyz), stamps in nanoseconds (CSV "
        "integers, the EuRoC convention), comma-separated, 11 columns (9-11 ignored), 1 header "
        "line");

  const Trajectory tabs = Read("0.1\t1 2 3\t0 0 0 1 \n", "tabs.txt", &report);
  CHECK(tabs.t_ns[0] == 100000000);
  CHECK(TrajectoryReadSummary(report) ==
        "read tabs.txt: 1 pose, format TUM (t x y z qx qy qz qw), stamps in seconds (<= 1e12), "
        "mixed separators (space, tab), trailing separator on 1 line");

  // The header names qw in column 5: w x y z although whitespace-separated.
  const Trajectory wfirst =
      Read("# t x y z qw qx qy qz\n0 1 2 3 0.7071068 0 0 0.7071068\n", "w.txt", &report);
  CHECK(wfirst.format == TrajectoryFormat::kEuroc);
  CHECK(report.quaternion_order_from_header);
  CHECK((wfirst.T_W_B[0].rotation() * Eigen::Vector3d::UnitX() - Eigen::Vector3d::UnitY()).norm() <
        1e-6);
}

TEST_CASE("malformed rows name the file, the line, the column and what was expected",
          "[trajectory]") {
  CHECK(ReadError("# h\n0 0 0 0 0 0 0 1\n1 0 0 0 x 0 0 1\n", "e.txt") ==
        "e.txt: line 3: expected a finite number in column 5 (TUM: t x y z qx qy qz qw), got "
        "'x'");
  CHECK(ReadError("1,2,3,4,1,0,0,0\n2,3,4,1,0,0,0\n", "e.csv") ==
        "e.csv: line 2: expected 8 comma-separated columns (EuRoC CSV: t, p_x, p_y, p_z, q_w, "
        "q_x, q_y, q_z[, more columns, ignored]), got 7");
  CHECK(ReadError("1,2,3,4,1,0,0,0\n2, ,3,4,1,0,0,0\n", "e.csv") ==
        "e.csv: line 2: expected a finite number in column 2 (EuRoC CSV: t, p_x, p_y, p_z, q_w, "
        "q_x, q_y, q_z[, more columns, ignored]), got ''");
  CHECK(ReadError("1403715274.0 0 0 0 0 0 0 1\n1403715274100000000 0 0 0 0 0 0 1\n", "u.txt") ==
        "u.txt: line 2: expected a time stamp in seconds in column 1 like line 1, got "
        "'1403715274100000000' (nanoseconds: > 1e12)");
  // A repeated row is checked in full before it is dropped.
  CHECK(ReadError("1 0 0 0 0 0 0 1\n1 0 0 0 0 0 0 5\n", "r.txt") ==
        "r.txt: line 2: expected a unit quaternion (norm within 0.1 of 1), got norm 5");
}

// The estimate is a quirky CSV (header, CRLF, nanoseconds, a repeated stamp whose second pose
// is far off); every estimate has exactly one ground-truth stamp within 10 ms, so the pairs
// are the same under any rule. With no alignment (evo_ape's default), by hand:
//   errors 0.3, 0.4, 0, 1.2 -> RMSE sqrt((0.09 + 0.16 + 0 + 1.44) / 4) = sqrt(0.4225) = 0.65,
//   mean 0.475, max 1.2.
// evo itself keeps both poses of the repeated stamp (its own PoseTrajectory3D.check() calls
// such a file invalid); vilma equals evo run on the file with the repeat removed.
TEST_CASE("ATE on a quirky file with a repeated stamp equals the hand-computed value",
          "[trajectory][eval]") {
  testing::TempDir dir;
  const std::string gt_path = dir.File("gt.txt");
  const std::string est_path = dir.File("est.csv");
  std::ofstream(gt_path) << "# timestamp tx ty tz qx qy qz qw\n"
                            "1403715274.00 0 0 0 0 0 0 1\n"
                            "1403715274.05 1 0 0 0 0 0 1\n"
                            "1403715274.10 2 0 0 0 0 0 1\n"
                            "1403715274.15 3 0 0 0 0 0 1\n"
                            "1403715274.20 4 0 0 0 0 0 1\n";
  std::ofstream(est_path, std::ios::binary) << "#timestamp [ns],p_x,p_y,p_z,q_w,q_x,q_y,q_z\r\n"
                                               "1403715274002000000,0,0.3,0,1,0,0,0\r\n"
                                               "1403715274051000000,1,0,0.4,1,0,0,0\r\n"
                                               "1403715274051000000,1,5,5,1,0,0,0\r\n"
                                               "1403715274099000000,2,0,0,1,0,0,0\r\n"
                                               "1403715274153000000,3,1.2,0,1,0,0,0\r\n";
  TrajectoryReadReport report;
  const Trajectory gt = ReadTrajectoryFile(gt_path);
  const Trajectory est = ReadTrajectoryFile(est_path, &report);
  REQUIRE(est.size() == 4);
  CHECK(TrajectoryReadSummary(report) ==
        "read " + est_path +
            ": 4 poses, format EuRoC (t p_xyz q_wxyz), stamps in nanoseconds (> 1e12), "
            "comma-separated, 1 header line, CRLF line ends, 1 repeated stamp dropped");
  CHECK(TrajectoryReadWarnings(report) ==
        std::vector<std::string>{est_path + ": line 4: repeated time stamp 1403715274051000000 "
                                            "(first at line 3): dropped"});
  for (AssociationRule rule : {AssociationRule::kEvo, AssociationRule::kUnique}) {
    CAPTURE(AssociationRuleName(rule));
    const EvalResult r = EvaluateTrajectory(gt, est, NoAlignment(rule));
    REQUIRE(r.association.size() == 4);
    CHECK(r.association.gt_index == std::vector<std::size_t>{0, 1, 2, 3});
    CHECK(r.ate.translation_m.rmse == Approx(0.65).epsilon(1e-12));
    CHECK(r.ate.translation_m.mean == Approx(0.475).epsilon(1e-12));
    CHECK(r.ate.translation_m.max == Approx(1.2).epsilon(1e-12));
    CHECK(r.ate.rotation_deg.max == 0.0);
  }
}

// Where evo's rule decides: the estimate (4 poses) is shorter than the ground truth (5), so
// evo walks the estimate and gives each stamp its nearest ground-truth stamp within 10 ms:
//   3 ms -> gt 0 ms (error 0.1), 95 ms -> gt 100 ms (0.3), 102 ms -> gt 100 ms (0.4),
//   405 ms -> gt 400 ms (0): gt 100 ms is used twice.
//   RMSE = sqrt((0.01 + 0.09 + 0.16 + 0) / 4) = sqrt(0.065) = 0.254950975679639.
// The one-to-one rule gives 100 ms to the nearer 102 ms and drops 95 ms:
//   RMSE = sqrt((0.01 + 0.16 + 0) / 3) = sqrt(0.17 / 3) = 0.238047614284762.
TEST_CASE("ATE where evo's nearest-stamp rule decides the pairs", "[trajectory][eval]") {
  const Trajectory gt = Read(
      "0.0 0 0 0 0 0 0 1\n0.1 1 0 0 0 0 0 1\n0.2 2 0 0 0 0 0 1\n0.3 3 0 0 0 0 0 1\n"
      "0.4 4 0 0 0 0 0 1\n",
      "gt.txt");
  const Trajectory est = Read(
      "0.003,0,0.1,0,1,0,0,0\n0.095,1,0.3,0,1,0,0,0\n0.102,1,0,0.4,1,0,0,0\n"
      "0.405,4,0,0,1,0,0,0\n",
      "est.csv");
  const EvalResult evo = EvaluateTrajectory(gt, est, NoAlignment(AssociationRule::kEvo));
  CHECK(evo.association.est_index == std::vector<std::size_t>{0, 1, 2, 3});
  CHECK(evo.association.gt_index == std::vector<std::size_t>{0, 1, 1, 4});
  CHECK(evo.ate.translation_m.rmse == Approx(std::sqrt(0.065)).epsilon(1e-12));
  CHECK(evo.ate.translation_m.rmse == Approx(0.254950975679639).epsilon(1e-12));

  const EvalResult unique = EvaluateTrajectory(gt, est, NoAlignment(AssociationRule::kUnique));
  CHECK(unique.association.est_index == std::vector<std::size_t>{0, 2, 3});
  CHECK(unique.association.gt_index == std::vector<std::size_t>{0, 1, 4});
  CHECK(unique.ate.translation_m.rmse == Approx(0.238047614284762).epsilon(1e-12));
}

}  // namespace vilma
