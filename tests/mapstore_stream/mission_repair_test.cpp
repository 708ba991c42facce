// Assembling streamed missions from any sender (mapstore/mission_repair.h): a consistent stream
// is assembled exactly as before; each kind of forged or inconsistent element is refused or
// repaired, counted, and the map is consistent with every vertex that could be kept. The last
// case sends such a stream through MapStoreServer.
#include "vilma/mapstore/mission_repair.h"

#include <catch2/catch.hpp>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <string>
#include <vector>

#include "mapstore/synthetic_map.h"  // RequireMapsEqual
#include "vilma/mapstore/consistency.h"
#include "vilma/mapstore/stream/map_store_server.h"
#include "vilma/mapstore/stream/mission_stream_sender.h"
#include "vilma/mapstore/stream/synthetic_mission.h"

using namespace vilma::mapstore;
using vilma::mapstore::testing::RequireMapsEqual;

namespace {

SyntheticMissionOptions SmallMission() {
  SyntheticMissionOptions mo;
  mo.vertices = 6;
  mo.vertices_per_delta = 2;
  mo.keypoints_per_frame = 10;
  mo.landmarks_per_vertex = 3;
  mo.imu_samples_per_edge = 3;
  return mo;
}

VIMap Assemble(const std::vector<MissionDelta>& deltas, MissionRepairReport* report) {
  const MissionId id = deltas.at(0).mission.id;
  VIMap map;
  Mission header;
  header.id = id;
  header.name = "header only";
  map.AddMission(header);
  for (const MissionDelta& d : deltas) ApplyStreamedDelta(d, id, &map, report);
  RepairStreamedMission(id, &map, report);
  return map;
}

Id MakeId(const char* hex) {
  Id id;
  REQUIRE(Id::FromHex(hex, &id));
  return id;
}

// The IMU edge of the deltas that leaves `from` (the synthetic chain has one per vertex).
Edge* ImuEdgeFrom(std::vector<MissionDelta>* deltas, const VertexId& from) {
  for (MissionDelta& d : *deltas) {
    for (Edge& e : d.edges) {
      if (e.type == EdgeType::kImu && e.from == from) return &e;
    }
  }
  return nullptr;
}

std::size_t TotalVertices(const VIMap& map) {
  std::size_t n = 0;
  for (const MissionId& m : map.mission_ids()) n += map.vertex_ids(m).size();
  return n;
}

}  // namespace

TEST_CASE("a consistent stream is assembled as ApplyDeltas assembles it, with no repairs", "[mapstore_stream]") {
  const std::vector<MissionDelta> deltas = MakeSyntheticMissionDeltas(SmallMission());
  MissionRepairReport report;
  const VIMap map = Assemble(deltas, &report);
  INFO(report.Summary());
  CHECK(report.Total() == 0);
  CHECK(report.Summary() == "no repairs");
  RequireMapsEqual(ApplyDeltas(deltas), map);
}

