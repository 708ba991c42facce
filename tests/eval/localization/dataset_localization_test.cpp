// eval/localization: `vilma localize`'s query loop (dataset_localization) and the ground-truth
// localization map of a simulated dataset (ground_truth_map, vilma-locmap-gt).
#include "vilma/eval/localization/dataset_localization.h"

#include <unistd.h>

#include <algorithm>
#include <catch2/catch.hpp>
#include <cstdlib>
#include <filesystem>
#include <memory>
#include <numeric>

#include "integration/process_util.h"
#include "test_skip.h"
#include "vilma/core/error.h"
#include "vilma/eval/localization/ground_truth_map.h"
#include "vilma/localizer/feature_options.h"

namespace vilma::eval {
namespace {

namespace fs = std::filesystem;

GroundTruthState Sample(int64_t t_ns, double x, double yaw_rad) {
  GroundTruthState g;
  g.t_ns = t_ns;
  g.p_W_I = Eigen::Vector3d(x, 0.0, 1.0);
  g.q_W_I = Eigen::Quaterniond(Eigen::AngleAxisd(yaw_rad, Eigen::Vector3d::UnitZ()));
  return g;
}

// An 8-s session of the simulated room (seed 3; the map builder's landmarks need ~5 s of motion), rendered once per test process by the built
// vilma-sim; "" when the program is not built.
std::string SimulatedRoom() {
  static const std::string dir = []() -> std::string {
    const std::string sim = std::string(VILMA_BINARY_DIR) + "/bin/vilma-sim";
    if (!fs::exists(sim)) return "";
    const std::string d =
        (fs::temp_directory_path() / ("vilma_dataset_localization_" + std::to_string(::getpid())))
            .string();
    fs::remove_all(d);
    fs::create_directories(d);
    test::ChildProcess p({sim, "room", "--seed", "3", "--seconds", "8", "--out", d + "/room"},
                         d + "/sim.out");
    if (p.Wait(120.0) != 0) throw std::runtime_error(test::ReadTextFile(d + "/sim.out"));
    static const std::string to_remove = d;
    std::atexit([] { fs::remove_all(to_remove); });
    return d + "/room";
  }();
  return dir;
}

}  // namespace

TEST_CASE("GroundTruthAt: exact samples, interpolation within 51 ms, none across gaps") {
  const std::vector<GroundTruthState> gt = {Sample(0, 0.0, 0.0), Sample(50'000'000, 1.0, 0.2),
                                            Sample(150'000'000, 3.0, 0.4)};
  Transformation T_W_I;
  REQUIRE(GroundTruthAt(gt, 50'000'000, &T_W_I));
  CHECK(T_W_I.translation().x() == Approx(1.0));
  // Linear in position, slerp in rotation: at 1/4 of the way, x = 0.25 and yaw = 0.05 rad.
  REQUIRE(GroundTruthAt(gt, 12'500'000, &T_W_I));
  CHECK(T_W_I.translation().x() == Approx(0.25));
  CHECK(Eigen::AngleAxisd(T_W_I.rotation()).angle() == Approx(0.05));
  CHECK_FALSE(GroundTruthAt(gt, 100'000'000, &T_W_I));  // a 100-ms gap: no ground truth
  CHECK_FALSE(GroundTruthAt(gt, -1, &T_W_I));           // before the first sample
  CHECK_FALSE(GroundTruthAt(gt, 150'000'001, &T_W_I));  // after the last
}

TEST_CASE("dataset localization options: every, camera, align and align_from are checked") {
  DatasetLocalizationOptions o;
  CHECK(o.Validate().empty());
  o.every = 0;
  CHECK(o.Validate().rfind("every:", 0) == 0);
  o = DatasetLocalizationOptions();
  o.camera = -1;
  CHECK(o.Validate().rfind("camera:", 0) == 0);
  o = DatasetLocalizationOptions();
  o.align = AlignmentType::kSim3;  // a scale makes no sense for a metric map
  CHECK(o.Validate().rfind("align:", 0) == 0);
  o.align = AlignmentType::kPosYaw;
  o.align_from_path = "a.json";
  CHECK(o.Validate().rfind("align:", 0) == 0);
}

TEST_CASE("dataset localization summary: reports without ground truth say so") {
  DatasetLocalizationSummary s;
  s.dataset_path = "/data/session";
  s.queries = 4;
  s.localized = 3;
  s.status_counts[static_cast<int>(localizer::LocalizationStatus::kOk)] = 3;
  s.status_counts[static_cast<int>(localizer::LocalizationStatus::kTooFewMatches)] = 1;
  const std::string full = s.FullReport();
  CHECK(full.rfind("summary: 4 queries\n", 0) == 0);
  CHECK(full.find("  localized  3 / 4 (75.0 %)\n") != std::string::npos);
  CHECK(full.find("errors     none: /data/session has no ground truth") != std::string::npos);
  const std::string brief = s.BriefReport();
  CHECK(brief.find('\n') == std::string::npos);
  CHECK(brief.rfind("4 queries, localized 3 / 4 (75.0 %), no errors (no ground truth)", 0) == 0);
}

TEST_CASE("ground-truth map + dataset localization on a simulated room session",
          "[eval][localization]") {
  const std::string room = SimulatedRoom();
  if (room.empty()) VILMA_SKIP("vilma-sim is not built");
  GroundTruthMapOptions map_options;
  map_options.seconds = 0.0;
  CHECK_THROWS_AS(BuildGroundTruthLocalizationMap(room, map_options), InputError);
  map_options = GroundTruthMapOptions();
  map_options.camera = 4;
  CHECK_THROWS_WITH(BuildGroundTruthLocalizationMap(room, map_options),
                    Catch::Contains(room) && Catch::Contains("--camera"));
  map_options = GroundTruthMapOptions();
  map_options.map_builder.track_refinement.on_failure = "drop";
  CHECK_THROWS_WITH(BuildGroundTruthLocalizationMap(room, map_options),
                    Catch::Contains("map_builder.track_refinement.on_failure"));
  const GroundTruthMapSummary built = BuildGroundTruthLocalizationMap(room, GroundTruthMapOptions());
  CHECK(built.frames == 161);  // 8 s at 20 Hz, both ends
  CHECK(built.vertices > 10);
  CHECK(built.map.num_landmarks() > 100);
  CHECK(built.BriefReport() == std::to_string(built.vertices) + " vertices, " +
                                   std::to_string(built.map.num_landmarks()) + " landmarks, " +
                                   std::to_string(built.map.num_descriptors()) + " descriptors");

  // The session against its own ground-truth map: G = W, so errors need no alignment.
  const AslDataset dataset = AslDataset::Open(room);
  const SensorRig rig = LoadSensorRig(room + "/rig.yaml");
  CHECK_THROWS_WITH(CheckDatasetCamera(room, dataset, rig, room + "/rig.yaml", 3),
                    Catch::Contains("cam3"));
  const auto map = std::make_shared<localizer::LocalizationMap>(built.map);
  const localizer::Localizer loc(map, localizer::LocalizerOptions());
  const localizer::FeatureExtractor extractor(localizer::LocalizationQueryFeatureOptions());
  DatasetLocalizationOptions options;
  options.every = 10;
  const DatasetLocalizationSummary s =
      LocalizeDataset(room, dataset, rig, room + "/rig.yaml", extractor, loc, options);
  CHECK(s.frames == 161);
  CHECK(s.queries == 17);  // frames 0, 10, ..., 160
  REQUIRE(s.results.size() == 17u);
  CHECK(std::accumulate(s.status_counts.begin(), s.status_counts.end(), 0) == s.queries);
  CHECK(s.with_ground_truth == 17);
  CHECK(s.errors_valid);
  CHECK(s.localized >= 14);
  CHECK(s.within_03m_2deg >= 14);
  for (const DatasetLocalizationQuery& q : s.results) {
    if (q.has_error) CHECK(q.position_error_m < 0.05);
  }
  // The reports: one line; the full one with the recall; the CSV one row per query.
  CHECK(s.BriefReport().find('\n') == std::string::npos);
  CHECK(s.FullReport().find("  recall     within 0.5 m: ") != std::string::npos);
  const std::string csv = s.Csv();
  CHECK(std::count(csv.begin(), csv.end(), '\n') == 18);
  const std::string table = s.QueryTable();
  CHECK(std::count(table.begin(), table.end(), '\n') == 18);
}

}  // namespace vilma::eval
