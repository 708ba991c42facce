// keyframe_heuristic / kfh in the console, on a daemon-built map: fewer vertices, the kept ones
// unchanged, IMU samples conserved, map consistent; bad flags and missions change nothing.
#include <catch2/catch.hpp>

#include "console_plugins/test_maps.h"
#include "vilma/mapping/keyframing/keyframe_heuristic.h"
#include "vilma/mapstore/consistency.h"

namespace vilma::console {
namespace {

using Fixture = test::ConsoleFixture;

TEST_CASE("kfh on a daemon map keeps every 10th vertex and conserves the IMU samples") {
  const auto& maps = test::TestMaps();
  Fixture f;
  REQUIRE(f.Run("load " + maps.session0_map).ok());
  const mapstore::VIMap before = f.map().Clone();
  const auto mission = before.mission_ids().at(0);
  const std::size_t samples = mapping::DistinctImuSamples(before, mission);

  REQUIRE(f.Run("kfh").ok());
  CHECK_THAT(f.out.str(), Catch::Contains("IMU samples " + std::to_string(samples) + " -> " +
                                          std::to_string(samples)));
  const mapstore::VIMap& after = f.map();
  CHECK(mapstore::CheckMapConsistency(after).ok());
  CHECK(mapping::DistinctImuSamples(after, mission) == samples);
  // A 10 s room session at 10 Hz: at least every 10th vertex, first and last.
  const std::size_t n = before.vertex_ids(mission).size();
  CHECK(after.vertex_ids(mission).size() >= (n - 1) / 10 + 1);
  CHECK(after.vertex_ids(mission).size() < n / 2);
  // The kept vertices are the old ones, untouched (so their ATE is unchanged).
  for (const auto& id : after.vertex_ids(mission)) {
    REQUIRE(before.HasVertex(id));
    CHECK(after.vertex(id).T_M_I.translation() == before.vertex(id).T_M_I.translation());
    CHECK(after.vertex(id).t_ns == before.vertex(id).t_ns);
  }
  CHECK(after.VertexChain(mission).front() == before.VertexChain(mission).front());
  CHECK(after.VertexChain(mission).back() == before.VertexChain(mission).back());
  CHECK(after.num_landmarks() < before.num_landmarks());
}

TEST_CASE("kfh flags map onto the options, bad values and missions leave the map unchanged") {
  const auto& maps = test::TestMaps();
  Fixture f;
  REQUIRE(f.Run("load " + maps.session0_map).ok());
  const std::size_t n = f.map().num_vertices();

  CommandResult r = f.Run("kfh --kf_every_nth_vertex=0");
  CHECK(r.outcome == CommandOutcome::kFailed);
  CHECK_THAT(r.message, Catch::Contains("kf_every_nth_vertex"));
  r = f.Run("kfh --kf_distance_threshold_m=far");
  CHECK(r.outcome == CommandOutcome::kFailed);
  CHECK_THAT(r.message, Catch::Contains("kf_distance_threshold_m"));
  r = f.Run("kfh --map_mission=ffffffffnotamission");
  CHECK(r.outcome == CommandOutcome::kFailed);
  CHECK(f.map().num_vertices() == n);

  // `set` changes the default for the rest of the session.
  REQUIRE(f.Run("set kf_every_nth_vertex 3").ok());
  REQUIRE(f.Run("keyframe_heuristic --mission=" + f.map().mission_ids()[0].Hex()).ok());
  CHECK(f.map().num_vertices() >= (n - 1) / 3 + 1);
  CHECK(f.map().num_vertices() < n / 2);
  CHECK(mapstore::CheckMapConsistency(f.map()).ok());
}

}  // namespace
}  // namespace vilma::console
