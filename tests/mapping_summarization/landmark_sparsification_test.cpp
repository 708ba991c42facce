// landmark_sparsify on synthetic maps: the budget, coverage of every keyframe by the ILP (where
// the baselines leave keyframes bare), partitions, determinism, and a map left unchanged when
// the options are wrong.
#include "vilma/mapping/summarization/landmark_sparsification.h"

#include <algorithm>
#include <catch2/catch.hpp>

#include "mapstore/synthetic_map.h"
#include "vilma/mapstore/consistency.h"

namespace vilma::mapping {
namespace {

using mapstore::LandmarkId;
using mapstore::LandmarkQuality;
using mapstore::VIMap;

// Two missions of 30 vertices, 4 landmarks stored per vertex, each seen by 3 consecutive
// vertices (the last vertices' landmarks by fewer); every 10th landmark bad, the rest good.
VIMap GoodMap(int* num_good) {
  mapstore::testing::SyntheticMapOptions o;
  o.vertices_per_mission = 30;
  o.extra_edges = false;
  VIMap map = mapstore::testing::MakeSyntheticMap(o);
  int i = 0;
  *num_good = 0;
  for (const auto& m : map.mission_ids()) {
    for (const LandmarkId& l : map.landmark_ids(m)) {
      const bool good = i++ % 10 != 9;
      map.landmark(l).quality = good ? LandmarkQuality::kGood : LandmarkQuality::kBad;
      *num_good += good ? 1 : 0;
    }
  }
  return map;
}

std::vector<LandmarkId> Landmarks(const VIMap& map) {
  std::vector<LandmarkId> ids;
  for (const auto& m : map.mission_ids()) {
    for (const LandmarkId& l : map.landmark_ids(m)) ids.push_back(l);
  }
  return ids;
}

LandmarkSparsificationOptions Options(const std::string& method, int keep) {
  LandmarkSparsificationOptions o;
  o.method = method;
  o.num_landmarks_to_keep = keep;
  o.min_landmarks_per_keyframe = 2;
  return o;
}

TEST_CASE("lsparsify keeps N good landmarks, the ILP covers every keyframe, the baselines do not",
          "[lsparsify]") {
  int good = 0;
  const VIMap original = GoodMap(&good);
  REQUIRE(good > 200);
  std::size_t below_most_observed = 0;
  for (const std::string method : {"ilp", "most_observed", "random"}) {
    VIMap map = original.Clone();
    const LandmarkSparsificationSummary s = SparsifyLandmarks(Options(method, 60), &map);
    INFO(method << ": " << s.FullReport());
    CHECK(s.good_before == static_cast<std::size_t>(good));
    CHECK(s.landmarks_before == original.num_landmarks());
    CHECK(s.landmarks_after == 60);
    CHECK(map.num_landmarks() == 60);
    for (const LandmarkId& l : Landmarks(map)) {
      CHECK(map.landmark(l).quality == LandmarkQuality::kGood);
    }
    CHECK(mapstore::CheckMapConsistency(map).ok());
    CHECK(s.keyframes == original.num_vertices());
    CHECK(s.observations_after < s.observations_before);
    if (method == "ilp") {
      CHECK(s.keyframes_below_minimum == 0);
      REQUIRE(s.partitions.size() == 1);
      CHECK((s.partitions[0].status == "optimal" || s.partitions[0].status == "within gap"));
      CHECK(s.partitions[0].kept == 60);
    }
    if (method == "most_observed") below_most_observed = s.keyframes_below_minimum;
  }
  // Most-observed takes the first 60 of equally observed landmarks: one mission goes bare.
  CHECK(below_most_observed >= 20);
}

TEST_CASE("lsparsify: most_observed keeps the landmarks with the most observations",
          "[lsparsify]") {
  int good = 0;
  VIMap map = GoodMap(&good);
  std::vector<std::size_t> counts;
  for (const LandmarkId& l : Landmarks(map)) {
    if (map.landmark(l).quality == LandmarkQuality::kGood) {
      counts.push_back(map.landmark(l).observations.size());
    }
  }
  std::sort(counts.rbegin(), counts.rend());
  SparsifyLandmarks(Options("most_observed", 100), &map);
  std::size_t min_kept = 1000;
  for (const LandmarkId& l : Landmarks(map)) {
    min_kept = std::min(min_kept, map.landmark(l).observations.size());
  }
  CHECK(min_kept == counts[99]);
}

TEST_CASE("lsparsify: partitions split the budget and still cover every keyframe", "[lsparsify]") {
  int good = 0;
  VIMap map = GoodMap(&good);
  LandmarkSparsificationOptions o = Options("ilp", 80);
  o.partition_max_landmarks = 40;
  const VIMap copy = map.Clone();
  const LandmarkSparsificationSummary s = SparsifyLandmarks(o, &map);
  INFO(s.FullReport());
  CHECK(s.partitions.size() >= 5);
  std::size_t kept = 0, candidates = 0, keyframes = 0;
  for (const auto& p : s.partitions) {
    kept += p.kept;
    candidates += p.candidates;
    keyframes += p.keyframes;
  }
  CHECK(kept == 80);
  CHECK(candidates == static_cast<std::size_t>(good));
  CHECK(keyframes == copy.num_vertices());
  CHECK(s.keyframes_below_minimum == 0);
  CHECK(map.num_landmarks() == 80);
}

TEST_CASE("lsparsify is deterministic, the random baseline follows its seed", "[lsparsify]") {
  int good = 0;
  const VIMap original = GoodMap(&good);
  for (const std::string method : {"ilp", "random"}) {
    VIMap a = original.Clone(), b = original.Clone();
    SparsifyLandmarks(Options(method, 50), &a);
    SparsifyLandmarks(Options(method, 50), &b);
    CHECK(Landmarks(a) == Landmarks(b));
  }
  VIMap a = original.Clone(), b = original.Clone();
  LandmarkSparsificationOptions o = Options("random", 50);
  SparsifyLandmarks(o, &a);
  o.random_seed = 2;
  SparsifyLandmarks(o, &b);
  CHECK(Landmarks(a) != Landmarks(b));
}

TEST_CASE("lsparsify: a budget above the good landmarks removes only the others, keep_fraction",
          "[lsparsify]") {
  int good = 0;
  VIMap map = GoodMap(&good);
  LandmarkSparsificationSummary s = SparsifyLandmarks(Options("ilp", 100000), &map);
  CHECK(s.landmarks_after == static_cast<std::size_t>(good));
  CHECK(map.num_landmarks() == static_cast<std::size_t>(good));
  CHECK(s.keyframes_below_minimum == 0);

  LandmarkSparsificationOptions o = Options("ilp", 0);
  o.keep_fraction = 0.25;
  s = SparsifyLandmarks(o, &map);
  CHECK(s.landmarks_after == static_cast<std::size_t>(std::llround(0.25 * good)));
}

TEST_CASE("lsparsify: invalid options throw and leave the map unchanged", "[lsparsify]") {
  int good = 0;
  VIMap map = GoodMap(&good);
  const std::size_t n = map.num_landmarks();
  CHECK_THROWS_WITH(SparsifyLandmarks(Options("greedy", 10), &map),
                    Catch::Contains("method: expected ilp, most_observed or random"));
  CHECK_THROWS_WITH(SparsifyLandmarks(Options("ilp", 0), &map),
                    Catch::Contains("num_landmarks_to_keep"));
  LandmarkSparsificationOptions o = Options("ilp", 10);
  o.time_limit_s = 0.0;
  CHECK_THROWS_WITH(SparsifyLandmarks(o, &map), Catch::Contains("time_limit_s"));
  CHECK(map.num_landmarks() == n);
}

}  // namespace
}  // namespace vilma::mapping

