#include "vilma/console/eval_command.h"
#include "vilma/eval/alignment_json.h"
#include "test_skip.h"

#include <catch2/catch.hpp>

#include <sys/stat.h>
#include <sys/wait.h>
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

namespace vilma::console {
namespace {

constexpr double kPi = 3.14159265358979323846;

// Generated files live outside the repository ($VILMA_TEST_TMPDIR or /tmp); per-process folder so
// that parallel ctest runs do not collide.
std::string TestDir() {
  const char* base = std::getenv("VILMA_TEST_TMPDIR");
  std::string dir = base != nullptr ? base : "/tmp";
  dir += "/vilma_eval_command_test_" + std::to_string(::getpid());
  ::mkdir(dir.c_str(), 0755);
  return dir;
}

// Ground truth: a horizontal figure-eight, 60 s at 20 Hz with heading along the path, ~70 m.
Trajectory MakeGroundTruth() {
  Trajectory t;
  for (int i = 0; i < 1200; ++i) {
    const double s = 0.05 * i;
    const double w = 2.0 * kPi / 30.0;
    const Eigen::Vector3d p(6.0 * std::sin(w * s), 3.0 * std::sin(2.0 * w * s), 1.5);
    const Eigen::Vector3d v(6.0 * w * std::cos(w * s), 6.0 * w * std::cos(2.0 * w * s), 0.0);
    const Eigen::Quaterniond q(Eigen::AngleAxisd(std::atan2(v.y(), v.x()),
                                                 Eigen::Vector3d::UnitZ()));
    t.Add(1403715273262142976 + int64_t{i} * 50000000, Transformation(q, p));
  }
  return t;
}

// Estimate: the gt in a world rotated by 30 deg yaw and shifted, a deterministic 5 cm wobble in
// x, stamps 1 ms late (within --max-dt).
Trajectory MakeEstimate(const Trajectory& gt) {
  Trajectory est;
  const Transformation T_E_G(
      Eigen::Quaterniond(Eigen::AngleAxisd(kPi / 6.0, Eigen::Vector3d::UnitZ())),
      Eigen::Vector3d(10.0, -3.0, 0.5));
  for (std::size_t i = 0; i < gt.size(); ++i) {
    Transformation T = gt.T_W_B[i];
    // +-5 cm alternating along gt x: mean zero, so no alignment can remove it.
    const double wobble = (i % 2 == 0 ? 0.05 : -0.05);
    T = Transformation(T.rotation(), T.translation() + Eigen::Vector3d(wobble, 0.0, 0.0));
    est.Add(gt.t_ns[i] + 1000000, T_E_G * T);
  }
  return est;
}

// Removes its folder when done, so repeated runs leave nothing behind.
struct Files {
  std::string dir, gt, est;
  Files() = default;
  Files(const Files&) = delete;
  Files& operator=(const Files&) = delete;
  ~Files() {
    std::error_code ignored;
    if (!dir.empty()) std::filesystem::remove_all(dir, ignored);
  }
};

void WriteInputs(Files& f) {
  f.dir = TestDir();
  f.gt = f.dir + "/gt.csv";
  f.est = f.dir + "/est.txt";
  const Trajectory gt = MakeGroundTruth();
  WriteTrajectoryFile(f.gt, gt, TrajectoryFormat::kEuroc);
  WriteTrajectoryFile(f.est, MakeEstimate(gt), TrajectoryFormat::kTum);
}

std::string Slurp(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::ostringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// Output and exit status of a shell command.
int Run(const std::string& command, std::string* output) {
  FILE* pipe = ::popen(command.c_str(), "r");
  if (pipe == nullptr) return -1;
  char buf[4096];
  std::size_t n = 0;
  output->clear();
  while ((n = std::fread(buf, 1, sizeof(buf), pipe)) > 0) output->append(buf, n);
  const int status = ::pclose(pipe);
  return WIFEXITED(status) ? WEXITSTATUS(status) : -1;
}

struct Result {
  int code;
  std::string out, err;
};

Result Eval(const std::vector<std::string>& args) {
  std::ostringstream out, err;
  const int code = RunEvalCommand(args, out, err);
  return {code, out.str(), err.str()};
}

}  // namespace

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

}  // namespace vilma::console

namespace vilma::console {
namespace {

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

}  // namespace
}  // namespace vilma::console

namespace vilma::console {
namespace {

TEST_CASE("eval --within: bad arguments are usage errors naming the option", "[eval]") {
  struct Case {
    std::vector<std::string> within;
    std::string message;
  };
  const std::vector<Case> cases = {
      {{"--within", "-0.5"}, "--within: expected distances >= 0 [m], got -0.5"},
      {{"--within", "0.5,-1"}, "--within: expected distances >= 0 [m], got -1"},
      {{"--within", ""}, "--within: expected a non-empty value"},
      {{"--within="}, "--within: expected a non-empty value"},
      {{"--within"}, "--within: expected a value"},
      {{"--within", "abc"}, "--within: expected a number, got 'abc'"},
      {{"--within", "0.5m"}, "--within: expected a number, got '0.5m'"},
      {{"--within", "nan"}, "--within: expected a number, got 'nan'"},
      {{"--within", "0.5,"}, "--within: expected comma-separated distances [m], got '0.5,'"},
      {{"--within", ",0.5"}, "--within: expected comma-separated distances [m], got ',0.5'"},
      {{"--within", "0.5,,1"}, "--within: expected comma-separated distances [m], got '0.5,,1'"},
  };
  for (const Case& c : cases) {
    std::vector<std::string> args = {"--gt", "a.txt", "--est", "b.txt"};
    args.insert(args.end(), c.within.begin(), c.within.end());
    INFO(c.message);
    CHECK_THROWS_WITH(ParseEvalArgs(args), c.message);
    const Result r = Eval(args);
    CHECK(r.code == kExitUsage);
    CHECK(r.err == "vilma eval: " + c.message + "\n(see 'vilma eval --help')\n");
    CHECK(r.out.empty());
  }
  const Result help = Eval({"--help"});
  CHECK_THAT(help.out, Catch::Contains("--within D1,D2,...") && Catch::Contains("first:"));
}

// 30 poses along a line; the estimate is in a world yawed by 30 deg and shifted, with a known
// position offset (in G) per pose: 0 for the first, 0.6 m for poses 7 and 20, 0.1 * (k % 4)
// otherwise. So after --align first the errors are those offsets.
void WriteKnownErrors(Files& f) {
  f.dir = TestDir();
  f.gt = f.dir + "/known_gt.txt";
  f.est = f.dir + "/known_est.txt";
  const Transformation T_E_G(
      Eigen::Quaterniond(Eigen::AngleAxisd(kPi / 6.0, Eigen::Vector3d::UnitZ())),
      Eigen::Vector3d(10.0, -3.0, 0.5));
  Trajectory gt, est;
  for (int k = 0; k < 30; ++k) {
    const int64_t t = 1403715273262142976 + int64_t{k} * 100000000;
    const Transformation T_G_B(
        Eigen::Quaterniond(Eigen::AngleAxisd(0.05 * k, Eigen::Vector3d::UnitZ())),
        Eigen::Vector3d(0.5 * k, 0.1 * k, 1.0));
    const double offset = (k == 7 || k == 20) ? 0.6 : 0.1 * (k % 4);
    gt.Add(t, T_G_B);
    est.Add(t, T_E_G * Transformation(T_G_B.rotation(),
                                      T_G_B.translation() + Eigen::Vector3d(0.0, offset, 0.0)));
  }
  WriteTrajectoryFile(f.gt, gt, TrajectoryFormat::kTum);
  WriteTrajectoryFile(f.est, est, TrajectoryFormat::kTum);
}

TEST_CASE("eval --align first --within: report and JSON", "[eval]") {
  Files f;
  WriteKnownErrors(f);
  const std::string json = f.dir + "/first.json";
  const Result r = Eval({"--gt", f.gt, "--est", f.est, "--align", "first", "--within",
                         "0.5,0.35,1", "--segments", "1", "--json", json});
  INFO(r.err);
  REQUIRE(r.code == kExitOk);
  CHECK_THAT(r.out, Catch::Contains("alignment:     first  rotation vector [deg] (0.000, 0.000, "
                                    "-30.000)  translation [m]"));
  // Offsets 0.1 * (k % 4) <= 0.3 for 28 poses, 0.6 for 2.
  CHECK_THAT(r.out, Catch::Contains("within 0.50 m: 28 / 30 poses (93.3 %)\n"
                                    "within 0.35 m: 28 / 30 poses (93.3 %)\n"
                                    "within 1.00 m: 30 / 30 poses (100.0 %)\n"));
  CHECK_THAT(r.out, !Catch::Contains("note:"));
  CHECK_THAT(r.out, Catch::Contains("ATE translation [m]:") &&
                        Catch::Contains("max 0.6000"));

  std::string parsed;
  const std::string script =
      "import json,sys; d=json.load(open(sys.argv[1])); t=d['alignment_transform']; "
      "print(d['alignment'], d['matched_poses'], '%.6f %.6f' % (t['quaternion_wxyz'][0], "
      "t['quaternion_wxyz'][3]), ' '.join('%.3f' % x for x in t['translation_m']), "
      "[(w['distance_m'], w['poses'], w['matched_poses'], round(w['fraction'], 4)) "
      "for w in d['within']])";
  const int code = Run("python3 -c \"" + script + "\" " + json + " 2>&1", &parsed);
  if (code != 0 && parsed.find("not found") != std::string::npos) {
    VILMA_SKIP_NOTE("python3 not available, JSON checked by text only");
    CHECK_THAT(Slurp(json), Catch::Contains("\"alignment\": \"first\""));
  } else {
    INFO(Slurp(json));
    CHECK(code == 0);
    // T_G_E = T_E_G^-1: yaw -30 deg, p_G_E = -Rz(-30 deg) (10, -3, 0.5).
    const double c = std::cos(kPi / 6.0), s = std::sin(kPi / 6.0);
    char expected[256];
    std::snprintf(expected, sizeof(expected),
                  "first 30 %.6f %.6f %.3f %.3f %.3f [(0.5, 28, 30, 0.9333), (0.35, 28, 30, "
                  "0.9333), (1, 30, 30, 1)]\n",
                  std::cos(kPi / 12.0), -std::sin(kPi / 12.0), -(c * 10.0 + s * -3.0),
                  -(-s * 10.0 + c * -3.0), -0.5);
    CHECK(parsed == expected);
  }

  // Without --within the JSON has an empty list and the report no within line.
  const Result plain = Eval({"--gt", f.gt, "--est", f.est, "--json", json});
  REQUIRE(plain.code == kExitOk);
  CHECK_THAT(plain.out, !Catch::Contains("within"));
  CHECK_THAT(Slurp(json), Catch::Contains("\"within\": []"));
}

TEST_CASE("eval --within: a pose exactly at D counts as within", "[eval]") {
  // Errors 0, 0.25, 0.5, 0.75, 1.0 (exact in binary and in the files' 9 decimals), 6 times.
  Files f;
  f.dir = TestDir();
  f.gt = f.dir + "/boundary_gt.txt";
  f.est = f.dir + "/boundary_est.txt";
  Trajectory gt, est;
  for (int k = 0; k < 30; ++k) {
    const int64_t t = 1403715273262142976 + int64_t{k} * 100000000;
    gt.Add(t, Transformation(Eigen::Quaterniond::Identity(), Eigen::Vector3d(k, 0.0, 0.0)));
    est.Add(t, Transformation(Eigen::Quaterniond::Identity(),
                              Eigen::Vector3d(k, 0.25 * (k % 5), 0.0)));
  }
  WriteTrajectoryFile(f.gt, gt, TrajectoryFormat::kTum);
  WriteTrajectoryFile(f.est, est, TrajectoryFormat::kTum);
  const Result r = Eval({"--gt", f.gt, "--est", f.est, "--align", "none", "--within",
                         "0.5,0.125,0"});
  INFO(r.err);
  REQUIRE(r.code == kExitOk);
  CHECK_THAT(r.out, Catch::Contains("within 0.50 m: 18 / 30 poses (60.0 %)\n"
                                    "within 0.125 m: 6 / 30 poses (20.0 %)\n"
                                    "within 0.00 m: 6 / 30 poses (20.0 %)\n"));
}

TEST_CASE("eval --align-from: parsing", "[eval]") {
  const EvalCommandOptions o =
      ParseEvalArgs({"--gt", "a", "--est", "b", "--align-from", "map.json"});
  CHECK(o.eval.alignment == AlignmentType::kFixed);
  CHECK(o.align_from_path == "map.json");
  CHECK(ParseEvalArgs({"--gt", "a", "--est", "b"}).align_from_path.empty());
  CHECK_THROWS_WITH(
      ParseEvalArgs({"--gt", "a", "--est", "b", "--align", "first", "--align-from", "m.json"}),
      "--align and --align-from exclude each other (--align-from applies the file's transform, "
      "nothing is fitted)");
  CHECK_THROWS_WITH(ParseEvalArgs({"--gt", "a", "--est", "b", "--align", "fixed"}),
                    "--align fixed: give the transform with --align-from FILE.json");
  CHECK_THROWS_WITH(ParseEvalArgs({"--gt", "a", "--est", "b", "--align-from"}),
                    "--align-from: expected a value");
  const Result usage = Eval({"--gt", "a", "--est", "b", "--align-from=m.json", "--align=se3"});
  CHECK(usage.code == kExitUsage);
}

// Multi-session evaluation in a map frame: the map session's estimate lives in E (its VIO
// frame = the map frame), aligned at its start it gives S_G_E; a second session localized in E
// is evaluated with that same S_G_E, nothing fitted to it.
TEST_CASE("eval --align-from: round trip through --json", "[eval]") {
  Files f;
  f.dir = TestDir();
  f.gt = f.dir + "/rt_gt.csv";
  const std::string map_est = f.dir + "/rt_map.txt";
  const std::string query_est = f.dir + "/rt_query.txt";
  const std::string map_json = f.dir + "/rt_map.json";
  const std::string query_json = f.dir + "/rt_query.json";
  const Trajectory gt = MakeGroundTruth();
  WriteTrajectoryFile(f.gt, gt, TrajectoryFormat::kEuroc);
  // T_E_G: yaw 30 deg plus a small roll (a fixed transform keeps it; first would not), shift.
  const Transformation T_E_G(
      Eigen::Quaterniond(Eigen::AngleAxisd(kPi / 6.0, Eigen::Vector3d::UnitZ())),
      Eigen::Vector3d(10.0, -3.0, 0.5));
  // Map session: exact, every pose. Query session: the second half of the run, in the same E,
  // with a constant error d in G (a map whose frame is off by d): every pose off by |d| = 0.5 m.
  const Eigen::Vector3d d(0.3, -0.4, 0.0);
  Trajectory map, query;
  for (std::size_t i = 0; i < gt.size(); ++i) {
    map.Add(gt.t_ns[i], T_E_G * gt.T_W_B[i]);
    if (i >= gt.size() / 2) {
      const Transformation T_off(gt.T_W_B[i].rotation(), gt.T_W_B[i].translation() + d);
      query.Add(gt.t_ns[i], T_E_G * T_off);
    }
  }
  WriteTrajectoryFile(map_est, map, TrajectoryFormat::kTum);
  WriteTrajectoryFile(query_est, query, TrajectoryFormat::kTum);

  const Result m = Eval({"--gt", f.gt, "--est", map_est, "--align", "first", "--json", map_json});
  INFO(m.err);
  REQUIRE(m.code == kExitOk);
  const Alignment read = ReadAlignmentJson(map_json);
  CHECK(read.type == AlignmentType::kFixed);
  CHECK(read.scale == 1.0);
  // Up to the files' precision: TUM's 9 decimals of the first pose's quaternion (a few 1e-9
  // rad, times the 10 m lever of the translation) and the JSON's 10 significant digits.
  CHECK(AngleBetween(read.T_G_E.rotation(), T_E_G.inverse().rotation()) < 1e-8);
  CHECK((read.T_G_E.translation() - T_E_G.inverse().translation()).norm() < 1e-7);

  const Result q = Eval({"--gt", f.gt, "--est", query_est, "--align-from", map_json, "--within",
                         "0.49,0.51", "--segments", "5", "--json", query_json});
  INFO(q.err);
  REQUIRE(q.code == kExitOk);
  CHECK_THAT(q.out, Catch::Contains("alignment:     fixed (from " + map_json +
                                    ")  rotation vector [deg] (0.000, 0.000, -30.000)"));
  CHECK_THAT(q.out, Catch::Contains("ATE translation [m]:  rmse 0.5000  mean 0.5000  median "
                                    "0.5000  max 0.5000"));
  CHECK_THAT(q.out, Catch::Contains("within 0.49 m: 0 / 600 poses (0.0 %)\n"
                                    "within 0.51 m: 600 / 600 poses (100.0 %)\n"));
  CHECK_THAT(q.out, !Catch::Contains("scale"));
  // Fitting to the query instead would hide the map's error: posyaw removes the offset, first
  // too (it puts the query's own first pose onto the ground truth).
  for (const char* fitted : {"posyaw", "first"}) {
    const Result r = Eval({"--gt", f.gt, "--est", query_est, "--align", fitted});
    REQUIRE(r.code == kExitOk);
    CHECK_THAT(r.out, Catch::Contains("ATE translation [m]:  rmse 0.0000"));
  }
  // The query's JSON says where its transform came from and carries it on unchanged, so it can
  // be chained.
  const Alignment again = ReadAlignmentJson(query_json);
  CHECK(AngleBetween(again.T_G_E.rotation(), read.T_G_E.rotation()) < 1e-9);
  CHECK((again.T_G_E.translation() - read.T_G_E.translation()).norm() < 1e-8);
  const std::string text = Slurp(query_json);
  CHECK_THAT(text, Catch::Contains("\"alignment\": \"fixed\",\n"));
  CHECK_THAT(text, Catch::Contains("\"alignment_from\": \"" + map_json + "\",\n"));
  CHECK_THAT(Slurp(map_json), Catch::Contains("\"alignment_from\": null,\n"));
  std::string parsed;
  const int code =
      Run("python3 -c \"import json,sys; d=json.load(open(sys.argv[1])); "
          "print(d['alignment'], d['alignment_from'] == sys.argv[2], "
          "'%.4f' % d['ate']['translation_rmse_m'])\" " +
              query_json + " " + map_json + " 2>&1",
          &parsed);
  if (code != 0 && parsed.find("not found") != std::string::npos) {
    VILMA_SKIP_NOTE("python3 not available, JSON checked by text only");
  } else {
    CHECK(code == 0);
    CHECK(parsed == "fixed True 0.5000\n");
  }

  // A sim3 transform's scale is applied: the map session in E scaled by 1/2 and its sim3 fit.
  Trajectory half;
  for (std::size_t i = 0; i < map.size(); ++i) {
    half.Add(map.t_ns[i],
             Transformation(map.T_W_B[i].rotation(), 0.5 * map.T_W_B[i].translation()));
  }
  const std::string half_est = f.dir + "/rt_half.txt";
  const std::string half_json = f.dir + "/rt_half.json";
  WriteTrajectoryFile(half_est, half, TrajectoryFormat::kTum);
  REQUIRE(Eval({"--gt", f.gt, "--est", half_est, "--align", "sim3", "--json", half_json}).code ==
          kExitOk);
  const Result scaled = Eval({"--gt", f.gt, "--est", half_est, "--align-from", half_json});
  REQUIRE(scaled.code == kExitOk);
  CHECK_THAT(scaled.out, Catch::Contains("scale 2.000000"));
  CHECK_THAT(scaled.out, Catch::Contains("ATE translation [m]:  rmse 0.0000"));
}

TEST_CASE("eval --align-from: malformed files name the file, the field and the expectation",
          "[eval]") {
  const std::string f = "map.json";
  const std::string good_t = R"("alignment_transform": {"scale": 1, "translation_m": [1, 2, 3], )"
                             R"("quaternion_wxyz": [1, 0, 0, 0]})";
  // A good document, minimal and with the other keys --json writes (ignored).
  const Alignment a = ParseAlignmentJson("{\"schema_version\": 1, " + good_t + "}", f);
  CHECK(a.type == AlignmentType::kFixed);
  CHECK(a.T_G_E.translation() == Eigen::Vector3d(1, 2, 3));
  const Alignment b = ParseAlignmentJson(
      "\n{\"schema_version\": 1, \"estimate\": {\"path\": \"a\\\"b\\u00e9\\ud83d\\ude00\"}, "
      "\"rpe\": [], \"x\": [true, false, null, -0.5e-3],\r\n\t" +
          good_t + "}\n",
      f);
  CHECK(b.T_G_E.translation() == Eigen::Vector3d(1, 2, 3));
  // A quaternion as --json writes it (10 digits) is normalized.
  const Alignment c = ParseAlignmentJson(
      R"({"schema_version": 1, "alignment_transform": {"scale": 1, "translation_m": [0, 0, 0],)"
      R"( "quaternion_wxyz": [0.9659258263, 0, 0, 0.2588190451]}})",
      f);
  CHECK(c.T_G_E.rotation().norm() == Approx(1.0).epsilon(1e-15));
  CHECK(AngleBetween(c.T_G_E.rotation(), Eigen::Quaterniond(Eigen::AngleAxisd(
                                             kPi / 6.0, Eigen::Vector3d::UnitZ()))) < 1e-9);

  const std::string v1 = "{\"schema_version\": 1, ";
  // {"alignment_transform": {MEMBERS}} after v1.
  const auto with_t = [&](const std::string& members) {
    return v1 + "\"alignment_transform\": {" + members + "}}";
  };
  const std::vector<std::pair<std::string, std::string>> cases = {
      {"",
       "map.json: expected valid JSON: syntax error while parsing value - unexpected end of "
       "input; expected '[', '{', or a literal at line 1, column 1"},
      {"[]", "map.json: expected a JSON object (the file of `vilma eval --json`), got an array"},
      {"{\"schema_version\": 1,}",
       "map.json: expected valid JSON: syntax error while parsing object key - unexpected "
       "'}'; expected string literal at line 1, column 22"},
      {v1 + good_t + "} x",
       "map.json: expected valid JSON: syntax error while parsing value - invalid literal; "
       "last read: '0]}} x'; expected end of input at line 1, column 121"},
      {v1 + "\"a\": NaN, " + good_t + "}",
       "map.json: expected valid JSON: syntax error while parsing value - invalid literal; "
       "last read: '\"a\": N' at line 1, column 28"},
      {v1 + "\"a\": 01, " + good_t + "}",
       "map.json: expected valid JSON: syntax error while parsing object - unexpected number "
       "literal; expected '}' at line 1, column 29"},
      {v1 + "\"a\": 1e999, " + good_t + "}",
       "map.json: expected valid JSON: a number in the range of a double at line 1, column 28"},
      {v1 + "\"a\": \"x\ny\", " + good_t + "}",
       "map.json: expected valid JSON: syntax error while parsing value - invalid string: "
       "control character U+000A (LF) must be escaped to \\u000A or \\n; last read: "
       "'\"x<U+000A>' at line 1, column 30"},
      {v1 + "\"schema_version\": 1, " + good_t + "}",
       "map.json: expected valid JSON: no duplicate key \"schema_version\" at line 1, column 39"},
      {v1 + good_t,
       "map.json: expected valid JSON: syntax error while parsing object - unexpected end of "
       "input; expected '}' at line 1, column 119"},
      {"{" + good_t + "}",
       "map.json: schema_version: expected 1 (a `vilma eval --json` file), missing"},
      {"{\"schema_version\": 2, " + good_t + "}",
       "map.json: schema_version: expected 1 (a `vilma eval --json` file), got 2"},
      {"{\"schema_version\": \"1\", " + good_t + "}",
       "map.json: schema_version: expected 1 (a `vilma eval --json` file), got a string"},
      {"{\"schema_version\": 1}",
       "map.json: alignment_transform: expected an object {scale, translation_m, "
       "quaternion_wxyz}, missing"},
      {v1 + R"("alignment_transform": [1, 2]})",
       "map.json: alignment_transform: expected an object {scale, translation_m, "
       "quaternion_wxyz}, got an array"},
      {with_t(R"("translation_m": [0, 0, 0], "quaternion_wxyz": [1, 0, 0, 0])"),
       "map.json: alignment_transform.scale: expected a number > 0, missing"},
      {with_t(R"("scale": 0, "translation_m": [0, 0, 0], "quaternion_wxyz": [1, 0, 0, 0])"),
       "map.json: alignment_transform.scale: expected a number > 0, got 0"},
      {with_t(R"("scale": 1, "translation_m": [0, 0], "quaternion_wxyz": [1, 0, 0, 0])"),
       "map.json: alignment_transform.translation_m: expected an array of 3 numbers, got 2 "
       "elements"},
      {with_t(R"("scale": 1, "translation_m": [0, "1", 0], "quaternion_wxyz": [1, 0, 0, 0])"),
       "map.json: alignment_transform.translation_m[1]: expected a number, got a string"},
      {with_t(R"("scale": 1, "translation_m": [0, 0, 0], "quaternion_wxyz": [1, 0, 0, null])"),
       "map.json: alignment_transform.quaternion_wxyz[3]: expected a number, got null"},
      {with_t(R"("scale": 1, "translation_m": [0, 0, 0], "quaternion_wxyz": [2, 0, 0, 0])"),
       "map.json: alignment_transform.quaternion_wxyz: expected a unit quaternion (w, x, y, z), "
       "got norm 2"},
      {with_t(R"("scale": 1, "translation_m": [0, 0, 0])"),
       "map.json: alignment_transform.quaternion_wxyz: expected an array of 4 numbers, missing"},
  };
  for (const auto& [text, message] : cases) {
    INFO(text);
    CHECK_THROWS_WITH(ParseAlignmentJson(text, f), message);
  }

  // Through the command: exit 1, the message names the file; nothing is evaluated.
  Files files;
  WriteInputs(files);
  const std::string bad = files.dir + "/bad_map.json";
  std::ofstream(bad) << "{\"schema_version\": 1}\n";
  const Result r = Eval({"--gt", files.gt, "--est", files.est, "--align-from", bad});
  CHECK(r.code == kExitInputError);
  CHECK(r.err == "vilma eval: error: " + bad +
                     ": alignment_transform: expected an object {scale, translation_m, "
                     "quaternion_wxyz}, missing\n");
  CHECK(r.out.empty());
  const Result missing =
      Eval({"--gt", files.gt, "--est", files.est, "--align-from", files.dir + "/nope.json"});
  CHECK(missing.code == kExitInputError);
  CHECK(missing.err == "vilma eval: error: " + files.dir +
                           "/nope.json: expected a readable "
                           "JSON file\n");
}

}  // namespace
}  // namespace vilma::console
