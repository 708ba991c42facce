#include "vilma/eval/localization/kitti_localization.h"

#include <sys/resource.h>

#include <algorithm>
#include <catch2/catch.hpp>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <iostream>

#include "localizer/synthetic_descriptors.h"
#include <memory>
#include <random>
#include <sstream>

#include "vilma/core/error.h"
#include "test_skip.h"
#include "test_random.h"

using namespace vilma;
using namespace vilma::localizer;
using namespace vilma::eval;
namespace fs = std::filesystem;

namespace {

const fs::path kSequence = fs::path(VILMA_SHARED_DATA_DIR) / "kitti_slices" / "KITTI_sequence_1";

}  // namespace

TEST_CASE("kitti localization: stereo matching triangulates a synthetic rectified pair",
          "[localization][kitti]") {
  // Two identical descriptors on the same row with disparity 20 px -> Z = fx b / 20.
  const Camera camera(1226, 370, Eigen::Vector4d(700.0, 700.0, 600.0, 180.0),
                      DistortionModel::kNone, Eigen::VectorXd());
  KeyframeFeatures left, right;
  left.descriptors = cv::Mat::zeros(2, 64, CV_8U);
  right.descriptors = cv::Mat::zeros(3, 64, CV_8U);
  left.descriptors.at<uint8_t>(1, 0) = 0xFF;  // keypoint 1 differs from every right one by >= 8
  right.descriptors.at<uint8_t>(1, 5) = 0xFF;
  right.descriptors.at<uint8_t>(2, 9) = 0x0F;
  left.keypoints = {cv::KeyPoint(700.f, 200.f, 12.f), cv::KeyPoint(400.f, 100.f, 12.f)};
  right.keypoints = {cv::KeyPoint(680.f, 200.5f, 12.f),  // the match: d = 20, dv = 0.5
                     cv::KeyPoint(650.f, 200.f, 12.f),   // same row, Hamming 8
                     cv::KeyPoint(680.f, 203.f, 12.f)};  // row too far
  StereoMatchOptions options;
  options.ratio = 0.9;
  const std::vector<StereoMatch> m = MatchStereo(left, right, camera, 0.5, options);
  REQUIRE(m.size() == 1);
  CHECK(m[0].left == 0);
  CHECK(m[0].right == 0);
  CHECK(m[0].hamming == 0);
  CHECK(m[0].disparity_px == 20.0);
  CHECK(m[0].p_C.z() == Approx(700.0 * 0.5 / 20.0));
  CHECK(m[0].p_C.x() == Approx((700.0 - 600.0) * m[0].p_C.z() / 700.0));
  CHECK(m[0].p_C.y() == Approx((200.0 - 180.0) * m[0].p_C.z() / 700.0));
  // Negative disparity is never a match: the right keypoint 1 (Hamming 8, d = 50) wins then.
  right.keypoints[0].pt.x = 720.f;
  const std::vector<StereoMatch> m2 = MatchStereo(left, right, camera, 0.5, options);
  REQUIRE(m2.size() == 1);
  CHECK(m2[0].right == 1);
  CHECK(m2[0].hamming == 8);
  // ... and beyond max_depth_m nothing is kept (d = 50 -> Z = 7 m).
  options.max_depth_m = 5.0;
  CHECK(MatchStereo(left, right, camera, 0.5, options).empty());
}

TEST_CASE("kitti localization: loader errors name the file", "[localization][kitti]") {
  CHECK_THROWS_AS(LoadKittiSequence("/nonexistent/kitti"), InputError);
  KittiLocalizationOptions options;
  options.stereo.ratio = 0.0;
  CHECK(options.Validate().find("stereo.ratio") == 0);
}