namespace vilma::mapping {
namespace {

TEST_CASE("lsparsify: an ILP that reaches its time limit fails with a message, map unchanged",
          "[lsparsify]") {
  mapstore::testing::SyntheticMapOptions o;
  o.missions = 1;
  o.vertices_per_mission = 400;
  o.landmarks_per_vertex = 10;
  o.observations_per_landmark = 5;
  o.extra_edges = false;
  VIMap map = mapstore::testing::MakeSyntheticMap(o);
  for (const LandmarkId& l : Landmarks(map)) map.landmark(l).quality = LandmarkQuality::kGood;
  const std::vector<LandmarkId> before = Landmarks(map);
  LandmarkSparsificationOptions options = Options("ilp", 300);
  options.min_landmarks_per_keyframe = 5;
  options.time_limit_s = 0.001;
  options.mip_gap = 0.0;
  CHECK_THROWS_WITH(SparsifyLandmarks(options, &map),
                    Catch::Contains("partition 0 of 1 (4000 landmarks, 400 keyframes)") &&
                        Catch::Contains("time limit") &&
                        Catch::Contains("--lsparsify_time_limit_s") &&
                        Catch::Contains("the map is unchanged"));
  CHECK(Landmarks(map) == before);
  // With time, the same program is solved.
  options.time_limit_s = 60.0;
  options.mip_gap = 0.01;
  const LandmarkSparsificationSummary s = SparsifyLandmarks(options, &map);
  CHECK(s.landmarks_after == 300);
}

}  // namespace
}  // namespace vilma::mapping
