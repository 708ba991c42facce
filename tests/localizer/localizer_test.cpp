#include "vilma/localizer/localizer.h"

#include <algorithm>
#include <catch2/catch.hpp>
#include <set>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iostream>
#include <random>
#include <time.h>

#include "vilma/core/asl_dataset.h"
#include "vilma/core/error.h"
#include "vilma/core/rig.h"
#include "vilma/localizer/keyframe_features.h"
#include "vilma/mapping/locmap/localization_map_builder.h"
#include "vilma/mapping/map_builder.h"
#include "core/test_data.h"
#include "test_skip.h"

using namespace vilma;
using namespace vilma::localizer;
namespace fs = std::filesystem;

namespace {

double ThreadCpuMs() {
  timespec ts;
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return 1e3 * static_cast<double>(ts.tv_sec) + 1e-6 * static_cast<double>(ts.tv_nsec);
}

double Percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0.0;
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(std::min<double>(v.size() - 1, q * (v.size() - 1) + 0.5))];
}

// Ground-truth state at t (the simulator writes ground truth at the IMU times, which include
// the frame times); false if there is none.
bool GroundTruthAt(const AslDataset& ds, int64_t t, GroundTruthState* state) {
  const auto& gt = ds.ground_truth();
  const auto it = std::lower_bound(
      gt.begin(), gt.end(), t, [](const GroundTruthState& g, int64_t tt) { return g.t_ns < tt; });
  if (it == gt.end() || it->t_ns != t) return false;
  *state = *it;
  return true;
}

// A VI-map of the first `seconds` of a simulated session built by the map builder driven by the
// GROUND-TRUTH states (so M = W = G, and localization errors are errors against ground truth),
// with keyframe features of camera 0 only.
mapstore::VIMap BuildGroundTruthMap(const fs::path& dataset_dir, double seconds) {
  const AslDataset ds = AslDataset::Open(dataset_dir.string());
  const SensorRig rig = LoadSensorRig((dataset_dir / "rig.yaml").string());
  mapping::MapBuilderOptions options;
  options.cameras = {0};
  mapping::MapBuilder builder(rig, options, 42, "loc-gt");
  const auto& imu = ds.imu();
  std::size_t next_imu = 0;
  const auto& frames = ds.cameras()[0].frames;
  const int64_t t_end = frames.front().t_ns + static_cast<int64_t>(seconds * 1e9);
  for (std::size_t i = 0; i < frames.size() && frames[i].t_ns <= t_end; ++i) {
    const int64_t t = frames[i].t_ns + rig.cameras[0].time_offset_ns;
    while (next_imu < imu.size() && imu[next_imu].t_ns <= t) builder.AddImu(imu[next_imu++]);
    if (next_imu < imu.size()) builder.AddImu(imu[next_imu++]);
    GroundTruthState g;
    if (!GroundTruthAt(ds, t, &g)) continue;
    mapping::FrameState s;
    s.t_ns = t;
    s.T_M_I = Transformation(g.q_W_I, g.p_W_I);
    s.v_M = g.v_W;
    s.gyro_bias = g.b_g;
    s.accel_bias = g.b_a;
    if (!builder.WantsFrame(t)) {
      builder.AddFrame(s, {});
      continue;
    }
    std::vector<cv::Mat> images(rig.cameras.size());
    images[0] = AslDataset::LoadImage(frames[i].image_path);
    builder.AddFrame(s, images);
  }
  while (next_imu < imu.size()) builder.AddImu(imu[next_imu++]);
  builder.Finish();
  return builder.ReleaseMap();
}

}  // namespace