TEST_CASE("kitti localization: odd frames against a map of the even frames (real images)",
          "[localization][kitti]") {
  if (!fs::exists(kSequence / "poses.txt")) {
    VILMA_SKIP("KITTI slice absent at " << kSequence);
  }
  const KittiSequence seq = LoadKittiSequence(kSequence.string());
  REQUIRE(seq.size() >= 10);
  CHECK(seq.baseline_m == Approx(0.537).epsilon(0.01));
  const KittiLocalizationOptions options;
  const KittiLocalizationReport report = EvaluateKittiLocalization(seq, options);
  std::cout << report.FullReport();
  CHECK(report.BriefReport().find('\n') == std::string::npos);
  CHECK(report.successes == static_cast<int>(std::lround(report.recall * report.queries.size())));
  CHECK(report.map_frames == static_cast<int>((seq.size() + 1) / 2));
  CHECK(report.queries.size() == seq.size() / 2);
  CHECK(report.merged_observations > 0);
  // The target: recall >= 90 % within 0.3 m and 2 deg.
  CHECK(report.recall >= 0.9);
  CHECK(report.median_position_error_m < 0.3);
  CHECK(report.median_rotation_error_deg < 2.0);

  // The 752x480 indoor default features (600 keypoints, one level) meet the target as well,
  // with fewer inliers per query (about 60-140 instead of 150-330): the KITTI profile is margin,
  // not a necessity.
  KittiLocalizationOptions indoor;
  indoor.features = KeyframeFeatureOptions();
  const KittiLocalizationReport indoor_report = EvaluateKittiLocalization(seq, indoor);
  std::cout << "indoor default features: recall " << indoor_report.recall << ", median "
            << indoor_report.median_position_error_m << " m, "
            << indoor_report.median_rotation_error_deg << " deg\n";
  CHECK(indoor_report.recall >= 0.9);
}

// ---------------------------------------------------------------------------------------------
// Query time against a 50k-landmark map (the "<= 20 ms p50" figure, wall time). Hidden
// benchmark: vilma_localizer_tests "[.benchmark][loc50k]" -s. It prints a table of p50/p90
// wall and thread-CPU times of matching and pose, the index build and projection training
// times, the load average, and a checksum of every query's matches and inliers: equal
// checksums from two builds mean bit-identical localization results.
// The map is synthetic (the KITTI slice gives only ~7.5k landmarks): 500 map keyframes along a
// 500 m path, 100 landmarks each placed in front of their keyframe, each seen by that keyframe
// and the next (2 descriptors, covisibility chain), with BRISK-like correlated descriptors (the
// latent model of descriptor_index_test.cpp: ~15 % bit flips between observations of one
// landmark). A query keyframe at a map keyframe's pose (perturbed by 0.2 m, 1 deg) has 500
// keypoints: the projections of the 200 landmarks of that keyframe and the next with fresh noisy
// descriptors and 0.5 px noise, plus 300 distractors of unseen appearance.
namespace {

constexpr int kBytes = 64;

using vilma::localizer::testing::BriskLikeDescriptors;

// "/proc/loadavg" fields 1-3 (1, 5 and 15 min load averages), "?" where unavailable.
std::string LoadAverage() {
  std::ifstream in("/proc/loadavg");
  std::string a, b, c;
  if (!(in >> a >> b >> c)) return "?";
  return a + " / " + b + " / " + c;
}

double Quantile(std::vector<double> v, double q) {
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(std::lround(q * static_cast<double>(v.size() - 1)))];
}

// Keyframe j of the path: 1 m apart along x, looking along x (camera z) with a slow yaw wave.
Transformation MapKeyframePose(int j) {
  const double yaw = 0.3 * std::sin(0.02 * j);
  Eigen::Matrix3d R_G_C;
  // Camera z forward = G x, camera x right = -G y, camera y down = -G z, then yaw about G z.
  R_G_C << 0, 0, 1, -1, 0, 0, 0, -1, 0;
  R_G_C = Eigen::AngleAxisd(yaw, Eigen::Vector3d::UnitZ()).toRotationMatrix() * R_G_C;
  return Transformation(R_G_C, Eigen::Vector3d(static_cast<double>(j), 0.0, 1.5));
}

}  // namespace

