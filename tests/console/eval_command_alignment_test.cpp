// `vilma eval --within` (the share of poses within given distances) and `--align-from` (an
// alignment fitted on one trajectory, written as JSON, applied to another).
#include "eval_command_fixture.h"
#include "vilma/eval/alignment_json.h"
#include "test_skip.h"

#include <catch2/catch.hpp>

namespace vilma::console {

using namespace eval_test;  // NOLINT: the shared fixture of the eval command tests

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

namespace {

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

}  // namespace

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

}  // namespace vilma::console
