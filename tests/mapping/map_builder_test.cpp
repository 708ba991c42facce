#include "vilma/mapping/map_builder.h"

#include <unistd.h>

#include <algorithm>
#include <array>
#include <catch2/catch.hpp>
#include <cmath>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <iterator>
#include <limits>
#include <sstream>

#include "vilma/core/asl_dataset.h"
#include "vilma/core/rig.h"
#include "vilma/eval/trajectory.h"
#include "vilma/eval/evaluate.h"
#include "vilma/mapstore/consistency.h"
#include "vilma/mapstore/map_io.h"
#include "vilma/sim/simulator.h"
#include "vilma/sim/world.h"
#include "test_skip.h"

using namespace vilma;
using namespace vilma::mapping;
namespace fs = std::filesystem;

namespace {

// Deterministic synthetic IMU stream at 200 Hz starting at t0.
std::vector<ImuSample> MakeImu(int64_t t0, int n) {
  std::vector<ImuSample> imu;
  for (int i = 0; i < n; ++i) {
    ImuSample s;
    s.t_ns = t0 + int64_t{5'000'000} * i;
    s.omega_I =
        Eigen::Vector3d(0.1 * std::sin(0.01 * i), 0.2 * std::cos(0.02 * i), 0.05 + 1e-4 * i);
    s.a_I = Eigen::Vector3d(0.3 * std::cos(0.03 * i), 0.1, 9.81 + 0.01 * i);
    imu.push_back(s);
  }
  return imu;
}

FrameState StateAt(int64_t t_ns) {
  FrameState s;
  s.t_ns = t_ns;
  s.T_M_I =
      Transformation(Eigen::Quaterniond::Identity(),
                     Eigen::Vector3d(1e-9 * static_cast<double>(t_ns % 1'000'000'000'000), 0, 0));
  return s;
}

bool SameSample(const ImuSample& a, const ImuSample& b) {
  return a.t_ns == b.t_ns && a.omega_I == b.omega_I && a.a_I == b.a_I;
}

std::string ReadFileBytes(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  return std::string(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
}

// Relative path -> content of every file under `root`.
std::map<std::string, std::string> FolderContents(const fs::path& root) {
  std::map<std::string, std::string> files;
  for (const auto& e : fs::recursive_directory_iterator(root)) {
    if (e.is_regular_file()) files[fs::relative(e.path(), root).string()] = ReadFileBytes(e.path());
  }
  return files;
}

using sim::DistanceToWorld;

double Median(std::vector<double> v) {
  REQUIRE(!v.empty());
  std::sort(v.begin(), v.end());
  return v.size() % 2 ? v[v.size() / 2] : 0.5 * (v[v.size() / 2 - 1] + v[v.size() / 2]);
}

// A 20 s stereo room session from the simulator binary (seed 1, as vilma-sim's default), made
// once per test process in the build tree and removed at exit. Empty when vilma-sim is not built.
struct RoomSessionDir {
  fs::path dir;
  ~RoomSessionDir() {
    std::error_code ec;
    if (!dir.empty()) fs::remove_all(dir, ec);
  }
};
fs::path RoomSession() {
  static RoomSessionDir session;
  static bool tried = false;
  if (tried) return session.dir;
  tried = true;
  const fs::path sim = fs::path(VILMA_BINARY_DIR) / "bin" / "vilma-sim";
  if (!fs::exists(sim)) return session.dir;
  const fs::path out =
      fs::path(VILMA_BINARY_DIR) / "test-data" / ("mapping_room20_" + std::to_string(::getpid()));
  fs::create_directories(out);
  const std::string cmd = sim.string() + " room --seconds 20 --stereo --seed 1 --out " +
                          out.string() + " > " + out.string() + "/vilma-sim.log 2>&1";
  session.dir = out;
  if (std::system(cmd.c_str()) != 0) FAIL("vilma-sim failed: " << cmd);
  return session.dir;
}

// Builds the mission from the dataset driven by its ground-truth states (M = W).
struct GtBuild {
  mapstore::VIMap map;
  MapBuilderStats stats;
  std::vector<mapstore::MissionDelta> deltas;
};
GtBuild BuildFromGroundTruth(const fs::path& dataset_dir,
                             const MapBuilderOptions& options = MapBuilderOptions()) {
  const AslDataset ds = AslDataset::Open(dataset_dir.string());
  const SensorRig rig = LoadSensorRig((dataset_dir / "rig.yaml").string());
  REQUIRE(ds.cameras().size() == 2);
  REQUIRE(!ds.ground_truth().empty());
  MapBuilder builder(rig, options, 42, "room-gt");
  GtBuild out;
  const auto& gt = ds.ground_truth();
  const auto& imu = ds.imu();
  std::size_t next_imu = 0;
  const auto& frames0 = ds.cameras()[0].frames;
  const auto& frames1 = ds.cameras()[1].frames;
  for (std::size_t i = 0; i < frames0.size(); ++i) {
    const int64_t t = frames0[i].t_ns + rig.cameras[0].time_offset_ns;
    while (next_imu < imu.size() && imu[next_imu].t_ns <= t) builder.AddImu(imu[next_imu++]);
    if (next_imu < imu.size()) builder.AddImu(imu[next_imu++]);
    // Ground truth at t (the simulator writes it at the IMU times, which include the frames').
    const auto it = std::lower_bound(
        gt.begin(), gt.end(), t, [](const GroundTruthState& g, int64_t tt) { return g.t_ns < tt; });
    if (it == gt.end() || it->t_ns != t) continue;
    FrameState s;
    s.t_ns = t;
    s.T_M_I = Transformation(it->q_W_I, it->p_W_I);
    s.v_M = it->v_W;
    s.gyro_bias = it->b_g;
    s.accel_bias = it->b_a;
    if (!builder.WantsFrame(t)) {
      CHECK_FALSE(builder.AddFrame(s, {}));
      continue;
    }
    std::vector<cv::Mat> images(2);
    images[0] = AslDataset::LoadImage(frames0[i].image_path);
    if (i < frames1.size() && frames1[i].t_ns == frames0[i].t_ns) {
      images[1] = AslDataset::LoadImage(frames1[i].image_path);
    }
    CHECK(builder.AddFrame(s, images));
    if (i % 50 == 0) out.deltas.push_back(builder.TakeDelta());
  }
  while (next_imu < imu.size()) builder.AddImu(imu[next_imu++]);
  builder.Finish();
  out.deltas.push_back(builder.TakeDelta());
  out.stats = builder.stats();
  out.map = builder.ReleaseMap();
  return out;
}

}  // namespace

TEST_CASE("map builder: the vertex rate thins the frames", "[mapping]") {
  const SensorRig rig = sim::MakeEurocRig(false);
  struct Case {
    double rate_hz;
    double jitter_ms;
    int expected;
  };
  // 100 frames at 20 Hz (5 s).
  for (const Case c : {Case{10.0, 0.0, 50}, Case{10.0, 2.0, 50}, Case{0.0, 0.0, 100},
                       Case{5.0, 0.0, 25}, Case{20.0, 1.0, 100}, Case{100.0, 0.0, 100}}) {
    MapBuilderOptions o;
    o.vertex_rate_hz = c.rate_hz;
    MapBuilder builder(rig, o, 1);
    for (int i = 0; i < 100; ++i) {
      const double jitter = (i % 2 ? 1 : -1) * c.jitter_ms * 1e6;
      builder.AddFrame(
          StateAt(1'000'000'000 + int64_t{50'000'000} * i + static_cast<int64_t>(jitter)), {});
    }
    INFO("rate " << c.rate_hz << " Hz, jitter " << c.jitter_ms << " ms");
    CHECK(builder.stats().vertices == c.expected);
    CHECK(builder.stats().frames_skipped_rate == 100 - c.expected);
    CHECK(builder.map().num_vertices() == static_cast<std::size_t>(c.expected));
  }
  // Frames not increasing in time are rejected.
  MapBuilder builder(rig, MapBuilderOptions(), 1);
  CHECK(builder.AddFrame(StateAt(2'000'000'000), {}));
  CHECK_FALSE(builder.AddFrame(StateAt(2'000'000'000), {}));
  CHECK_FALSE(builder.AddFrame(StateAt(1'000'000'000), {}));
  CHECK(builder.stats().frames_rejected == 2);
}

TEST_CASE("map builder: the vertex-rate rule compares in double, at its exact threshold",
          "[mapping]") {
  // 10 Hz: the threshold 0.9 / 10 s = 90 000 000 ns is an integer.
  CHECK(VertexIntervalReached(90'000'000, 10.0));
  CHECK_FALSE(VertexIntervalReached(89'999'999, 10.0));
  // 7 Hz: 0.9e9 / 7 = 128 571 428.57 ns. The daemon's former copy truncated the threshold to
  // 128 571 428 ns and handed the builder a frame that WantsFrame then refused.
  CHECK_FALSE(VertexIntervalReached(128'571'428, 7.0));
  CHECK(VertexIntervalReached(128'571'429, 7.0));
  // 0 Hz: every frame.
  CHECK(VertexIntervalReached(0, 0.0));
  // WantsFrame applies it after the first vertex.
  const SensorRig rig = sim::MakeEurocRig(false);
  MapBuilderOptions o;
  o.vertex_rate_hz = 7.0;
  MapBuilder builder(rig, o, 1);
  CHECK(builder.WantsFrame(1'000'000'000));
  REQUIRE(builder.AddFrame(StateAt(1'000'000'000), {}));
  CHECK_FALSE(builder.WantsFrame(1'128'571'428));
  CHECK(builder.WantsFrame(1'128'571'429));
}

TEST_CASE("map builder: IMU edges carry every sample exactly once", "[mapping]") {
  const SensorRig rig = sim::MakeEurocRig(false);
  const int64_t t0 = 1'000'000'000;
  const std::vector<ImuSample> imu = MakeImu(t0, 2000);  // 10 s
  // Frame times at 20 Hz: on sample stamps, or between them (offset 1.234 ms).
  const int64_t offset_ns = GENERATE(int64_t{0}, int64_t{1'234'567});
  // The IMU leads the frames (as the offline runner), or lags them by 0.3 s (a late IMU
  // stream in the daemon): pending edges then complete when their end sample arrives.
  const bool imu_lags = GENERATE(false, true);
  INFO("offset " << offset_ns << " ns, imu lags " << imu_lags);
  MapBuilder builder(rig, MapBuilderOptions(), 9);
  std::size_t next = 0;
  std::vector<int64_t> vertex_times;
  std::size_t edges_streamed = 0;
  for (int k = 0; k < 190; ++k) {
    const int64_t t = t0 + int64_t{100'000'000} + int64_t{50'000'000} * k + offset_ns;
    const int64_t feed_until = imu_lags ? t - 300'000'000 : t + 5'000'000;
    while (next < imu.size() && imu[next].t_ns <= feed_until) builder.AddImu(imu[next++]);
    if (builder.AddFrame(StateAt(t), {})) vertex_times.push_back(t);
    if (k % 7 == 0) edges_streamed += builder.TakeDelta().edges.size();
  }
  // Duplicates and out-of-order samples are dropped, not stored.
  builder.AddImu(imu[next - 1]);
  while (next < imu.size()) builder.AddImu(imu[next++]);
  builder.AddImu(imu[5]);
  const mapstore::VIMap& map = builder.Finish();
  edges_streamed += builder.TakeDelta().edges.size();
  CHECK(builder.stats().imu_dropped == 2);
  CHECK(builder.stats().imu_edges_held == 0);
  REQUIRE(vertex_times.size() == 95);

  const mapstore::MissionId mission = builder.mission_id();
  const std::vector<mapstore::VertexId> chain = map.VertexChain(mission);
  REQUIRE(chain.size() == vertex_times.size());
  REQUIRE(map.edge_ids(mission).size() == vertex_times.size() - 1);
  CHECK(edges_streamed == vertex_times.size() - 1);
  // Interior samples of all edges, in chain order.
  std::vector<ImuSample> interior;
  std::size_t k = 0;
  for (const mapstore::EdgeId& eid : map.edge_ids(mission)) {
    const mapstore::Edge& e = map.edge(eid);
    REQUIRE(e.type == mapstore::EdgeType::kImu);
    CHECK(e.from == chain[k]);
    CHECK(e.to == chain[k + 1]);
    REQUIRE(e.imu_samples.size() >= 2);
    CHECK(e.imu_samples.front().t_ns == vertex_times[k]);
    CHECK(e.imu_samples.back().t_ns == vertex_times[k + 1]);
    // End samples: the raw sample when a stamp matches, else the interpolation.
    for (const ImuSample* end : {&e.imu_samples.front(), &e.imu_samples.back()}) {
      const auto it = std::lower_bound(imu.begin(), imu.end(), end->t_ns,
                                       [](const ImuSample& s, int64_t t) { return s.t_ns < t; });
      REQUIRE(it != imu.end());
      const ImuSample expected =
          it->t_ns == end->t_ns ? *it : InterpolateImu(*(it - 1), *it, end->t_ns);
      CHECK(SameSample(*end, expected));
    }
    interior.insert(interior.end(), e.imu_samples.begin() + 1, e.imu_samples.end() - 1);
    ++k;
  }
  // Expected: the input samples strictly inside (first vertex, last vertex), excluding those
  // exactly at a vertex time (those are end samples).
  std::vector<ImuSample> expected;
  for (const ImuSample& s : imu) {
    if (s.t_ns <= vertex_times.front() || s.t_ns >= vertex_times.back()) continue;
    if (std::binary_search(vertex_times.begin(), vertex_times.end(), s.t_ns)) continue;
    expected.push_back(s);
  }
  REQUIRE(interior.size() == expected.size());
  for (std::size_t i = 0; i < expected.size(); ++i) {
    INFO("sample " << i);
    REQUIRE(SameSample(interior[i], expected[i]));
  }
  const mapstore::ConsistencyReport report = mapstore::CheckMapConsistency(map);
  INFO(report.FullReport());
  CHECK(report.ok());
}

TEST_CASE("map builder: a last edge without its end sample is held at Finish", "[mapping]") {
  const SensorRig rig = sim::MakeEurocRig(false);
  const std::vector<ImuSample> imu = MakeImu(1'000'000'000, 100);  // up to 1.495 s
  MapBuilder builder(rig, MapBuilderOptions(), 3);
  for (const ImuSample& s : imu) builder.AddImu(s);
  CHECK(builder.AddFrame(StateAt(1'200'000'000), {}));
  CHECK(builder.AddFrame(StateAt(1'600'000'000), {}));  // after the last sample
  CHECK(builder.TakeDelta().edges.empty());             // pending
  const mapstore::VIMap& map = builder.Finish();
  CHECK(builder.stats().imu_edges == 1);
  CHECK(builder.stats().imu_edges_held == 1);
  CHECK(mapstore::CheckMapConsistency(map).ok());
}

TEST_CASE("map builder: room session driven by ground truth", "[mapping][sim]") {
  const fs::path dataset = RoomSession();
  if (dataset.empty()) {
    VILMA_SKIP("vilma-sim not built (" << VILMA_BINARY_DIR << "/bin/vilma-sim)");
  }
  GtBuild a = BuildFromGroundTruth(dataset);
  const MapBuilderStats& s = a.stats;
  INFO(s.FullReport());
  CHECK(s.vertices >= 195);  // 20 s at 10 Hz (the filter-free run has a pose from the start)
  CHECK(s.imu_edges == s.vertices - 1);
  CHECK(s.imu_edges_held == 0);
  CHECK(s.landmarks_good >= 300);

  const mapstore::MissionId mission = a.map.mission_ids().at(0);
  const sim::World world = sim::MakePresetWorld("room", 1);
  std::vector<double> distances;
  for (const mapstore::LandmarkId& id : a.map.landmark_ids(mission)) {
    if (a.map.landmark(id).quality != mapstore::LandmarkQuality::kGood) continue;
    distances.push_back(DistanceToWorld(world, a.map.LandmarkPosition_M(id)));
  }
  const double median = Median(distances);
  std::sort(distances.begin(), distances.end());
  const double p90 = distances[distances.size() * 9 / 10];
  WARN("ground truth: " << distances.size() << " good landmarks, median distance to the world "
                        << median * 100 << " cm, p90 " << p90 * 100 << " cm");
  CHECK(median < 0.02);

  // Consistency, the delta stream, save / load, determinism.
  const mapstore::ConsistencyReport report = mapstore::CheckMapConsistency(a.map);
  INFO(report.FullReport());
  CHECK(report.ok());
  mapstore::VIMap from_deltas;
  for (const auto& d : a.deltas) {
    mapstore::ApplyMissionDelta(
        mapstore::ParseMissionDelta(mapstore::SerializeMissionDelta(d), "delta"), &from_deltas);
  }
  CHECK(from_deltas.num_vertices() == a.map.num_vertices());
  CHECK(from_deltas.num_edges() == a.map.num_edges());
  CHECK(from_deltas.num_landmarks() == a.map.num_landmarks());
  CHECK(mapstore::CheckMapConsistency(from_deltas).ok());

  const fs::path dir_a = dataset / "map_a";
  const fs::path dir_b = dataset / "map_b";
  const fs::path dir_c = dataset / "map_c";
  mapstore::SaveMap(a.map, dir_a.string());
  mapstore::SaveMap(from_deltas, dir_c.string());
  const mapstore::VIMap loaded = mapstore::LoadMap(dir_a.string());
  CHECK(loaded.num_landmarks() == a.map.num_landmarks());
  CHECK(loaded.num_vertices() == a.map.num_vertices());
  CHECK(mapstore::CheckMapConsistency(loaded).ok());
  GtBuild b = BuildFromGroundTruth(dataset);
  mapstore::SaveMap(b.map, dir_b.string());
  const auto files_a = FolderContents(dir_a);
  CHECK(files_a.size() >= 4);
  CHECK(files_a == FolderContents(dir_b));  // same input -> byte-identical map
  CHECK(files_a == FolderContents(dir_c));  // the delta stream rebuilds the same map
  for (const fs::path& d : {dir_a, dir_b, dir_c}) fs::remove_all(d);
}

TEST_CASE("map builder: track refinement puts the room's landmarks closer to the surfaces",
          "[mapping][sim]") {
  const fs::path dataset = RoomSession();
  if (dataset.empty()) {
    VILMA_SKIP("vilma-sim not built (" << VILMA_BINARY_DIR << "/bin/vilma-sim)");
  }
  const sim::World world = sim::MakePresetWorld("room", 1);
  const auto median_distance = [&](const mapstore::VIMap& map) {
    const mapstore::MissionId mission = map.mission_ids().at(0);
    std::vector<double> distances;
    for (const mapstore::LandmarkId& id : map.landmark_ids(mission)) {
      if (map.landmark(id).quality != mapstore::LandmarkQuality::kGood) continue;
      distances.push_back(DistanceToWorld(world, map.LandmarkPosition_M(id)));
    }
    return Median(distances);
  };
  MapBuilderOptions plain_options;
  plain_options.track_refinement.method = "none";  // the detector's keypoints
  const GtBuild plain = BuildFromGroundTruth(dataset, plain_options);
  MapBuilderOptions options;
  options.track_refinement.method = "affine";
  const GtBuild refined = BuildFromGroundTruth(dataset, options);
  const double d_plain = median_distance(plain.map);
  const double d_refined = median_distance(refined.map);
  INFO(refined.stats.FullReport());
  WARN("ground truth poses, median landmark distance to the world: detector keypoints "
       << d_plain * 100 << " cm (" << plain.stats.landmarks_good << " good), affine track "
       << "refinement " << d_refined * 100 << " cm (" << refined.stats.landmarks_good
       << " good; " << refined.stats.refined_keypoints << " observations aligned, "
       << refined.stats.refinement_splits << " splits, " << refined.stats.refinement_kept
       << " failed alignments kept, on_failure " << options.track_refinement.on_failure << ")");
  CHECK(refined.stats.refined_keypoints > refined.stats.tracked_keypoints / 2);
  CHECK(refined.stats.refinement_splits < refined.stats.tracked_keypoints / 5);
  CHECK(refined.stats.landmarks_good >= 300);
  // Every failed alignment is counted by its reason; the aligned ones moved the detector's
  // keypoints by less than max_shift_px on average (more: the c0 chain would not hold).
  int64_t failed = 0;
  for (const int64_t n : refined.stats.refinement_failed_by_status) failed += n;
  CHECK(failed == refined.stats.refinement_splits + refined.stats.refinement_kept);
  CHECK(refined.stats.refinement_failed_by_status[0] == 0);  // kOk is no failure
  const double mean_shift =
      refined.stats.refinement_shift_sum_px / static_cast<double>(refined.stats.refined_keypoints);
  CHECK(mean_shift > 0.0);
  CHECK(mean_shift < options.track_refinement.max_shift_px);
  CHECK_THAT(refined.stats.FullReport(), Catch::Contains("mean |aligned - detected|"));
  CHECK(d_refined < 0.5 * d_plain);  // measured 0.33 against 1.54 cm (2026-11-27)
  CHECK(mapstore::CheckMapConsistency(refined.map).ok());
  // The delta stream carries the refined keypoints and split track ids like any others.
  mapstore::VIMap from_deltas;
  for (const auto& d : refined.deltas) mapstore::ApplyMissionDelta(d, &from_deltas);
  CHECK(from_deltas.num_landmarks() == refined.map.num_landmarks());
  CHECK(mapstore::CheckMapConsistency(from_deltas).ok());
}

TEST_CASE("map builder: room session driven by the VIO (vilma vio --save-map)", "[mapping][sim]") {
  const fs::path vilma = fs::path(VILMA_BINARY_DIR) / "bin" / "vilma";
  const fs::path dataset = RoomSession();
  if (dataset.empty() || !fs::exists(vilma)) {
    VILMA_SKIP("vilma-sim or vilma not built in " << VILMA_BINARY_DIR << "/bin");
  }
  const fs::path traj = dataset / "vio.txt";
  const fs::path map_dir = dataset / "vio_map";
  const std::string cmd = vilma.string() + " vio " + dataset.string() + " --out " + traj.string() +
                          " --save-map " + map_dir.string() + " > " +
                          (dataset / "vio.log").string() + " 2>&1";
  REQUIRE(std::system(cmd.c_str()) == 0);
  const mapstore::VIMap map = mapstore::LoadMap(map_dir.string());
  {
    const mapstore::ConsistencyReport report = mapstore::CheckMapConsistency(map);
    INFO(report.FullReport());
    CHECK(report.ok());
  }
  // Align M to the simulator's world W: posyaw alignment of the VIO trajectory to ground truth.
  const AslDataset ds = AslDataset::Open(dataset.string());
  Trajectory gt;
  for (const GroundTruthState& g : ds.ground_truth())
    gt.Add(g.t_ns, Transformation(g.q_W_I, g.p_W_I));
  const Trajectory est = ReadTrajectoryFile(traj.string());
  const Association assoc = AssociateTrajectories(gt, est, AssociationOptions());
  REQUIRE(assoc.size() > 100);
  std::vector<Eigen::Vector3d> p_G, p_E;
  for (std::size_t i = 0; i < assoc.size(); ++i) {
    p_G.push_back(gt.T_W_B[assoc.gt_index[i]].translation());
    p_E.push_back(est.T_W_B[assoc.est_index[i]].translation());
  }
  const Alignment align = AlignPositionYaw(p_G, p_E);
  const sim::World world = sim::MakePresetWorld("room", 1);
  const mapstore::MissionId mission = map.mission_ids().at(0);
  std::vector<double> distances;
  for (const mapstore::LandmarkId& id : map.landmark_ids(mission)) {
    if (map.landmark(id).quality != mapstore::LandmarkQuality::kGood) continue;
    distances.push_back(DistanceToWorld(world, align.T_G_E * map.LandmarkPosition_M(id)));
  }
  REQUIRE(distances.size() >= 200);
  const double median = Median(distances);
  WARN("VIO: " << distances.size()
               << " good landmarks, median distance to the world (after "
                  "posyaw alignment) "
               << median * 100 << " cm");
  CHECK(median < 0.05);  // issue 6's acceptance: within 5 cm (median) of the true world
  fs::remove_all(map_dir);
  fs::remove(traj);
}

namespace vilma::mapping {
namespace {

uintmax_t FolderBytes(const fs::path& root) {
  uintmax_t bytes = 0;
  for (const auto& e : fs::recursive_directory_iterator(root)) {
    if (e.is_regular_file()) bytes += e.file_size();
  }
  return bytes;
}

// Good landmark positions in M, sorted (ids differ when short tracks get none).
std::vector<std::array<double, 3>> GoodPositions(const mapstore::VIMap& map) {
  std::vector<std::array<double, 3>> p;
  const mapstore::MissionId mission = map.mission_ids().at(0);
  for (const mapstore::LandmarkId& id : map.landmark_ids(mission)) {
    if (map.landmark(id).quality != mapstore::LandmarkQuality::kGood) continue;
    const Eigen::Vector3d p_M = map.LandmarkPosition_M(id);
    p.push_back({p_M.x(), p_M.y(), p_M.z()});
  }
  std::sort(p.begin(), p.end());
  return p;
}

TEST_CASE("map builder: compact maps keep every good landmark and drop free keypoints",
          "[mapping][sim]") {
  const fs::path dataset = RoomSession();
  if (dataset.empty()) {
    VILMA_SKIP("vilma-sim not built (" << VILMA_BINARY_DIR << "/bin/vilma-sim)");
  }
  std::map<std::string, GtBuild> builds;
  std::map<std::string, uintmax_t> bytes;
  for (const std::string level : {"none", "tracks", "good"}) {
    MapBuilderOptions options;
    options.compact = level;
    builds[level] = BuildFromGroundTruth(dataset, options);
    const fs::path dir = dataset / ("map_" + level);
    mapstore::SaveMap(builds[level].map, dir.string());
    bytes[level] = FolderBytes(dir);
    fs::remove_all(dir);
  }
  WARN("map of 20 s: " << bytes["none"] / 1e6 << " MB (none), " << bytes["tracks"] / 1e6
                       << " MB (tracks), " << bytes["good"] / 1e6 << " MB (good)");
  CHECK(MapBuilderOptions().compact == "good");
  CHECK(bytes["tracks"] * 2 < bytes["none"]);
  CHECK(bytes["good"] * 5 < bytes["none"]);
  const int min_observers = MapBuilderOptions().landmark_quality.min_observers;
  for (const std::string level : {"tracks", "good"}) {
    const GtBuild& compact = builds[level];
    INFO(level << ": " << compact.stats.FullReport());
    CHECK(compact.stats.short_tracks > 0);
    CHECK(compact.stats.keypoints_dropped > 0);
    CHECK(compact.stats.landmarks_good == builds["none"].stats.landmarks_good);
    CHECK(GoodPositions(compact.map) == GoodPositions(builds["none"].map));
    CHECK(mapstore::CheckMapConsistency(compact.map).ok());
    const mapstore::MissionId mission = compact.map.mission_ids().at(0);
    std::size_t free_keypoints = 0, short_landmarks = 0, bad = 0;
    for (const mapstore::VertexId& v : compact.map.vertex_ids(mission)) {
      for (const mapstore::VisualFrame& f : compact.map.vertex(v).frames) {
        for (const mapstore::LandmarkId& l : f.landmark_ids) free_keypoints += l.IsValid() ? 0 : 1;
      }
    }
    for (const mapstore::LandmarkId& l : compact.map.landmark_ids(mission)) {
      const mapstore::Landmark& landmark = compact.map.landmark(l);
      short_landmarks +=
          landmark.observations.size() < static_cast<std::size_t>(min_observers) ? 1 : 0;
      bad += landmark.quality != mapstore::LandmarkQuality::kGood ? 1 : 0;
    }
    CHECK(free_keypoints == 0);
    CHECK(short_landmarks == 0);
    if (level == "good") {
      CHECK(bad == 0);
    } else {
      CHECK(bad > 0);
    }
  }
  MapBuilderOptions wrong;
  wrong.compact = "yes";
  CHECK_THAT(wrong.Validate(), Catch::Contains("compact: expected"));
}

}  // namespace
}  // namespace vilma::mapping