TEST_CASE("localizer: query time against a 50k-landmark map", "[.benchmark][loc50k]") {
  const int kKeyframes = 500, kPerKeyframe = 100, kQueries = 50;
  const Camera camera(752, 480, Eigen::Vector4d(460.0, 460.0, 376.0, 240.0),
                      DistortionModel::kNone, Eigen::VectorXd());
  BriskLikeDescriptors gen(21, 0.25, 0.25);
  std::mt19937_64 rng(22);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  std::normal_distribution<double> n(0.0, 1.0);

  auto map = std::make_shared<LocalizationMap>();
  std::vector<Eigen::VectorXd> latent;
  map->observer_begin.push_back(0);
  for (int j = 0; j < kKeyframes; ++j) map->observers.push_back(MapObjectId{1, uint64_t(j + 1)});
  uint8_t d[kBytes];
  for (int j = 0; j < kKeyframes; ++j) {
    const Transformation T_G_C = MapKeyframePose(j);
    for (int i = 0; i < kPerKeyframe; ++i) {
      const uint32_t l = static_cast<uint32_t>(map->p_G.size());
      Eigen::Vector3d bearing;
      const double y = 20 + u(rng) * 440;  // y before x, as GCC drew them (tests/test_random.h)
      const double x = 20 + u(rng) * 712;
      camera.Unproject(Eigen::Vector2d(x, y), &bearing);
      const double depth = 4.0 + 26.0 * u(rng);  // [m]
      map->p_G.push_back(T_G_C * (bearing / bearing.z() * depth));
      map->landmark_ids.push_back(MapObjectId{2, uint64_t(l + 1)});
      map->observer_index.push_back(static_cast<uint32_t>(j));
      if (j + 1 < kKeyframes) map->observer_index.push_back(static_cast<uint32_t>(j + 1));
      map->observer_begin.push_back(static_cast<uint32_t>(map->observer_index.size()));
      latent.push_back(gen.Latent());
      for (int o = 0; o < 2; ++o) {
        gen.Observe(latent.back(), d);
        map->descriptors.insert(map->descriptors.end(), d, d + kBytes);
        map->descriptor_landmark.push_back(l);
      }
    }
  }
  REQUIRE(map->Validate().empty());
  REQUIRE(map->num_landmarks() >= 50000);

  const LocalizerOptions options;  // config/localizer.yaml defaults
  auto t0 = std::chrono::steady_clock::now();
  const Localizer localizer(map, options);
  const double construct_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();

  // Wall and thread-CPU times per stage; the load average is printed with them because on this
  // shared 2-core machine wall - CPU is the time spent waiting for a core.
  const std::string load_before = LoadAverage();
  // Context switches of this thread over the queries: voluntary ones would mean the query
  // blocks (I/O, locks, sleeps), involuntary ones that it was preempted (machine load).
  rusage usage0{};
  getrusage(RUSAGE_THREAD, &usage0);
  std::vector<double> match_wall, match_cpu, pose_wall, pose_cpu, query_wall, query_cpu;
  int localized = 0;
  std::size_t total_matches = 0, total_raw = 0, total_inliers = 0;
  uint64_t checksum = 1469598103934665603ull;  // FNV-1a over every query's matches and inliers
  auto hash = [&](uint64_t v) {
    for (int b = 0; b < 8; ++b) checksum = (checksum ^ ((v >> (8 * b)) & 0xFF)) * 1099511628211ull;
  };
  LocalizerStats stats;
  for (int q = 0; q < kQueries; ++q) {
    const int j = 5 + q * (kKeyframes - 10) / kQueries;
    Transformation T_G_C = MapKeyframePose(j);
    Eigen::Matrix<double, 6, 1> xi;
    xi << 0.2 * n(rng), 0.2 * n(rng), 0.2 * n(rng), 0.017 * n(rng), 0.017 * n(rng),
        0.017 * n(rng);
    T_G_C = T_G_C * Transformation::Exp(xi);
    const Transformation T_C_G = T_G_C.inverse();
    std::vector<Eigen::Vector2d> uv;
    std::vector<uint8_t> descriptors;
    for (int l = j * kPerKeyframe; l < (j + 2) * kPerKeyframe; ++l) {
      Eigen::Vector2d px;
      if (camera.Project(T_C_G * map->p_G[static_cast<std::size_t>(l)], &px) !=
          Camera::ProjectionResult::kValid) {
        continue;
      }
      uv.push_back(px + 0.5 * vilma::testing::DrawVector2([&] { return n(rng); }));
      gen.Observe(latent[static_cast<std::size_t>(l)], d);
      descriptors.insert(descriptors.end(), d, d + kBytes);
    }
    while (uv.size() < 500) {
      const double y = u(rng) * 479;  // y before x, as GCC drew them
      const double x = u(rng) * 751;
      uv.emplace_back(x, y);
      gen.Observe(gen.Latent(), d);
      descriptors.insert(descriptors.end(), d, d + kBytes);
    }
    const LocalizationResult r =
        localizer.Localize(camera, Transformation(), uv, descriptors.data());
    match_wall.push_back(r.match_ms);
    match_cpu.push_back(r.match_cpu_ms);
    pose_wall.push_back(r.pose_ms);
    pose_cpu.push_back(r.pose_cpu_ms);
    query_wall.push_back(r.match_ms + r.pose_ms);
    query_cpu.push_back(r.match_cpu_ms + r.pose_cpu_ms);
    stats.Add(r);
    total_raw += static_cast<std::size_t>(r.num_raw_matches);
    total_matches += r.matches.size();
    total_inliers += r.inliers.size();
    hash(static_cast<uint64_t>(r.status));
    hash(static_cast<uint64_t>(r.num_raw_matches));
    for (const Match2D3D& m : r.matches) {
      hash(static_cast<uint64_t>(m.keypoint));
      hash(m.landmark);
      hash(static_cast<uint64_t>(m.hamming));
    }
    for (int i : r.inliers) hash(static_cast<uint64_t>(i));
    if (r.status == LocalizationStatus::kOk &&
        (r.T_G_C.translation() - T_G_C.translation()).norm() < 0.1) {
      ++localized;
    }
  }
  const std::string load_after = LoadAverage();
  rusage usage1{};
  getrusage(RUSAGE_THREAD, &usage1);
  auto row = [&](const char* name, const std::vector<double>& wall,
                 const std::vector<double>& cpu) {
    std::cout << "  | " << std::left << std::setw(20) << name << std::right << std::fixed
              << std::setprecision(2) << " | " << std::setw(7) << Quantile(wall, 0.5) << " | "
              << std::setw(7) << Quantile(wall, 0.9) << " | " << std::setw(7) << Quantile(cpu, 0.5)
              << " | " << std::setw(7) << Quantile(cpu, 0.9) << " |\n";
  };
  std::cout << "50k-landmark map: " << map->num_landmarks() << " landmarks, "
            << map->num_descriptors() << " descriptors, k = " << localizer.index().k() << "\n"
            << "  load average (1/5/15 min) before " << load_before << ", after " << load_after
            << "; context switches in the query loop: " << usage1.ru_nivcsw - usage0.ru_nivcsw
            << " involuntary (preempted), " << usage1.ru_nvcsw - usage0.ru_nvcsw << " voluntary"
            << "\n  Localizer construction " << std::fixed << std::setprecision(1) << construct_ms
            << " ms: projection training " << localizer.projection_train_ms() << " ms, index build "
            << localizer.index_build_ms() << " ms\n"
            << "  | " << kQueries
            << " queries x 500 kpts  | wall p50 | wall p90 | CPU p50 | CPU p90 |"
            << " [ms]\n";
  row("match", match_wall, match_cpu);
  row("pose", pose_wall, pose_cpu);
  row("query (match + pose)", query_wall, query_cpu);
  std::cout << "  localized within 0.1 m: " << localized << "/" << kQueries << "; "
            << stats.BriefReport() << "\n  matches: raw " << total_raw << ", after covisibility "
            << total_matches << ", inliers " << total_inliers << ", checksum " << std::hex
            << checksum << std::dec << "\n";
  std::cout.unsetf(std::ios::floatfield);
  CHECK(localized >= kQueries * 9 / 10);
  // The target is wall time on the 2-core machine; CPU time alone would hide a stage that
  // sleeps or waits.
  CHECK(Quantile(query_cpu, 0.5) <= 20.0);
  CHECK(Quantile(query_wall, 0.5) <= 20.0);
}