TEST_CASE("localizer options: the shipped YAML parses to the defaults", "[localization]") {
  const LocalizerOptions o =
      LoadLocalizerOptions(std::string(VILMA_SOURCE_DIR) + "/config/localizer.yaml");
  const LocalizerOptions d;
  CHECK(o.map.max_descriptors_per_landmark == d.map.max_descriptors_per_landmark);
  CHECK(o.projection.dimensions == d.projection.dimensions);
  CHECK(o.projection.max_pairs == d.projection.max_pairs);
  CHECK(o.index.codebook_size == d.index.codebook_size);
  CHECK(o.index.min_neighbors == d.index.min_neighbors);
  CHECK(o.index.max_neighbors == d.index.max_neighbors);
  CHECK(o.matching.max_hamming_distance == d.matching.max_hamming_distance);
  CHECK(o.matching.min_matches == d.matching.min_matches);
  CHECK(o.ransac.threshold_px == d.ransac.threshold_px);
  CHECK(o.ransac.min_inliers == d.ransac.min_inliers);
  CHECK(o.ransac.seed == d.ransac.seed);
  CHECK(o.acceptance.min_inlier_ratio == d.acceptance.min_inlier_ratio);
  CHECK(o.acceptance.refine_rounds == d.acceptance.refine_rounds);
  CHECK(o.acceptance.max_median_error_ratio == d.acceptance.max_median_error_ratio);
  CHECK(o.acceptance.max_p90_error_ratio == d.acceptance.max_p90_error_ratio);
  CHECK(o.acceptance.grid_cols == d.acceptance.grid_cols);
  CHECK(o.acceptance.grid_rows == d.acceptance.grid_rows);
  CHECK(o.acceptance.min_cell_fraction == d.acceptance.min_cell_fraction);
  CHECK(o.acceptance.min_hull_fraction == d.acceptance.min_hull_fraction);
  CHECK(o.acceptance.max_position_sigma_m == d.acceptance.max_position_sigma_m);
  CHECK(o.acceptance.max_rotation_sigma_deg == d.acceptance.max_rotation_sigma_deg);
  CHECK(o.acceptance.landmark_uncertainty == d.acceptance.landmark_uncertainty);
  CHECK(o.acceptance.unweighted_covariance == d.acceptance.unweighted_covariance);
  CHECK(o.acceptance.rival_check == d.acceptance.rival_check);
  CHECK(o.acceptance.rival_exclusion_factor == d.acceptance.rival_exclusion_factor);
  CHECK(o.acceptance.max_rival_ratio == d.acceptance.max_rival_ratio);
  CHECK(o.acceptance.rival_max_iterations == d.acceptance.rival_max_iterations);
  CHECK(o.acceptance.rival_min_position_m == d.acceptance.rival_min_position_m);
  CHECK(o.acceptance.rival_min_rotation_deg == d.acceptance.rival_min_rotation_deg);
  CHECK(d.Validate().empty());
}

TEST_CASE("localizer options: unknown keys and bad values name file and key", "[localization]") {
  CHECK_THROWS_WITH(ParseLocalizerOptions("ransac:\n  threshold_pix: 2\n", "loc.yaml"),
                    Catch::Contains("loc.yaml") && Catch::Contains("threshold_pix"));
  CHECK_THROWS_WITH(ParseLocalizerOptions("ransac:\n  threshold_px: -1\n", "loc.yaml"),
                    Catch::Contains("loc.yaml") && Catch::Contains("ransac.threshold_px"));
  CHECK_THROWS_WITH(ParseLocalizerOptions("projection:\n  dimensions: 7\n", "loc.yaml"),
                    Catch::Contains("projection.dimensions"));
  CHECK_THROWS_WITH(ParseLocalizerOptions("indx: {}\n", "loc.yaml"), Catch::Contains("indx"));
  CHECK_THROWS_AS(ParseLocalizerOptions("matching:\n  min_matches: many\n", "loc.yaml"),
                  InputError);
  CHECK(ParseLocalizerOptions("matching:\n  min_matches: 20\n", "loc.yaml").matching.min_matches ==
        20);
  // The acceptance section: strict keys, validated values, read values.
  CHECK_THROWS_WITH(ParseLocalizerOptions("acceptance:\n  max_rival: 0.5\n", "loc.yaml"),
                    Catch::Contains("loc.yaml") && Catch::Contains("max_rival"));
  CHECK_THROWS_WITH(ParseLocalizerOptions("acceptance:\n  max_rival_ratio: 0\n", "loc.yaml"),
                    Catch::Contains("loc.yaml") && Catch::Contains("acceptance.max_rival_ratio"));
  const LocalizerOptions a = ParseLocalizerOptions(
      "acceptance:\n  rival_check: false\n  max_position_sigma_m: 0.05\n", "loc.yaml");
  CHECK_FALSE(a.acceptance.rival_check);
  CHECK(a.acceptance.max_position_sigma_m == 0.05);
  // Every status has its own name.
  std::set<std::string> names;
  for (int k = 0; k < static_cast<int>(LocalizationStatus::kNumStatuses); ++k) {
    names.insert(LocalizationStatusName(static_cast<LocalizationStatus>(k)));
  }
  CHECK(names.size() == static_cast<std::size_t>(LocalizationStatus::kNumStatuses));
  CHECK(names.count("unknown") == 0);
  // A refined pose exists exactly for ok, too few inliers after refinement and the gates.
  const std::set<std::string> with_pose = {"ok",
                                           "too_few_inliers",
                                           "low_inlier_ratio",
                                           "high_reprojection_error",
                                           "clustered_inliers",
                                           "uncertain_pose",
                                           "ambiguous_pose"};
  for (int k = 0; k < static_cast<int>(LocalizationStatus::kNumStatuses); ++k) {
    const auto status = static_cast<LocalizationStatus>(k);
    INFO(LocalizationStatusName(status));
    CHECK(HasRefinedPose(status) == (with_pose.count(LocalizationStatusName(status)) == 1));
  }
  CHECK_FALSE(HasRefinedPose(LocalizationStatus::kNumStatuses));
}