TEST_CASE("forged elements are refused or repaired, counted, and the map is consistent", "[mapstore_stream]") {
  std::vector<MissionDelta> deltas = MakeSyntheticMissionDeltas(SmallMission());
  const MissionId id = deltas[0].mission.id;
  const VIMap expected = ApplyDeltas(deltas);
  const std::vector<VertexId> chain = expected.VertexChain(id);
  REQUIRE(chain.size() == 6);
  const Id never_sent = MakeId("000000000000000000000000000000ff");
  const Id another_mission = MakeId("00000000000000000000000000000abc");
  MissionDelta& last = deltas.back();
  REQUIRE_FALSE(last.landmarks.empty());
  bool same_as_expected = true;  // the forged element is dropped without a trace
  std::function<void(const VIMap&, const MissionRepairReport&)> expect;

  SECTION("an IMU edge to a vertex never sent") {
    Edge e = *ImuEdgeFrom(&deltas, chain[0]);
    e.id = MakeId("000000000000000000000000000000e1");
    e.from = chain[5];  // the last vertex: no outgoing edge yet
    e.to = never_sent;
    last.edges.push_back(e);
    expect = [&](const VIMap&, const MissionRepairReport& report) {
      CHECK(report.edges_dropped == 1);
    };
  }
  SECTION("an edge from a vertex never sent") {
    Edge e = *ImuEdgeFrom(&deltas, chain[0]);
    e.id = MakeId("000000000000000000000000000000e2");
    e.from = never_sent;
    last.edges.push_back(e);
    expect = [&](const VIMap&, const MissionRepairReport& report) {
      CHECK(report.edges_refused == 1);
    };
  }
  SECTION("a landmark stored in a vertex never sent") {
    Landmark l = last.landmarks[0];
    l.id = MakeId("000000000000000000000000000000f1");
    l.store_vertex_id = never_sent;
    last.landmarks.push_back(l);
    expect = [&](const VIMap&, const MissionRepairReport& report) {
      CHECK(report.landmarks_refused == 1);
    };
  }
  SECTION("a vertex of another mission and a header of another mission") {
    Vertex v = last.vertices[0];
    v.id = MakeId("000000000000000000000000000000d1");
    v.mission_id = another_mission;
    last.vertices.push_back(v);
    MissionDelta other = last;
    other.mission.id = another_mission;
    other.vertices.clear();
    other.edges.clear();
    other.landmarks.clear();
    deltas.push_back(other);
    expect = [&](const VIMap&, const MissionRepairReport& report) {
      CHECK(report.vertices_refused == 1);
      CHECK(report.headers_refused == 1);
    };
  }
  SECTION("a landmark with the id of a vertex") {
    Landmark l = last.landmarks[0];
    l.id = chain[2];
    last.landmarks.push_back(l);
    expect = [&](const VIMap&, const MissionRepairReport& report) {
      CHECK(report.landmarks_refused == 1);
    };
  }
  SECTION("a landmark observation of a vertex never sent, and one of a keypoint that does not refer back") {
    Landmark& l = last.landmarks[0];
    REQUIRE_FALSE(l.observations.empty());
    LandmarkObservation o = l.observations[0];
    o.vertex_id = never_sent;
    l.observations.push_back(o);
    o = l.observations[0];
    o.keypoint = 9;  // keypoints beyond landmarks_per_vertex have no landmark
    l.observations.push_back(o);
    expect = [&](const VIMap&, const MissionRepairReport& report) {
      CHECK(report.observations_dropped == 2);
    };
  }
  SECTION("a landmark whose every observation is forged") {
    Landmark l = last.landmarks[0];
    l.id = MakeId("000000000000000000000000000000f2");
    for (LandmarkObservation& o : l.observations) o.keypoint = 9;
    last.landmarks.push_back(l);
    expect = [&](const VIMap&, const MissionRepairReport& report) {
      CHECK(report.landmarks_dropped == 1);
    };
  }
  SECTION("a second IMU edge out of a vertex") {
    Edge e = *ImuEdgeFrom(&deltas, chain[1]);  // a copy under a new id: a second edge out and in
    e.id = MakeId("000000000000000000000000000000e3");
    last.edges.push_back(e);
    expect = [&](const VIMap&, const MissionRepairReport& report) {
      CHECK(report.edges_dropped == 1);
    };
  }
  SECTION("a root that is not one of the mission's vertices") {
    for (MissionDelta& d : deltas) d.mission.root_vertex_id = never_sent;
    expect = [&](const VIMap& map, const MissionRepairReport& report) {
      CHECK(report.root_replaced == 1);
      CHECK(map.mission(id).root_vertex_id == chain[0]);
    };
    same_as_expected = false;
  }
  SECTION("a frame whose keypoint arrays disagree loses its keypoints and their observations") {
    Vertex& v = deltas[1].vertices[0];
    REQUIRE_FALSE(v.frames.empty());
    v.frames[0].track_ids.pop_back();
    expect = [&](const VIMap& map, const MissionRepairReport& report) {
      CHECK(report.frames_cleared == 1);
      CHECK(map.vertex(v.id).frames[0].keypoints.empty());
      CHECK(report.observations_dropped + report.landmarks_dropped > 0);
    };
    same_as_expected = false;
  }
  SECTION("IMU edges whose samples are unsorted or that go back in time split the chain; no vertex is lost") {
    Edge* unsorted = ImuEdgeFrom(&deltas, chain[1]);
    REQUIRE(unsorted != nullptr);
    REQUIRE(unsorted->imu_samples.size() >= 2);
    std::swap(unsorted->imu_samples[0], unsorted->imu_samples[1]);
    Edge* backwards = ImuEdgeFrom(&deltas, chain[3]);
    REQUIRE(backwards != nullptr);
    std::swap(backwards->from, backwards->to);
    expect = [&](const VIMap& map, const MissionRepairReport& report) {
      CHECK(report.edges_dropped == 2);
      CHECK(report.missions_split_off == 2);
      REQUIRE(map.mission_ids().size() == 3);
      CHECK(map.mission_ids()[0] == id);
      CHECK(map.VertexChain(id) == std::vector<VertexId>{chain[0], chain[1]});
      CHECK(map.mission(map.mission_ids()[1]).name == "synthetic (part 2)");
      CHECK(map.VertexChain(map.mission_ids()[1]) == std::vector<VertexId>{chain[2], chain[3]});
      CHECK(map.VertexChain(map.mission_ids()[2]) == std::vector<VertexId>{chain[4], chain[5]});
      CHECK(TotalVertices(map) == 6);
      CHECK(map.num_landmarks() == expected.num_landmarks());
      // Deterministic: the same stream gives the same mission ids.
      MissionRepairReport again;
      const VIMap map2 = Assemble(deltas, &again);
      CHECK(map2.mission_ids() == map.mission_ids());
    };
    same_as_expected = false;
  }
  MissionRepairReport report;
  const VIMap map = Assemble(deltas, &report);
  INFO(report.Summary());
  INFO(CheckMapConsistency(map).FullReport());
  CHECK(CheckMapConsistency(map).ok());
  CHECK(report.Total() > 0);
  CHECK(report.Summary() != "no repairs");
  CHECK_FALSE(report.examples.empty());
  REQUIRE(expect);
  expect(map, report);
  if (same_as_expected) RequireMapsEqual(expected, map);
}

