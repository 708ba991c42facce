#include "eval_command_fixture.h"
#include "vilma/eval/alignment_json.h"
#include "test_skip.h"

#include <catch2/catch.hpp>

namespace vilma::console {

using namespace eval_test;  // NOLINT: the shared fixture of the eval command tests

TEST_CASE("eval argument parsing", "[eval]") {
  const EvalCommandOptions d = ParseEvalArgs({"--gt", "a.csv", "--est", "b.txt"});
  CHECK(d.gt_path == "a.csv");
  CHECK(d.est_path == "b.txt");
  CHECK(d.eval.alignment == AlignmentType::kPosYaw);
  CHECK(d.eval.segment_lengths_m == std::vector<double>{10, 20, 30, 40, 50});
  CHECK(d.eval.association.max_dt_s == 0.01);
  CHECK(d.json_path.empty());
  CHECK(d.plot_path.empty());

  const EvalCommandOptions o =
      ParseEvalArgs({"--gt=a", "--est", "b", "--align", "sim3", "--segments", "1,2.5",
                     "--max-dt=0.02", "--json", "o.json", "--plot", "o.png"});
  CHECK(o.eval.alignment == AlignmentType::kSim3);
  CHECK(o.eval.segment_lengths_m == std::vector<double>{1.0, 2.5});
  CHECK(o.eval.association.max_dt_s == 0.02);
  CHECK(o.json_path == "o.json");
  CHECK(o.plot_path == "o.png");
  CHECK(ParseEvalArgs({"--help"}).help);

  CHECK_THROWS_WITH(ParseEvalArgs({"--gt", "a", "--est", "b", "--frobnicate"}),
                    "unknown option '--frobnicate'");
  CHECK_THROWS_WITH(ParseEvalArgs({"--gt", "a", "--est"}), "--est: expected a value");
  CHECK_THROWS_WITH(ParseEvalArgs({"a.csv", "b.txt"}),
                    "unexpected argument 'a.csv' (files go after --gt and --est)");
  CHECK_THROWS_WITH(ParseEvalArgs({"--gt", "a", "--est", "b", "--align", "affine"}),
                    "--align: expected posyaw, se3, sim3, none or first, got 'affine'");
  CHECK_THROWS_WITH(ParseEvalArgs({"--gt", "a", "--est", "b", "--align", "first-se3"}),
                    "--align: expected posyaw, se3, sim3, none or first, got 'first-se3'");
  CHECK(ParseEvalArgs({"--gt", "a", "--est", "b", "--align", "first"}).eval.alignment ==
        AlignmentType::kFirst);
  CHECK(d.eval.within_m.empty());
  CHECK(ParseEvalArgs({"--gt", "a", "--est", "b", "--within", "0.5"}).eval.within_m ==
        std::vector<double>{0.5});
  CHECK(ParseEvalArgs({"--gt", "a", "--est", "b", "--within=1,0.25,0"}).eval.within_m ==
        std::vector<double>{1.0, 0.25, 0.0});
  CHECK_THROWS_WITH(ParseEvalArgs({"--gt", "a", "--est", "b", "--segments", "10,x"}),
                    "--segments: expected a number, got 'x'");
  CHECK_THROWS_WITH(ParseEvalArgs({"--gt", "a", "--est", "b", "--segments", "10,0"}),
                    "--segments: expected lengths > 0 [m], got 10,0");
  CHECK_THROWS_WITH(ParseEvalArgs({"--est", "b"}),
                    "--gt: expected a ground-truth trajectory file");
  CHECK_THROWS_WITH(ParseEvalArgs({"--gt", "a", "--est", "b", "--max-dt", "-1"}),
                    "association.max_dt_s: expected a finite time difference >= 0 [s]");
}

TEST_CASE("eval --association and the read report on stderr", "[eval]") {
  CHECK(ParseEvalArgs({"--gt", "a", "--est", "b"}).eval.association.rule ==
        AssociationRule::kEvo);
  CHECK(ParseEvalArgs({"--gt", "a", "--est", "b", "--association", "unique"})
            .eval.association.rule == AssociationRule::kUnique);
  CHECK_THROWS_WITH(ParseEvalArgs({"--gt", "a", "--est", "b", "--association", "tum"}),
                    "--association: expected evo or unique, got 'tum'");

  // An ORB-SLAM-like estimate: nanosecond stamps in a TUM file, one stamp repeated.
  Files f;
  WriteInputs(f);
  const std::string orb = f.dir + "/orb.txt";
  {
    const Trajectory gt = MakeGroundTruth();
    std::ofstream out(orb);
    for (std::size_t i = 0; i < 100; ++i) {
      const Eigen::Vector3d& p = gt.T_W_B[i].translation();
      const Eigen::Quaterniond& q = gt.T_W_B[i].rotation();
      const int repeats = i == 10 ? 2 : 1;
      for (int k = 0; k < repeats; ++k) {
        out << gt.t_ns[i] << " " << p.x() << " " << p.y() << " " << p.z() << " " << q.x() << " "
            << q.y() << " " << q.z() << " " << q.w() << "\n";
      }
    }
  }
  const Result r = Eval({"--gt", f.gt, "--est", orb, "--align", "none", "--segments", "1"});
  INFO(r.err);
  REQUIRE(r.code == kExitOk);
  CHECK(r.out.find("matched poses: 100 (max dt 0.01 s, evo rule)") != std::string::npos);
  CHECK(r.out.find("ATE translation [m]:  rmse 0.0000") != std::string::npos);
  CHECK(r.err.find("vilma eval: read " + f.gt + ": 1200 poses, format EuRoC") == 0);
  CHECK(r.err.find("vilma eval: read " + orb +
                   ": 100 poses, format TUM (t x y z qx qy qz qw), stamps in nanoseconds (> "
                   "1e12), space-separated, 1 repeated stamp dropped\n") != std::string::npos);
  CHECK(r.err.find("vilma eval: warning: " + orb + ": line 12: repeated time stamp " +
                   std::to_string(MakeGroundTruth().t_ns[10]) + " (first at line 11): dropped\n") !=
        std::string::npos);
}

TEST_CASE("eval exit codes and messages name the file", "[eval]") {
  Files f;
  WriteInputs(f);
  const Result usage = Eval({"--gt", f.gt});
  CHECK(usage.code == kExitUsage);
  CHECK(usage.err.find("--est: expected an estimated trajectory file") != std::string::npos);

  const Result missing = Eval({"--gt", f.gt, "--est", f.dir + "/nope.txt"});
  CHECK(missing.code == kExitInputError);
  CHECK(missing.err == "vilma eval: error: " + f.dir +
                           "/nope.txt: expected a readable trajectory file\n");

  const std::string bad = f.dir + "/bad.txt";
  std::ofstream(bad) << "# t x y z qx qy qz qw\n0 0 0 0 0 0 0 1\n1 0 0 0 0 0 1\n";
  const Result malformed = Eval({"--gt", f.gt, "--est", bad});
  CHECK(malformed.code == kExitInputError);
  CHECK(malformed.err == "vilma eval: error: " + bad +
                             ": line 3: expected 8 whitespace-separated columns (TUM: t x y z "
                             "qx qy qz qw), got 7\n");

  const Result help = Eval({"--help"});
  CHECK(help.code == kExitOk);
  CHECK(help.out.find("usage: vilma eval --gt GT --est EST") != std::string::npos);
}

TEST_CASE("eval end to end with --json parse-back", "[eval]") {
  Files f;
  WriteInputs(f);
  const std::string json = f.dir + "/out.json";
  const Result r = Eval({"--gt", f.gt, "--est", f.est, "--json", json, "--segments", "5,10,500"});
  INFO(r.err);
  REQUIRE(r.code == kExitOk);
  CHECK(r.out.find("matched poses: 1200") != std::string::npos);
  CHECK(r.out.find("alignment:     posyaw") != std::string::npos);
  CHECK(r.out.find("(path shorter than the segment)") != std::string::npos);  // 500 m

  // The wobble is +-5 cm along x of G, mean zero: after posyaw alignment every error is ~5 cm.
  const std::string text = Slurp(json);
  REQUIRE_FALSE(text.empty());
  std::string parsed;
  const std::string script =
      "import json,sys; d=json.load(open(sys.argv[1])); "
      "print(d['schema_version'], d['matched_poses'], d['alignment'], d['scale'], "
      "'%.4f' % d['ate']['translation_rmse_m'], '%.4f' % d['ate']['rotation_rmse_deg'], "
      "len(d['rpe']), d['rpe'][0]['length_m'], d['rpe'][2]['pairs'], "
      "d['rpe'][0]['pairs'] > 0, 'translation_mean_percent' in d['rpe'][0], "
      "'rotation_rmse_deg' in d['rpe'][0], 'translation_rmse_m' in d['rpe'][0])";
  const int code = Run("python3 -c \"" + script + "\" " + json + " 2>&1", &parsed);
  if (code != 0 && parsed.find("not found") != std::string::npos) {
    VILMA_SKIP_NOTE("python3 not available, JSON checked by text only");
    CHECK(text.find("\"translation_rmse_m\"") != std::string::npos);
  } else {
    INFO(text);
    CHECK(code == 0);
    CHECK(parsed == "1 1200 posyaw 1 0.0500 0.0000 3 5 0 True True True True\n");
  }
}

TEST_CASE("eval --plot writes a PNG", "[eval]") {
  std::string ignored;
  const bool have_matplotlib =
      Run("python3 -c 'import matplotlib' 2>/dev/null", &ignored) == 0 ||
      Run("/usr/bin/python3 -c 'import matplotlib' 2>/dev/null", &ignored) == 0;
  if (!have_matplotlib) {
    VILMA_SKIP("python3 matplotlib not importable (Debian package python3-matplotlib)");
  }
  Files f;
  WriteInputs(f);
  const std::string png = f.dir + "/plot.png";
  std::remove(png.c_str());
  const Result r = Eval({"--gt", f.gt, "--est", f.est, "--plot", png});
  INFO(r.err);
  REQUIRE(r.code == kExitOk);
  const std::string bytes = Slurp(png);
  REQUIRE(bytes.size() > 1000);
  CHECK(bytes.substr(0, 8) == std::string("\x89PNG\r\n\x1a\n", 8));
}

TEST_CASE("an installed tree runs vilma eval --plot with its own copy of the plot script",
          "[eval]") {
  std::string out;
  if (Run("/usr/bin/python3 -c 'import matplotlib' 2>/dev/null", &out) != 0 &&
      Run("python3 -c 'import matplotlib' 2>/dev/null", &out) != 0) {
    VILMA_SKIP("python3 matplotlib not importable (Debian package python3-matplotlib)");
  }
  Files f;
  WriteInputs(f);
  const std::string prefix = f.dir + "/prefix";
  REQUIRE(Run("cmake --install '" + std::string(VILMA_BINARY_DIR) + "' --prefix '" + prefix +
                  "' 2>&1",
              &out) == 0);
  INFO(out);
  const std::string vilma = prefix + "/bin/vilma";
  const std::string script = prefix + "/share/vilma/scripts/plot_trajectory.py";
  REQUIRE(::access(vilma.c_str(), X_OK) == 0);
  REQUIRE(::access(script.c_str(), R_OK) == 0);
  const std::string png = f.dir + "/installed.png";
  const std::string command = "env -u VILMA_SCRIPTS_DIR '" + vilma + "' eval --gt " + f.gt +
                              " --est " + f.est + " --plot " + png + " 2>&1";
  CHECK(Run(command, &out) == 0);
  CHECK(Slurp(png).substr(0, 8) == std::string("\x89PNG\r\n\x1a\n", 8));
  // The installed program uses the installed script, not the source or build tree's: without
  // it, --plot fails naming the path it looked for.
  std::filesystem::remove(script);
  CHECK(Run(command, &out) == kExitInputError);
  CHECK_THAT(out, Catch::Contains(prefix + "/bin/../share/vilma/scripts/plot_trajectory.py"));
}

TEST_CASE("the vilma binary dispatches eval", "[eval]") {
  const std::string binary = std::string(VILMA_BINARY_DIR) + "/bin/vilma";
  if (::access(binary.c_str(), X_OK) != 0) {
    VILMA_SKIP("no binary at " << binary << " (build target vilma)");
  }
  std::string out;
  CHECK(Run(binary + " --help", &out) == 0);
  CHECK(out.find("eval") != std::string::npos);
  CHECK(Run(binary + " 2>&1", &out) == kExitUsage);
  CHECK(Run(binary + " frobnicate 2>&1", &out) == kExitUsage);
  CHECK(out.find("unknown subcommand 'frobnicate'") != std::string::npos);
  CHECK(Run(binary + " eval --bogus 2>&1", &out) == kExitUsage);
  CHECK(Run(binary + " eval --gt /nonexistent/gt.txt --est /nonexistent/est.txt 2>&1", &out) ==
        kExitInputError);
  CHECK(out.find("/nonexistent/gt.txt") != std::string::npos);

  Files f;
  WriteInputs(f);
  CHECK(Run(binary + " eval --gt " + f.gt + " --est " + f.est + " --align se3", &out) == 0);
  CHECK(out.find("ATE translation [m]") != std::string::npos);
}


TEST_CASE("eval warns when a static trajectory leaves the alignment's rotation free",
          "[eval]") {
  Files f;
  f.dir = TestDir();
  f.gt = f.dir + "/static_gt.txt";
  f.est = f.dir + "/static_est.txt";
  Trajectory gt, est;
  for (int i = 0; i < 100; ++i) {
    const int64_t t = 1403715273262142976 + int64_t{i} * 50000000;
    gt.Add(t, Transformation(Eigen::Quaterniond::Identity(), Eigen::Vector3d(1, 2, 0.001 * i)));
    est.Add(t, Transformation(Eigen::Quaterniond::Identity(), Eigen::Vector3d(0, 0, 0.001 * i)));
  }
  WriteTrajectoryFile(f.gt, gt, TrajectoryFormat::kTum);
  WriteTrajectoryFile(f.est, est, TrajectoryFormat::kTum);
  const Result aligned = Eval({"--gt", f.gt, "--est", f.est, "--align", "posyaw"});
  REQUIRE(aligned.code == kExitOk);
  CHECK_THAT(aligned.out, Catch::Contains("note:") && Catch::Contains("arbitrary yaw"));
  const Result unaligned = Eval({"--gt", f.gt, "--est", f.est, "--align", "none"});
  REQUIRE(unaligned.code == kExitOk);
  CHECK_THAT(unaligned.out, !Catch::Contains("note:"));
  // A long path (the figure-eight) gets no note.
  Files g;
  WriteInputs(g);
  CHECK_THAT(Eval({"--gt", g.gt, "--est", g.est}).out, !Catch::Contains("note:"));
}

}  // namespace vilma::console
