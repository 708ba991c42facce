// loopclosure_all_missions / lc on a daemon-built map: loops within the mission, landmarks
// merged, edges added, consistent, deterministic; bad input changes nothing.
#include <catch2/catch.hpp>

#include "console_plugins/test_maps.h"
#include "vilma/mapstore/consistency.h"

namespace vilma::console {
namespace {

using Fixture = test::ConsoleFixture;

std::size_t LoopEdges(const mapstore::VIMap& map) {
  std::size_t n = 0;
  for (const auto& m : map.mission_ids()) {
    for (const auto& id : map.edge_ids(m)) {
      n += map.edge(id).type == mapstore::EdgeType::kLoopClosure;
    }
  }
  return n;
}

TEST_CASE("lc within a mission merges re-observed landmarks and adds loop-closure edges") {
  const auto& maps = test::TestMaps();
  std::string reports[2];
  std::size_t landmarks_after[2] = {0, 0};
  for (int run = 0; run < 2; ++run) {
    Fixture f;
    REQUIRE(f.Run("load " + maps.session0_map).ok());
    const std::size_t landmarks = f.map().num_landmarks();
    f.out.str("");
    // A 10 s session: places seen again after 3 s count.
    REQUIRE(f.Run("lc --lc_min_time_gap_s=3").ok());
    reports[run] = f.out.str();
    INFO(reports[run]);
    CHECK(LoopEdges(f.map()) > 0);
    CHECK(f.map().num_landmarks() < landmarks);
    CHECK(mapstore::CheckMapConsistency(f.map()).ok());
    landmarks_after[run] = f.map().num_landmarks();
    // A loop edge joins two vertices at least the gap apart.
    for (const auto& id : f.map().edge_ids(f.map().mission_ids()[0])) {
      const auto& e = f.map().edge(id);
      if (e.type != mapstore::EdgeType::kLoopClosure) continue;
      CHECK(std::llabs(f.map().vertex(e.from).t_ns - f.map().vertex(e.to).t_ns) > 2'900'000'000LL);
    }
  }
  CHECK(landmarks_after[0] == landmarks_after[1]);
  CHECK(reports[0].substr(0, reports[0].find("edges;")) ==
        reports[1].substr(0, reports[1].find("edges;")));
}

TEST_CASE("lc: a gap longer than the session finds nothing; bad input changes nothing") {
  const auto& maps = test::TestMaps();
  Fixture f;
  REQUIRE(f.Run("load " + maps.session0_map).ok());
  const std::size_t landmarks = f.map().num_landmarks();
  REQUIRE(f.Run("lc --lc_min_time_gap_s=60").ok());
  CHECK(LoopEdges(f.map()) == 0);
  CHECK(f.map().num_landmarks() == landmarks);
  CommandResult r = f.Run("lc --lc_min_inliers=2");
  CHECK(r.outcome == CommandOutcome::kFailed);
  CHECK_THAT(r.message, Catch::Contains("lc_min_inliers"));
  REQUIRE(f.Run("rlq").ok());
  r = f.Run("lc");
  CHECK(r.outcome == CommandOutcome::kFailed);
  CHECK_THAT(r.message, Catch::Contains("no good landmarks"));
  CHECK(f.map().num_landmarks() == landmarks);
}

}  // namespace
}  // namespace vilma::console