TEST_CASE("mapstored finalizes a forged stream into a consistent map: unreadable deltas skipped, chain pieces kept",
          "[mapstore_stream]") {
  std::vector<MissionDelta> deltas = MakeSyntheticMissionDeltas(SmallMission());
  const MissionId id = deltas[0].mission.id;
  const std::vector<VertexId> chain = ApplyDeltas(deltas).VertexChain(id);
  REQUIRE(chain.size() == 6);
  Edge* edge = ImuEdgeFrom(&deltas, chain[2]);
  REQUIRE(edge != nullptr);
  edge->imu_samples.clear();  // the chain breaks after vertex 2

  const std::string dir = "/tmp/vilma_mission_repair_test_" + std::to_string(::getpid());
  REQUIRE(std::system(("rm -rf '" + dir + "'").c_str()) == 0);
  MapStoreServerOptions so;
  so.root = dir;
  std::vector<std::string> log;
  MapStoreServer server(so, [](const vilma::mission_ack_t&) {}, [&](const std::string& line) { log.push_back(line); });
  server.Start();
  MissionStreamSenderOptions sender_options;
  sender_options.retransmit_timeout_s = 0.002;
  sender_options.max_retransmit_timeout_s = 0.01;
  MissionStreamSender sender(id, "forged", sender_options, [&](const vilma::mission_chunk_t& c) { server.OnChunk(c); });
  REQUIRE(sender.Send(deltas[0]));
  REQUIRE(sender.SendSerialized("these bytes are not a mission delta"));
  for (std::size_t i = 1; i < deltas.size(); ++i) REQUIRE(sender.Send(deltas[i]));
  sender.End();
  server.Flush();
  // Before: the unreadable delta failed the finalization, retried every 5 s for ever.
  CHECK(server.counters().finalize_errors == 0);
  REQUIRE(server.counters().missions_completed == 1);
  CHECK(server.counters().stream_repairs == 3);  // 1 unreadable delta, 1 edge, 1 split

  const VIMap loaded = LoadMap(server.MissionFolder(id));
  INFO(CheckMapConsistency(loaded).FullReport());
  CHECK(CheckMapConsistency(loaded).ok());
  CHECK(TotalVertices(loaded) == 6);
  CHECK(loaded.mission_ids().size() == 2);
  CHECK(loaded.VertexChain(id).size() == 3);
  for (const MissionId& m : loaded.mission_ids()) CHECK(loaded.mission(m).complete);
  bool logged = false;
  for (const std::string& line : log) {
    logged |= line.find("the stream needed repairs: 1 unreadable delta(s) skipped, 1 edge(s) removed, "
                        "1 chain piece(s) saved as mission(s) of their own") != std::string::npos;
  }
  CHECK(logged);
  REQUIRE(std::system(("rm -rf '" + dir + "'").c_str()) == 0);
}

// What the repair costs a consistent mission at finalization (docs/mapstore.md): applying the
// deltas as before (ApplyMissionDelta) against ApplyStreamedDelta + RepairStreamedMission, on
// the mission of the stream benchmark (2,000 vertices, 100 keypoints each, 20,000 landmarks).
// Run: build/bin/vilma_mapstore_stream_tests "mission repair benchmark*"
TEST_CASE("mission repair benchmark: the cost for a consistent mission", "[.benchmark][mapstore_stream]") {
  using Clock = std::chrono::steady_clock;
  SyntheticMissionOptions mo;
  mo.vertices = 2000;
  mo.keypoints_per_frame = 100;
  mo.landmarks_per_vertex = 10;
  const std::vector<MissionDelta> deltas = MakeSyntheticMissionDeltas(mo);
  const MissionId id = deltas[0].mission.id;
  std::vector<double> plain_s, streamed_s, repair_s;
  for (int round = 0; round < 5; ++round) {
    const auto t0 = Clock::now();
    VIMap plain;
    for (const MissionDelta& d : deltas) ApplyMissionDelta(d, &plain);
    const auto t1 = Clock::now();
    VIMap streamed;
    Mission header;
    header.id = id;
    streamed.AddMission(header);
    MissionRepairReport report;
    for (const MissionDelta& d : deltas) ApplyStreamedDelta(d, id, &streamed, &report);
    const auto t2 = Clock::now();
    RepairStreamedMission(id, &streamed, &report);
    const auto t3 = Clock::now();
    REQUIRE(report.Total() == 0);
    plain_s.push_back(std::chrono::duration<double>(t1 - t0).count());
    streamed_s.push_back(std::chrono::duration<double>(t2 - t1).count());
    repair_s.push_back(std::chrono::duration<double>(t3 - t2).count());
  }
  const auto median = [](std::vector<double> v) {
    std::sort(v.begin(), v.end());
    return v[v.size() / 2];
  };
  std::printf("2000 vertices, median of 5: ApplyMissionDelta %.3f s | ApplyStreamedDelta %.3f s + "
              "RepairStreamedMission %.3f s\n",
              median(plain_s), median(streamed_s), median(repair_s));
}
