#include "vilma/console/vio_command.h"
#include "test_skip.h"
#include "vilma/core/asl_dataset.h"
#include "vilma/core/error.h"
#include "vilma/eval/evaluate.h"
#include "vilma/eval/trajectory.h"

#include <algorithm>
#include <catch2/catch.hpp>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <unistd.h>
#include <vector>

namespace vilma::console {
namespace {

TEST_CASE("vilma vio parses its command line") {
  const VioCommandOptions o =
      ParseVioArgs({"DATA", "--out", "t.txt", "--config=c.yaml", "--rig", "r.yaml", "--camera",
                    "1", "--log-timing", "timing.csv", "--log-state", "state.csv"});
  CHECK(o.dataset == "DATA");
  CHECK(o.out_path == "t.txt");
  CHECK(o.config_path == "c.yaml");
  CHECK(o.rig_path == "r.yaml");
  CHECK(o.camera == 1);
  CHECK(o.timing_path == "timing.csv");
  CHECK(o.state_path == "state.csv");
  CHECK(ParseVioArgs({"--help"}).help);
  CHECK_THROWS_WITH(ParseVioArgs({"DATA"}), Catch::Contains("--out"));
  CHECK_THROWS_WITH(ParseVioArgs({"--out", "t.txt"}), Catch::Contains("DATASET"));
  CHECK_THROWS_WITH(ParseVioArgs({"DATA", "--out", "t", "--camera", "x"}),
                    Catch::Contains("--camera"));
  CHECK_THROWS_WITH(ParseVioArgs({"DATA", "--out", "t", "--fast"}),
                    Catch::Contains("unknown option '--fast'"));
  CHECK_THROWS_WITH(ParseVioArgs({"DATA", "--out"}), Catch::Contains("expected a value"));
}

TEST_CASE("vilma vio --initial-state: parsed, and a file that does not cover the start fails") {
  CHECK(ParseVioArgs({"DATA", "--out", "t", "--initial-state", "gt.csv"}).initial_state_path ==
        "gt.csv");
  CHECK_THROWS_WITH(ParseVioArgs({"DATA", "--out", "t", "--initial-state"}),
                    Catch::Contains("expected a value"));
  const std::string micro = std::string(VILMA_SHARED_DATA_DIR) + "/euroc_V1_01_micro";
  if (!std::filesystem::exists(micro + "/mav0")) {
    VILMA_SKIP("EuRoC slice not found under " VILMA_SHARED_DATA_DIR);
  }
  // A TUM file far from the slice's time: exit 1 naming the file.
  const std::string gt = (std::filesystem::temp_directory_path() / "vilma_vio_given_far.txt").string();
  std::ofstream(gt) << "1.0 0 0 0 0 0 0 1\n2.0 0 0 0 0 0 0 1\n";
  std::ostringstream out, err;
  CHECK(RunVioCommand({micro, "--out", "/tmp/vilma_vio_given_far_out.txt", "--initial-state", gt},
                      out, err) == 1);
  CHECK_THAT(err.str(), Catch::Contains(gt) && Catch::Contains("covers"));
  // The slice's own ground truth: the filter starts from it at the first frame.
  std::ostringstream out2, err2;
  REQUIRE(RunVioCommand({micro, "--out", "/tmp/vilma_vio_given_out.txt", "--initial-state",
                         micro + "/mav0/state_groundtruth_estimate0/data.csv"},
                        out2, err2) == 0);
  CHECK_THAT(out2.str(), Catch::Contains("1 given") && Catch::Contains("velocity and biases from the file"));
  std::filesystem::remove(gt);
}

TEST_CASE("vilma vio parses --save-map and --map-config") {
  const VioCommandOptions o =
      ParseVioArgs({"DATA", "--out", "t.txt", "--save-map", "map", "--map-config=m.yaml"});
  CHECK(o.save_map_dir == "map");
  CHECK(o.map_config_path == "m.yaml");
  CHECK(ParseVioArgs({"DATA", "--out", "t.txt"}).save_map_dir.empty());
  CHECK_THROWS_WITH(ParseVioArgs({"DATA", "--out", "t", "--map-config", "m.yaml"}),
                    Catch::Contains("--map-config: only with --save-map"));
}

TEST_CASE("vilma vio exits 2 on usage errors and 1 on bad input") {
  std::ostringstream out, err;
  CHECK(RunVioCommand({"--bogus"}, out, err) == kExitUsage);
  CHECK(RunVioCommand({"/nonexistent/dataset", "--out", "/tmp/x.txt"}, out, err) ==
        kExitInputError);
  CHECK_THAT(err.str(), Catch::Contains("/nonexistent/dataset"));
}

TEST_CASE("vilma vio runs on the EuRoC static slice and is deterministic") {
  const std::string data = std::string(VILMA_SHARED_DATA_DIR) + "/euroc_V1_01_micro";
  if (!std::filesystem::exists(data + "/mav0")) {
    VILMA_SKIP(data << " is absent");
  }
  const std::filesystem::path tmp = std::filesystem::temp_directory_path();
  const std::string pid = std::to_string(::getpid());
  const std::string a = (tmp / ("vilma_vio_test_a_" + pid + ".txt")).string();
  const std::string b = (tmp / ("vilma_vio_test_b_" + pid + ".txt")).string();
  std::ostringstream out, err;
  REQUIRE(RunVioCommand({data, "--out", a}, out, err) == kExitOk);
  // --log-state does not change the estimate; it writes one row per pose.
  const std::string st = (tmp / ("vilma_vio_test_state_" + pid + ".csv")).string();
  REQUIRE(RunVioCommand({data, "--out", b, "--log-state", st}, out, err) == kExitOk);
  CHECK_THAT(out.str(), Catch::Contains("real-time factor"));
  std::ifstream fa(a), fb(b);
  std::stringstream sa, sb;
  sa << fa.rdbuf();
  sb << fb.rdbuf();
  CHECK(sa.str().size() > 1000);
  CHECK(sa.str() == sb.str());  // bit-identical output
  std::ifstream fs(st);
  std::string line;
  REQUIRE(std::getline(fs, line));
  CHECK(line.rfind("t_ns,vx,vy,vz,bgx,", 0) == 0);
  int rows = 0;
  while (std::getline(fs, line)) {
    ++rows;
    std::stringstream ls(line);
    std::vector<double> v;
    for (std::string c; std::getline(ls, c, ',');) v.push_back(std::stod(c));
    REQUIRE(v.size() == 17u);
    for (int i = 10; i < 17; ++i) CHECK(v[static_cast<std::size_t>(i)] > 0.0);  // sigmas
  }
  const std::string traj = sa.str();
  const long poses = std::count(traj.begin(), traj.end(), '\n') - 1;  // minus the header
  CHECK(rows == poses);
  std::filesystem::remove(a);
  std::filesystem::remove(b);
  std::filesystem::remove(st);
}

TEST_CASE("vilma vio --profile: parsed, the base of --config, an unknown profile is bad input") {
  CHECK(ParseVioArgs({"d", "--out", "t.txt"}).profile == "auto");
  CHECK(ParseVioArgs({"d", "--out", "t.txt", "--profile", "euroc"}).profile == "euroc");
  const VioCommandOptions both =
      ParseVioArgs({"d", "--out", "t.txt", "--profile", "euroc", "--config", "c.yaml"});
  CHECK(both.profile == "euroc");
  CHECK(both.config_path == "c.yaml");
  std::ostringstream out, err;
  const std::string data = std::string(VILMA_SHARED_DATA_DIR) + "/euroc_V1_01_micro";
  if (!std::filesystem::exists(data + "/mav0")) VILMA_SKIP(data << " is absent");
  const std::string traj = (std::filesystem::temp_directory_path() /
                            ("vilma_vio_profile_" + std::to_string(::getpid()) + ".txt"))
                               .string();
  CHECK(RunVioCommand({data, "--out", traj, "--profile", "kitti"}, out, err) == kExitInputError);
  CHECK_THAT(err.str(), Catch::Contains("kitti") && Catch::Contains("default, euroc"));
  std::filesystem::remove(traj);
}

// Issue 17: a user runs `vilma vio DATASET` on real EuRoC data without any option and gets the
// targets (roll/pitch <= 1 deg over the whole run, ATE posyaw <= 0.03 m): the dataset's EuRoC
// sensor.yaml rig selects the "euroc" profile by itself.
TEST_CASE("vilma vio picks the euroc profile for a EuRoC dataset and meets the moving-start targets") {
  const std::string data = std::string(VILMA_SHARED_DATA_DIR) + "/euroc_V1_01_moving";
  if (!std::filesystem::exists(data + "/mav0")) VILMA_SKIP(data << " is absent");
  const std::string traj = (std::filesystem::temp_directory_path() /
                            ("vilma_vio_auto_" + std::to_string(::getpid()) + ".txt"))
                               .string();
  for (const bool given : {false, true}) {
    std::vector<std::string> args{data, "--out", traj};
    if (given) {
      args.push_back("--initial-state");
      args.push_back(data + "/mav0/state_groundtruth_estimate0/data.csv");
    }
    std::ostringstream out, err;
    REQUIRE(RunVioCommand(args, out, err) == kExitOk);
    INFO(out.str() << err.str());
    CHECK_THAT(out.str(), Catch::Contains("options          built-in profile euroc (auto"));
    CHECK_THAT(out.str(), Catch::Contains(given ? "1 given" : "(1 by alignment"));
    const AslDataset dataset = AslDataset::Open(data);
    Trajectory truth;
    for (const GroundTruthState& g : dataset.ground_truth()) {
      truth.Add(g.t_ns, Transformation(g.q_W_I, g.p_W_I));
    }
    EvalOptions options;
    options.alignment = AlignmentType::kPosYaw;
    options.segment_lengths_m = {1.0};
    const EvalResult eval = EvaluateTrajectory(truth, ReadTrajectoryFile(traj), options);
    INFO((given ? "given" : "moving") << " start: ATE rmse " << eval.ate.translation_m.rmse
                                      << " m, roll/pitch max " << eval.ate.roll_pitch_deg.max);
    CHECK(eval.t_ns.size() > 60);  // of 90 frames
    CHECK(eval.ate.roll_pitch_deg.max <= 1.0);
    CHECK(eval.ate.translation_m.rmse <= 0.03);
  }
  std::filesystem::remove(traj);
  // A vilma rig (the simulator writes rig.yaml; here --rig) keeps the defaults.
  std::ostringstream out, err;
  REQUIRE(RunVioCommand({data, "--out", traj, "--rig",
                         std::string(VILMA_SOURCE_DIR) + "/config/euroc-rig.yaml", "--print-config"},
                        out, err) == kExitOk);
  CHECK_THAT(out.str(), Catch::Contains("# filter options: built-in profile default (auto: vilma rig)"));
  CHECK_THAT(out.str(), Catch::Contains("  bearing: 0.001"));
  std::filesystem::remove(traj);
  // A partial --config changes only its keys; the rest is the auto-picked euroc profile's
  // (40 feature slots), not the simulator defaults' (25).
  const std::filesystem::path partial = std::filesystem::temp_directory_path() /
                                        ("vilma_vio_partial_" + std::to_string(::getpid()) + ".yaml");
  std::ofstream(partial) << "features:\n  detect_below: 21\n";
  std::ostringstream out2, err2;
  REQUIRE(RunVioCommand({data, "--out", traj, "--config", partial.string(), "--print-config"},
                        out2, err2) == kExitOk);
  CHECK_THAT(out2.str(), Catch::Contains(" over the built-in profile euroc (auto: rig from EuRoC"));
  CHECK_THAT(out2.str(), Catch::Contains("  max_features: 40"));
  CHECK_THAT(out2.str(), Catch::Contains("  detect_below: 21"));
  std::filesystem::remove(partial);
  std::filesystem::remove(traj);
}


// The opt-in options of issue 17 (session 36) report their counters: a user who turns on the
// template refresh or the stereo probation sees what they did.
TEST_CASE("vilma vio reports the patch refresh and the stereo probation when they are on") {
  const std::string data = std::string(VILMA_SHARED_DATA_DIR) + "/euroc_V1_01_micro";
  if (!std::filesystem::exists(data + "/mav0/cam1")) VILMA_SKIP(data << " (stereo) is absent");
  std::ifstream in(std::string(VILMA_SOURCE_DIR) + "/config/estimator_euroc.yaml");
  std::stringstream yaml;
  yaml << in.rdbuf();
  std::string text = yaml.str();
  const auto set = [&text](const std::string& key, const std::string& value) {
    const std::size_t at = text.find(key + ": 0 ");
    REQUIRE(at != std::string::npos);
    text.replace(at, key.size() + 3, key + ": " + value + " ");
  };
  set("refresh_patch_every", "5");
  set("probation_frames", "3");
  const std::filesystem::path tmp = std::filesystem::temp_directory_path();
  const std::string pid = std::to_string(::getpid());
  const std::string config = (tmp / ("vilma_vio_refresh_" + pid + ".yaml")).string();
  const std::string traj = (tmp / ("vilma_vio_refresh_" + pid + ".txt")).string();
  std::ofstream(config) << text;
  std::ostringstream out, err;
  REQUIRE(RunVioCommand({data, "--out", traj, "--config", config, "--stereo"}, out, err) ==
          kExitOk);
  INFO(out.str() << err.str());
  CHECK_THAT(out.str(), Catch::Contains("templates re-extracted") &&
                            Catch::Contains("stereo depths confirmed"));
  CHECK_THAT(out.str(), !Catch::Contains("patch refresh    0 templates"));
  // Off (the default): no such lines.
  std::ostringstream plain;
  REQUIRE(RunVioCommand({data, "--out", traj, "--stereo"}, plain, err) == kExitOk);
  CHECK_THAT(plain.str(), !Catch::Contains("patch refresh") && !Catch::Contains("probation"));
  std::filesystem::remove(config);
  std::filesystem::remove(traj);
}

}  // namespace
}  // namespace vilma::console