TEST_CASE("covisibility: the largest component through shared observers is kept",
          "[localization]") {
  // Landmarks 0,1,2 share observers (0-1 via vertex 0, 1-2 via vertex 1); 3,4 share vertex 2;
  // 5 is alone.
  LocalizationMap map;
  map.observers.resize(4);
  const std::vector<std::vector<uint32_t>> obs = {{0}, {0, 1}, {1}, {2}, {2}, {3}};
  map.observer_begin.push_back(0);
  for (const auto& o : obs) {
    map.p_G.emplace_back(0, 0, 0);
    map.landmark_ids.emplace_back();
    map.observer_index.insert(map.observer_index.end(), o.begin(), o.end());
    map.observer_begin.push_back(static_cast<uint32_t>(map.observer_index.size()));
  }
  REQUIRE(map.Validate().empty());
  const std::vector<Match2D3D> matches = {{0, 3, 0}, {1, 0, 0}, {2, 5, 0},
                                          {3, 2, 0}, {4, 4, 0}, {5, 1, 0}};
  CHECK(LargestCovisibleComponent(map, matches) == std::vector<int>{1, 3, 5});
  // Two equal components: the one of the earliest match wins.
  const std::vector<Match2D3D> tie = {{0, 3, 0}, {1, 0, 0}, {2, 4, 0}, {3, 2, 0}};
  CHECK(LargestCovisibleComponent(map, tie) == std::vector<int>{0, 2});
  CHECK(LargestCovisibleComponent(map, {}).empty());
}

TEST_CASE("localizer: end to end on simulated room sessions (map from room-easy, query room-s2)",
          "[localization][benchmark]") {
  const fs::path datasets = vilma::testing::SimulatedDatasetsDir();
  const fs::path map_set = datasets / "room-easy";
  const fs::path query_set = datasets / "room-s2";
  if (!fs::exists(map_set / "rig.yaml") || !fs::exists(query_set / "rig.yaml")) {
    VILMA_SKIP_OPTIONAL("simulated room datasets absent under "
                        << datasets << " (scripts/make-datasets.sh makes them)");
  }
  const double map_seconds = std::getenv("VILMA_LOC_MAP_SECONDS")
                                 ? std::atof(std::getenv("VILMA_LOC_MAP_SECONDS"))
                                 : 90.0;
  auto t0 = std::chrono::steady_clock::now();
  const mapstore::VIMap vimap = BuildGroundTruthMap(map_set, map_seconds);
  const double map_build_s =
      std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();
  auto loc_map = std::make_shared<LocalizationMap>(mapping::BuildLocalizationMap(vimap));
  REQUIRE(loc_map->num_landmarks() > 100);
  // Round trip through the file, as the daemon would load it.
  const std::string path = (fs::temp_directory_path() / "vilma_loc_e2e.vlocmap").string();
  SaveLocalizationMap(*loc_map, path);
  loc_map = std::make_shared<LocalizationMap>(LoadLocalizationMap(path));
  fs::remove(path);

  const LocalizerOptions options;
  const Localizer localizer(loc_map, options);

  const AslDataset ds = AslDataset::Open(query_set.string());
  const SensorRig rig = LoadSensorRig((query_set / "rig.yaml").string());
  const Camera& camera = rig.cameras[0].camera;
  const Transformation& T_I_C = rig.cameras[0].T_I_C;
  const FeatureExtractor extractor(mapping::MapBuilderOptions().features);
  const auto& frames = ds.cameras()[0].frames;
  LocalizerStats stats;
  std::vector<double> pos_err, rot_err_deg, query_ms, wall_ms, match_ms, pose_ms;
  int queries = 0, within = 0;
  const int stride = std::getenv("VILMA_LOC_STRIDE") ? std::atoi(std::getenv("VILMA_LOC_STRIDE")) : 10;
  for (std::size_t i = 0; i < frames.size(); i += stride) {
    GroundTruthState g;
    if (!GroundTruthAt(ds, frames[i].t_ns + rig.cameras[0].time_offset_ns, &g)) continue;
    const KeyframeFeatures f = extractor.Extract(AslDataset::LoadImage(frames[i].image_path));
    std::vector<Eigen::Vector2d> uv;
    for (const cv::KeyPoint& k : f.keypoints) uv.emplace_back(k.pt.x, k.pt.y);
    // Query time as CPU time of this thread (one core; the wall time on a shared machine
    // includes waiting for the CPU).
    const auto tq = std::chrono::steady_clock::now();
    const double cpu0 = ThreadCpuMs();
    const LocalizationResult r = localizer.Localize(camera, T_I_C, uv, f.descriptors.ptr<uint8_t>());
    query_ms.push_back(ThreadCpuMs() - cpu0);
    wall_ms.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - tq).count());
    match_ms.push_back(r.match_ms);
    pose_ms.push_back(r.pose_ms);
    stats.Add(r);
    ++queries;
    if (r.status != LocalizationStatus::kOk) continue;
    const double e_p = (r.T_G_I.translation() - g.p_W_I).norm();
    const double e_r = AngleBetween(r.T_G_I.rotation(), g.q_W_I) * 180.0 / M_PI;
    pos_err.push_back(e_p);
    rot_err_deg.push_back(e_r);
    if (e_p <= 0.5) ++within;
    CHECK(r.covariance_I.allFinite());
  }
  REQUIRE(queries > 0);
  const double recall = static_cast<double>(within) / queries;
  std::cout << "[localization e2e] map: room-easy first " << map_seconds << " s, ground-truth poses: "
            << vimap.num_vertices() << " vertices, " << loc_map->num_landmarks() << " landmarks, "
            << loc_map->num_descriptors() << " descriptors (map build " << map_build_s
            << " s); projection training " << localizer.projection_train_ms()
            << " ms, index build " << localizer.index_build_ms() << " ms, k "
            << localizer.index().k() << "\n"
            << "[localization e2e] queries room-s2 every " << stride << "th cam0 frame: " << queries
            << ", localized " << pos_err.size() << ", within 0.5 m " << within << " (recall "
            << recall << "), median position error " << Percentile(pos_err, 0.5)
            << " m, p90 " << Percentile(pos_err, 0.9) << " m, median rotation error "
            << Percentile(rot_err_deg, 0.5) << " deg; query time p50 " << Percentile(query_ms, 0.5)
            << " ms, p90 " << Percentile(query_ms, 0.9) << " ms (thread CPU); wall p50 "
            << Percentile(wall_ms, 0.5) << " ms (matching " << Percentile(match_ms, 0.5)
            << " ms, pose " << Percentile(pose_ms, 0.5) << " ms)\n"
            << "[localization e2e] " << stats.BriefReport() << std::endl;
  CHECK(recall >= 0.8);
  CHECK(Percentile(pos_err, 0.5) < 0.05);
  CHECK(Percentile(rot_err_deg, 0.5) < 0.5);
  CHECK(Percentile(query_ms, 0.5) < 20.0);
}

