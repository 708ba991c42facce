#include "vilma/eval/trajectory.h"

#include <catch2/catch.hpp>

#include <cmath>
#include <fstream>
#include <sstream>
#include <string>

#include "vilma/core/error.h"
#include "test_skip.h"

namespace vilma {
namespace {

Trajectory Read(const std::string& text, const std::string& name = "traj.txt") {
  std::istringstream in(text);
  return ReadTrajectory(in, name);
}

std::string ReadError(const std::string& text, const std::string& name = "traj.txt") {
  try {
    Read(text, name);
  } catch (const InputError& e) {
    return e.what();
  }
  return "<no error>";
}

}  // namespace

TEST_CASE("ParseSecondsToNs is exact for decimal stamps", "[trajectory]") {
  int64_t t = 0;
  REQUIRE(ParseSecondsToNs("1403715274.30214", &t));
  CHECK(t == 1403715274302140000);
  REQUIRE(ParseSecondsToNs("1403715274.302142976", &t));
  CHECK(t == 1403715274302142976);
  REQUIRE(ParseSecondsToNs("12", &t));
  CHECK(t == 12000000000);
  REQUIRE(ParseSecondsToNs("-0.5", &t));
  CHECK(t == -500000000);
  REQUIRE(ParseSecondsToNs(".25", &t));
  CHECK(t == 250000000);
  REQUIRE(ParseSecondsToNs("0.0000000015", &t));  // 10th decimal rounds
  CHECK(t == 2);
  REQUIRE(ParseSecondsToNs("1.5e2", &t));
  CHECK(t == 150000000000);
  CHECK_FALSE(ParseSecondsToNs("", &t));
  CHECK_FALSE(ParseSecondsToNs(".", &t));
  CHECK_FALSE(ParseSecondsToNs("1.2.3", &t));
  CHECK_FALSE(ParseSecondsToNs("abc", &t));
  CHECK_FALSE(ParseSecondsToNs("99999999999", &t));  // beyond int64 nanoseconds
}

TEST_CASE("TUM with and without header", "[trajectory]") {
  const std::string body =
      "1403715274.30214 0.878612 2.142470 0.947262 -0.828459 -0.058956 -0.553641 0.060514\n"
      "1403715274.30714 1 2 3 0 0 0 1\n";
  const Trajectory with_header = Read("# timestamp(s) tx ty tz qx qy qz qw\n" + body);
  const Trajectory without = Read(body);
  for (const Trajectory* t : {&with_header, &without}) {
    REQUIRE(t->size() == 2);
    CHECK(t->format == TrajectoryFormat::kTum);
    CHECK(t->has_timestamps);
    CHECK(t->t_ns[0] == 1403715274302140000);
    CHECK(t->t_ns[1] == 1403715274307140000);
    CHECK(t->T_W_B[0].translation().x() == Approx(0.878612));
    CHECK(t->T_W_B[0].translation().z() == Approx(0.947262));
    // x y z w order: w = 0.060514 (normalized by a factor ~1).
    CHECK(t->T_W_B[0].rotation().w() == Approx(0.060514).epsilon(1e-4));
    CHECK(t->T_W_B[0].rotation().x() == Approx(-0.828459).epsilon(1e-4));
    CHECK(t->T_W_B[1].translation() == Eigen::Vector3d(1, 2, 3));
    CHECK(t->T_W_B[1].rotation().w() == 1.0);
  }
  // Tabs, blank lines, CRLF and trailing comments lines are fine.
  const Trajectory tabs = Read("\r\n0.1\t1 2 3\t0 0 0 1\r\n\n# end\n");
  REQUIRE(tabs.size() == 1);
  CHECK(tabs.t_ns[0] == 100000000);
}

TEST_CASE("EuRoC CSV: 17-column state and 8-column pose, quaternion w first", "[trajectory]") {
  const std::string state =
      "#timestamp [ns], p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], q_RS_y "
      "[], q_RS_z [], v_RS_R_x [m s^-1], v_RS_R_y [m s^-1], v_RS_R_z [m s^-1], b_w_RS_S_x [rad "
      "s^-1], b_w_RS_S_y [rad s^-1], b_w_RS_S_z [rad s^-1], b_a_RS_S_x [m s^-2], b_a_RS_S_y [m "
      "s^-2], b_a_RS_S_z [m s^-2]\n"
      "1403715273262142976,0.878895,2.1834,0.948427,0.069433,-0.824237,-0.106942,-0.551702,"
      "0.00157587,0.00179383,-0.00231615,-0.00224703,0.0215352,0.0770299,-0.0180115,0.0659796,"
      "0.0309774\n"
      "1403715273312143104, 1, 2, 3, 0, 1, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0, 0\n";
  const Trajectory t = Read(state, "data.csv");
  REQUIRE(t.size() == 2);
  CHECK(t.format == TrajectoryFormat::kEuroc);
  CHECK(t.t_ns[0] == 1403715273262142976);
  CHECK(t.t_ns[1] == 1403715273312143104);
  CHECK(t.T_W_B[0].rotation().w() == Approx(0.069433).epsilon(1e-4));
  CHECK(t.T_W_B[0].rotation().z() == Approx(-0.551702).epsilon(1e-4));
  CHECK(t.T_W_B[1].rotation().x() == 1.0);  // w x y z = 0 1 0 0: 180 deg about x
  CHECK(t.T_W_B[1].translation() == Eigen::Vector3d(1, 2, 3));

  const Trajectory pose = Read("#timestamp,x,y,z,qw,qx,qy,qz\n5,1,2,3,1,0,0,0\n7,1,2,3,1,0,0,0\n");
  REQUIRE(pose.size() == 2);
  CHECK(pose.format == TrajectoryFormat::kEuroc);
  CHECK(pose.t_ns[1] == 7);
}

TEST_CASE("KITTI poses have no time stamps and are indexed", "[trajectory]") {
  const Trajectory t = Read(
      "1.000000e+00 0 0 0 0 1.000000e+00 0 0 0 0 1.000000e+00 0\n"
      "0 -1 0 1.5 1 0 0 2.5 0 0 1 -3.5\n");
  REQUIRE(t.size() == 2);
  CHECK(t.format == TrajectoryFormat::kKitti);
  CHECK_FALSE(t.has_timestamps);
  CHECK(t.t_ns[0] == 0);
  CHECK(t.t_ns[1] == 1);
  CHECK(t.T_W_B[1].translation() == Eigen::Vector3d(1.5, 2.5, -3.5));
  // R = Rz(90 deg): x_B -> y_W.
  CHECK((t.T_W_B[1].rotation() * Eigen::Vector3d::UnitX() - Eigen::Vector3d::UnitY()).norm() <
        1e-12);
}

TEST_CASE("format detection from content", "[trajectory]") {
  auto detect = [](const std::string& text) {
    std::istringstream in(text);
    return DetectTrajectoryFormat(in, "f");
  };
  CHECK(detect("# t x y z qx qy qz qw\n0 0 0 0 0 0 0 1\n") == TrajectoryFormat::kTum);
  CHECK(detect("#ts,...\n1,0,0,0,1,0,0,0\n") == TrajectoryFormat::kEuroc);
  CHECK(detect("1 0 0 0 0 1 0 0 0 0 1 0\n") == TrajectoryFormat::kKitti);
  CHECK_THROWS_WITH(detect("1 2 3\n"),
                    Catch::Contains("f: line 1: expected a trajectory line") &&
                        Catch::Contains("got 3 whitespace-separated columns"));
}

TEST_CASE("malformed trajectories give exact errors", "[trajectory]") {
  CHECK(ReadError("# header\n0 0 0 0 0 0 0 1\n1 0 0 0 0 0 1\n") ==
        "traj.txt: line 3: expected 8 whitespace-separated columns (TUM: t x y z qx qy qz qw), "
        "got 7");
  CHECK(ReadError("0 0 0 abc 0 0 0 1\n") ==
        "traj.txt: line 1: expected a finite number in column 4 (TUM: t x y z qx qy qz qw), got "
        "'abc'");
  CHECK(ReadError("0 0 0 nan 0 0 0 1\n") ==
        "traj.txt: line 1: expected a finite number in column 4 (TUM: t x y z qx qy qz qw), got "
        "'nan'");
  // A header row without '#' is fine before the first pose (trajectory_read_test.cpp), not after.
  CHECK(ReadError("0 0 0 0 0 0 0 1\ntimestamp tx ty tz qx qy qz qw\n") ==
        "traj.txt: line 2: expected a time stamp in column 1 (TUM: t x y z qx qy qz qw), got "
        "'timestamp' (header rows only before the first pose)");
  // A repeated stamp is dropped with a warning (trajectory_read_test.cpp); a decreasing one is
  // an error.
  CHECK(ReadError("2 0 0 0 0 0 0 1\n\n1 0 0 0 0 0 0 1\n") ==
        "traj.txt: line 3: expected increasing time stamps, got 1 after 2 at line 1 (decreasing "
        "stamps are not sorted: two runs in one file?)");
  CHECK(ReadError("1 0 0 0 0 0 0 2\n") ==
        "traj.txt: line 1: expected a unit quaternion (norm within 0.1 of 1), got norm 2");
  CHECK(ReadError("") ==
        "traj.txt: expected at least one trajectory line (TUM, EuRoC CSV or KITTI), found none");
  CHECK(ReadError("# only a header\n\n") ==
        "traj.txt: expected at least one trajectory line (TUM, EuRoC CSV or KITTI), found none");
  CHECK(ReadError("1 2 3 4 5\n") ==
        "traj.txt: line 1: expected a trajectory line: 8 whitespace-separated columns (TUM: t x "
        "y z qx qy qz qw), 12 whitespace-separated columns (KITTI: r11 r12 r13 tx r21 r22 r23 ty "
        "r31 r32 r33 tz) or 8 or more comma-separated columns (EuRoC CSV: t, p_x, p_y, p_z, "
        "q_w, q_x, q_y, q_z[, more columns, ignored]); got 5 whitespace-separated columns");
  // The unit of the first stamp holds for the whole file.
  CHECK(ReadError("1403715273262142976,0,0,0,1,0,0,0\n1403715273.3,0,0,0,1,0,0,0\n", "gt.csv") ==
        "gt.csv: line 2: expected a time stamp in nanoseconds in column 1 like line 1, got "
        "'1403715273.3' (seconds: decimals <= 1e12)");
  CHECK(ReadError("1,0,0,0,1,0,0,0\n2,0,,0,1,0,0,0\n", "gt.csv") ==
        "gt.csv: line 2: expected a finite number in column 3 (EuRoC CSV: t, p_x, p_y, p_z, q_w, "
        "q_x, q_y, q_z[, more columns, ignored]), got ''");
  CHECK(ReadError("1,0,0,0,1,0,0,0\n2 0 0 0 1 0 0 0\n", "gt.csv") ==
        "gt.csv: line 2: expected 8 comma-separated columns (EuRoC CSV: t, p_x, p_y, p_z, q_w, "
        "q_x, q_y, q_z[, more columns, ignored]), got 8 with other separators");
  CHECK(ReadError("2 0 0 0 0 2 0 0 0 0 1 0\n", "poses.txt") ==
        "poses.txt: line 1: expected an orthonormal rotation with determinant +1 (within 1e-3) "
        "in columns 1-3, 5-7, 9-11 (KITTI: r11 r12 r13 tx r21 r22 r23 ty r31 r32 r33 tz)");
}

TEST_CASE("missing file names the file", "[trajectory]") {
  CHECK_THROWS_WITH(ReadTrajectoryFile("/nonexistent/dir/gt.txt"),
                    "/nonexistent/dir/gt.txt: expected a readable trajectory file");
}

TEST_CASE("writers round-trip through the readers", "[trajectory]") {
  Trajectory t;
  for (int i = 0; i < 5; ++i) {
    const Eigen::Quaterniond q =
        ExpSO3(Eigen::Vector3d(0.1 * i, -0.2 + 0.05 * i, 0.3 * i)).normalized();
    t.Add(1403715273262142976 + i * 5000001, Transformation(q, Eigen::Vector3d(i, -2.0 * i,
                                                                                 0.125 * i)));
  }
  const TrajectoryFormat format =
      GENERATE(TrajectoryFormat::kTum, TrajectoryFormat::kEuroc, TrajectoryFormat::kKitti);
  CAPTURE(TrajectoryFormatName(format));
  std::ostringstream out;
  if (format == TrajectoryFormat::kTum) WriteTumTrajectory(out, t);
  if (format == TrajectoryFormat::kEuroc) WriteEurocTrajectory(out, t);
  if (format == TrajectoryFormat::kKitti) WriteKittiTrajectory(out, t);
  const Trajectory back = Read(out.str());
  REQUIRE(back.size() == t.size());
  CHECK(back.format == format);
  for (std::size_t i = 0; i < t.size(); ++i) {
    if (format != TrajectoryFormat::kKitti) {
      CHECK(back.t_ns[i] == t.t_ns[i]);  // exact, also through TUM seconds
    }
    CHECK((back.T_W_B[i].translation() - t.T_W_B[i].translation()).norm() < 1e-8);
    CHECK(AngleBetween(back.T_W_B[i].rotation(), t.T_W_B[i].rotation()) < 1e-8);
  }
}

TEST_CASE("real EuRoC ground truth and TUM files load", "[trajectory]") {
  const std::string dir = std::string(VILMA_SHARED_DATA_DIR) + "/euroc_V1_01_micro";
  std::ifstream probe(dir + "/V1_01_easy_gt_original_tum.txt");
  if (!probe) {
    VILMA_SKIP("shared data not found at " << dir);
  }
  const Trajectory tum = ReadTrajectoryFile(dir + "/V1_01_easy_gt_original_tum.txt");
  CHECK(tum.format == TrajectoryFormat::kTum);
  CHECK(tum.size() == 28712);
  const Trajectory csv = ReadTrajectoryFile(dir + "/mav0/state_groundtruth_estimate0/data.csv");
  CHECK(csv.format == TrajectoryFormat::kEuroc);
  CHECK(csv.size() == 2895);
  CHECK(csv.t_ns.front() == 1403715273262142976);
}

}  // namespace vilma
