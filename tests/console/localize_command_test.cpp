#include "vilma/console/localize_command.h"

#include <unistd.h>

#include <algorithm>
#include <catch2/catch.hpp>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include "integration/process_util.h"
#include "vilma/console/locmap_command.h"
#include "vilma/core/asl_dataset.h"
#include "vilma/core/rig.h"
#include "vilma/localizer/feature_options.h"
#include "vilma/mapping/map_builder.h"
#include "vilma/mapstore/map_io.h"

namespace vilma::console {
namespace {

namespace fs = std::filesystem;

std::vector<std::string> SplitCsv(const std::string& line) {
  std::vector<std::string> cells;
  std::stringstream s(line);
  std::string cell;
  while (std::getline(s, cell, ',')) cells.push_back(cell);
  if (!line.empty() && line.back() == ',') cells.emplace_back();
  return cells;
}

std::vector<std::vector<std::string>> ReadCsv(const std::string& path) {
  std::ifstream in(path);
  std::vector<std::vector<std::string>> rows;
  std::string line;
  while (std::getline(in, line)) rows.push_back(SplitCsv(line));
  return rows;
}

// A simulated room: session 0 (8 s, the map) and session 1 (6 s, walking back along session
// 0's path: --revisit), made once per test process with the built vilma-sim, plus a VI-map of
// session 0 built by the map builder from the GROUND-TRUTH states (G = the simulator's world,
// so localization errors are errors against ground truth), saved as a map folder.
struct SimData {
  std::string dir, session0, session1, vimap;
};

const SimData& Sim() {
  static const SimData data = [] {
    SimData d;
    d.dir = (fs::temp_directory_path() / ("vilma_localize_" + std::to_string(::getpid()))).string();
    fs::remove_all(d.dir);
    fs::create_directories(d.dir);
    const std::string sim = std::string(VILMA_BINARY_DIR) + "/bin/vilma-sim";
    if (!fs::exists(sim)) throw std::runtime_error(sim + " missing: build the vilma-sim target");
    d.session0 = d.dir + "/room0";
    d.session1 = d.dir + "/room1";
    auto run = [&](const std::vector<std::string>& args, const std::string& name) {
      test::ChildProcess p(args, d.dir + "/" + name + ".out");
      if (p.Wait(120.0) != 0) {
        throw std::runtime_error(name +
                                 " failed: " + test::ReadTextFile(d.dir + "/" + name + ".out"));
      }
    };
    run({sim, "room", "--session", "0", "--seed", "3", "--seconds", "8", "--out", d.session0},
        "sim0");
    run({sim, "room", "--session", "1", "--revisit", "8", "--seed", "3", "--seconds", "6", "--out",
         d.session1},
        "sim1");

    const AslDataset ds = AslDataset::Open(d.session0);
    const SensorRig rig = LoadSensorRig(d.session0 + "/rig.yaml");
    mapping::MapBuilderOptions options;
    options.cameras = {0};
    mapping::MapBuilder builder(rig, options, 42, "room0-gt");
    const auto& imu = ds.imu();
    const auto& gt = ds.ground_truth();
    std::size_t next_imu = 0;
    for (const CameraFrame& frame : ds.cameras()[0].frames) {
      const int64_t t = frame.t_ns + rig.cameras[0].time_offset_ns;
      while (next_imu < imu.size() && imu[next_imu].t_ns <= t) builder.AddImu(imu[next_imu++]);
      if (next_imu < imu.size()) builder.AddImu(imu[next_imu++]);
      const auto it =
          std::lower_bound(gt.begin(), gt.end(), t,
                           [](const GroundTruthState& g, int64_t tt) { return g.t_ns < tt; });
      if (it == gt.end() || it->t_ns != t) continue;
      mapping::FrameState s;
      s.t_ns = t;
      s.T_M_I = Transformation(it->q_W_I, it->p_W_I);
      s.v_M = it->v_W;
      s.gyro_bias = it->b_g;
      s.accel_bias = it->b_a;
      if (!builder.WantsFrame(t)) {
        builder.AddFrame(s, {});
        continue;
      }
      std::vector<cv::Mat> images(rig.cameras.size());
      images[0] = AslDataset::LoadImage(frame.image_path);
      builder.AddFrame(s, images);
    }
    while (next_imu < imu.size()) builder.AddImu(imu[next_imu++]);
    builder.Finish();
    d.vimap = d.dir + "/room0-vimap";
    mapstore::SaveMap(builder.map(), d.vimap);
    static const std::string to_remove = d.dir;
    std::atexit([] {
      if (!std::getenv("VILMA_KEEP_TEST_DATA")) fs::remove_all(to_remove);
    });
    return d;
  }();
  return data;
}

int Run(const std::vector<std::string>& args, std::string* out_text, std::string* err_text) {
  std::ostringstream out, err;
  const int code = RunLocalizeCommand(args, out, err);
  if (out_text != nullptr) *out_text = out.str();
  if (err_text != nullptr) *err_text = err.str();
  return code;
}

TEST_CASE("vilma localize parses its command line") {
  const LocalizeCommandOptions d = ParseLocalizeArgs({"DATA", "MAP"});
  CHECK(d.dataset == "DATA");
  CHECK(d.map == "MAP");
  CHECK(d.every == 10);
  CHECK(d.camera == 0);
  CHECK(d.align == AlignmentType::kNone);
  CHECK(d.features_path.empty());
  const LocalizeCommandOptions o = ParseLocalizeArgs(
      {"DATA", "MAP", "--every", "3", "--camera=1", "--config", "c.yaml", "--features", "f.yaml",
       "--out", "r.csv", "--align", "posyaw", "--rig", "rig.yaml", "--quiet"});
  CHECK(o.every == 3);
  CHECK(o.camera == 1);
  CHECK(o.config_path == "c.yaml");
  CHECK(o.features_path == "f.yaml");
  CHECK(o.out_path == "r.csv");
  CHECK(o.rig_path == "rig.yaml");
  CHECK(o.align == AlignmentType::kPosYaw);
  CHECK(o.quiet);
  CHECK(ParseLocalizeArgs({"--help"}).help);
  CHECK_THROWS_WITH(ParseLocalizeArgs({"DATA"}), Catch::Contains("MAP"));
  CHECK_THROWS_WITH(ParseLocalizeArgs({}), Catch::Contains("DATASET"));
  CHECK_THROWS_WITH(ParseLocalizeArgs({"D", "M", "--every", "0"}), Catch::Contains("--every"));
  CHECK_THROWS_WITH(ParseLocalizeArgs({"D", "M", "--every", "2x"}), Catch::Contains("--every"));
  CHECK_THROWS_WITH(ParseLocalizeArgs({"D", "M", "--camera", "-1"}), Catch::Contains("--camera"));
  CHECK_THROWS_WITH(ParseLocalizeArgs({"D", "M", "--align", "sim3"}), Catch::Contains("--align"));
  CHECK_THROWS_WITH(ParseLocalizeArgs({"D", "M", "X"}), Catch::Contains("unexpected argument 'X'"));
  CHECK_THROWS_WITH(ParseLocalizeArgs({"D", "M", "--fast"}), Catch::Contains("unknown option"));
  CHECK_THROWS_WITH(ParseLocalizeArgs({"D", "M", "--quiet=no"}), Catch::Contains("--quiet: takes no value"));
  CHECK(ParseLocalizeArgs({"D", "M", "--every=5"}).every == 5);
  CHECK_THROWS_WITH(ParseLocalizeArgs({"D", "M", "--out"}), Catch::Contains("expected a value"));
}

TEST_CASE("vilma localize: the default query features are vilma-estimatord's profile") {
  // tests/daemon checks config/localization_features.yaml against the same function.
  CHECK(ParseLocalizeArgs({"D", "M"}).features_path.empty());
  const localizer::KeyframeFeatureOptions f = localizer::LocalizationQueryFeatureOptions();
  CHECK(f.detector.num_levels == 3);
  CHECK(f.descriptor.scale_with_level);
  CHECK(f.detector.max_keypoints == localizer::KeyframeFeatureOptions().detector.max_keypoints);
}

TEST_CASE("vilma localize: usage errors exit 2, bad inputs exit 1 naming the file") {
  std::string out, err;
  CHECK(Run({"--help"}, &out, &err) == kExitOk);
  CHECK_THAT(out, Catch::Contains("--align none|posyaw|se3"));
  CHECK(Run({"D", "M", "--every", "0"}, &out, &err) == kExitUsage);
  CHECK_THAT(err, Catch::Contains("--every"));
  CHECK(Run({"D"}, &out, &err) == kExitUsage);

  CHECK(Run({"/nonexistent/dataset", "/nonexistent/map"}, &out, &err) == kExitInputError);
  CHECK_THAT(err, Catch::Contains("/nonexistent/dataset"));
  CHECK(Run({"/nonexistent/dataset", "/nonexistent/map", "--features", "/nonexistent/f.yaml"}, &out,
            &err) == kExitInputError);
  CHECK_THAT(err, Catch::Contains("/nonexistent/f.yaml"));

  const SimData& d = Sim();
  CHECK(Run({d.session1, d.dir + "/no-such-map"}, &out, &err) == kExitInputError);
  CHECK_THAT(err, Catch::Contains(d.dir + "/no-such-map"));
  { std::ofstream(d.dir + "/corrupt.vlocmap") << "VLOCMAP1 but then nothing useful"; }
  CHECK(Run({d.session1, d.dir + "/corrupt.vlocmap"}, &out, &err) == kExitInputError);
  CHECK_THAT(err, Catch::Contains(d.dir + "/corrupt.vlocmap"));
  fs::create_directories(d.dir + "/not-a-map");
  CHECK(Run({d.session1, d.dir + "/not-a-map"}, &out, &err) == kExitInputError);
  CHECK_THAT(err, Catch::Contains(d.dir + "/not-a-map"));
  CHECK(Run({d.session1, d.vimap, "--camera", "3"}, &out, &err) == kExitInputError);
  CHECK_THAT(err, Catch::Contains("cam3"));
}

TEST_CASE("vilma localize: a revisiting session localizes in a ground-truth map of the room") {
  const SimData& d = Sim();
  std::string out, err;
  // The map as a .vlocmap (with its trained projection) ...
  {
    std::ostringstream o, e;
    REQUIRE(RunLocmapCommand({"build", d.vimap, d.dir + "/room0.vlocmap"}, o, e) == kExitOk);
  }
  const std::string csv_file = d.dir + "/file.csv";
  REQUIRE(Run({d.session1, d.dir + "/room0.vlocmap", "--every", "5", "--out", csv_file}, &out,
              &err) == kExitOk);
  INFO(out << err);
  CHECK_THAT(out, Catch::Contains("projection stored"));
  CHECK_THAT(out, Catch::Contains("recall     within 0.5 m"));
  const auto rows = ReadCsv(csv_file);
  const std::size_t frames = AslDataset::Open(d.session1).cameras()[0].frames.size();
  const std::size_t queries = (frames + 4) / 5;
  REQUIRE(rows.size() == queries + 1);  // header + one row per query
  const std::vector<std::string>& header = rows[0];
  const auto column = [&](const std::string& name) {
    const auto it = std::find(header.begin(), header.end(), name);
    REQUIRE(it != header.end());
    return static_cast<std::size_t>(it - header.begin());
  };
  const std::size_t c_status = column("status"), c_err = column("position_error_m"),
                    c_rot = column("rotation_error_deg"), c_gt = column("has_ground_truth"),
                    c_frame = column("frame");
  int within = 0;
  for (std::size_t i = 1; i < rows.size(); ++i) {
    REQUIRE(rows[i].size() == header.size());
    CHECK(rows[i][c_frame] == std::to_string((i - 1) * 5));
    CHECK(rows[i][c_gt] == "1");
    if (rows[i][c_status] != "ok") {
      CHECK(rows[i][c_err].empty());
      continue;
    }
    CHECK(std::stod(rows[i][c_rot]) >= 0.0);
    if (std::stod(rows[i][c_err]) <= 0.5) ++within;
  }
  const double recall = static_cast<double>(within) / static_cast<double>(queries);
  INFO("recall within 0.5 m: " << within << " / " << queries);
  CHECK(recall >= 0.8);

  // --align-from: a fixed alignment from a `vilma eval --json` file. The identity gives the same
  // recall line as --align none; 10 m off in x, nothing is within 0.5 m.
  const auto recall_line = [](const std::string& text) {
    const std::size_t at = text.find("recall     within 0.5 m");
    return at == std::string::npos ? std::string() : text.substr(at, text.find('\n', at) - at);
  };
  const std::string line_none = recall_line(out);
  REQUIRE_FALSE(line_none.empty());
  for (const double x : {0.0, 10.0}) {
    const std::string json = d.dir + "/alignment-" + std::to_string(static_cast<int>(x)) + ".json";
    std::ofstream(json) << "{\"schema_version\": 1, \"alignment_transform\": {\"scale\": 1, "
                           "\"translation_m\": ["
                        << x << ", 0, 0], \"quaternion_wxyz\": [1, 0, 0, 0]}}\n";
    REQUIRE(Run({d.session1, d.dir + "/room0.vlocmap", "--every", "5", "--align-from", json,
                 "--quiet"},
                &out, &err) == kExitOk);
    CHECK_THAT(out, Catch::Contains("alignment  fixed, from " + json));
    if (x == 0.0) {
      CHECK(recall_line(out) == line_none);
    } else {
      CHECK_THAT(recall_line(out), Catch::StartsWith("recall     within 0.5 m: 0 / "));
    }
  }
  CHECK(Run({d.session1, d.dir + "/room0.vlocmap", "--align", "posyaw", "--align-from", "a.json"},
            &out, &err) == kExitUsage);
  CHECK(Run({d.session1, d.dir + "/room0.vlocmap", "--align-from", d.dir + "/missing.json"}, &out,
            &err) == kExitInputError);
  CHECK_THAT(err, Catch::Contains(d.dir + "/missing.json"));

  // ... and the VI-map folder itself (summarized and trained at start): the same results,
  // deterministically (all columns but the timings).
  const std::string csv_folder = d.dir + "/folder.csv";
  REQUIRE(Run({d.session1, d.vimap, "--every", "5", "--out", csv_folder, "--quiet"}, &out, &err) ==
          kExitOk);
  CHECK_THAT(out, Catch::Contains("trained at load"));
  const auto rows2 = ReadCsv(csv_folder);
  REQUIRE(rows2.size() == rows.size());
  const std::size_t c_timing = column("features_ms");
  for (std::size_t i = 0; i < rows.size(); ++i) {
    const std::vector<std::string> a(rows[i].begin(), rows[i].begin() + c_timing);
    const std::vector<std::string> b(rows2[i].begin(), rows2[i].begin() + c_timing);
    CHECK(a == b);
  }
}

}  // namespace
}  // namespace vilma::console