TEST_CASE("localizer options: every option round-trips through LocalizerOptionsToYaml",
          "[localization][options]") {
  // Defaults: written, read back, written again: the same text (doubles as shortest round-trip
  // text, so equal text means equal values).
  const std::string defaults = LocalizerOptionsToYaml(LocalizerOptions());
  CHECK(LocalizerOptionsToYaml(ParseLocalizerOptions(defaults, "defaults.yaml")) == defaults);
  // Every section is written.
  for (const char* section : {"map:", "projection:", "index:", "matching:", "ransac:",
                              "acceptance:"}) {
    const bool written = defaults.find(std::string("\n") + section) != std::string::npos ||
                         defaults.rfind(section, 0) == 0;
    CHECK(written);
  }
  // A value of each kind changed from its default survives (bool, int, uint64 seed, double).
  LocalizerOptions changed;
  changed.map.calibrate_landmark_covariances = !changed.map.calibrate_landmark_covariances;
  changed.index.codebook_size += 3;
  changed.ransac.seed = 123456789012345ULL;
  changed.acceptance.max_position_sigma_m = 0.1 + 0.2;
  changed.acceptance.rival_min_rotation_deg = 1.0 / 3.0;
  const LocalizerOptions back =
      ParseLocalizerOptions(LocalizerOptionsToYaml(changed), "changed.yaml");
  CHECK(back.map.calibrate_landmark_covariances == changed.map.calibrate_landmark_covariances);
  CHECK(back.index.codebook_size == changed.index.codebook_size);
  CHECK(back.ransac.seed == changed.ransac.seed);
  CHECK(back.acceptance.max_position_sigma_m == changed.acceptance.max_position_sigma_m);
  CHECK(back.acceptance.rival_min_rotation_deg == changed.acceptance.rival_min_rotation_deg);
  CHECK(LocalizerOptionsToYaml(back) == LocalizerOptionsToYaml(changed));
  CHECK(LocalizerOptionsToYaml(back) != defaults);
  // The shipped file reads, and writes back to the same values.
  const LocalizerOptions shipped =
      LoadLocalizerOptions(std::string(VILMA_SOURCE_DIR) + "/config/localizer.yaml");
  CHECK(LocalizerOptionsToYaml(ParseLocalizerOptions(LocalizerOptionsToYaml(shipped), "x")) ==
        LocalizerOptionsToYaml(shipped));
}
