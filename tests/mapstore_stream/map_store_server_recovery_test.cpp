// The mission stream server under failures: a restart that recovers the journal, a full disk, a
// sender that is gone, a crash during a map's save, a shutdown with open missions.
#include "vilma/mapstore/stream/map_store_server.h"

#include <catch2/catch.hpp>
#include <unistd.h>

#include <cerrno>
#include <chrono>
#include <deque>
#include <memory>
#include <thread>

#include "map_store_server_fixture.h"
#include "mapstore/synthetic_map.h"  // RequireMapsEqual

using namespace vilma::mapstore;
using namespace vilma::mapstore::server_test;  // NOLINT: the shared fixture of the server tests
using vilma::mapstore::testing::RequireMapsEqual;

TEST_CASE("a restarted server recovers the journal and the mission completes", "[mapstore_stream]") {
  SyntheticMissionOptions mo;
  mo.vertices = 30;
  mo.keypoints_per_frame = 10;
  mo.landmarks_per_vertex = 2;
  const auto deltas = MakeSyntheticMissionDeltas(mo);
  const MissionId id = deltas[0].mission.id;
  MapStoreServerOptions so;
  so.root = FreshRoot("restart");
  std::deque<vilma::mission_chunk_t> wire;
  std::deque<vilma::mission_ack_t> back;
  MissionStreamSender sender(id, mo.name, FastSender(), [&](const vilma::mission_chunk_t& c) { wire.push_back(c); });
  auto server = std::make_unique<MapStoreServer>(so, [&](const vilma::mission_ack_t& a) { back.push_back(a); }, nullptr);
  server->Start();
  auto pump = [&]() {
    while (!wire.empty()) {
      if (server) server->OnChunk(wire.front());
      wire.pop_front();
    }
    if (server) server->Flush();
    while (!back.empty()) {
      sender.OnAck(back.front());
      back.pop_front();
    }
  };
  for (int i = 0; i < 10; ++i) REQUIRE(sender.Send(deltas[i]));
  pump();
  REQUIRE(sender.acked_seq() == 9);
  // Chunks 10..14 reach the journal but the server dies before fsync/ack (kill -9: the
  // object is simply dropped; the page cache holds the unsynced records).
  for (int i = 10; i < 15; ++i) REQUIRE(sender.Send(deltas[i]));
  while (!wire.empty()) {
    server->OnChunk(wire.front());
    wire.pop_front();
  }
  server.reset();
  for (int i = 15; i < 20; ++i) REQUIRE(sender.Send(deltas[i]));  // lost: nobody listens
  wire.clear();
  server = std::make_unique<MapStoreServer>(so, [&](const vilma::mission_ack_t& a) { back.push_back(a); }, nullptr);
  server->Start();
  CHECK(server->counters().missions_recovered == 1);
  CHECK(server->missions_open() == 1);
  for (std::size_t i = 20; i < deltas.size(); ++i) REQUIRE(sender.Send(deltas[i]));
  REQUIRE(sender.End());
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(10);
  while (!sender.finished() && std::chrono::steady_clock::now() < deadline) {
    pump();
    sender.Poll();
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
  }
  REQUIRE(sender.finished());
  CHECK(server->counters().chunks_duplicate > 0);  // 10..14 were already journaled
  RequireMapsEqual(Expected(deltas, true), LoadMap(server->MissionFolder(id)));
  // A late retransmission of the END after completion is answered with COMPLETE again.
  vilma::mission_chunk_t end_again;
  end_again.mission_id = id.Hex();
  end_again.session_id = sender.session_id();
  end_again.seq = static_cast<int64_t>(deltas.size());
  end_again.flags = vilma::mission_chunk_t::FLAG_END;
  end_again.payload_size = 0;
  end_again.checksum = 0;
  server->OnChunk(end_again);
  REQUIRE_FALSE(back.empty());
  CHECK(back.back().status == vilma::mission_ack_t::COMPLETE);
  CHECK(back.back().ack_seq == end_again.seq);
}

TEST_CASE("a full disk is reported as DISK_FULL and nothing is lost", "[mapstore_stream]") {
  SyntheticMissionOptions mo;
  mo.vertices = 20;
  mo.keypoints_per_frame = 10;
  mo.landmarks_per_vertex = 2;
  const auto deltas = MakeSyntheticMissionDeltas(mo);
  const MissionId id = deltas[0].mission.id;
  int fail_writes = 0, fail_syncs = 0;  // errno to inject
  MapStoreServerOptions so;
  so.root = FreshRoot("disk_full");
  so.fault_hook = [&](const char* op) { return std::string(op) == "write" ? fail_writes : fail_syncs; };
  std::vector<vilma::mission_ack_t> acks;
  MapStoreServer server(so, [&](const vilma::mission_ack_t& a) { acks.push_back(a); }, nullptr);
  server.Start();
  std::vector<vilma::mission_chunk_t> chunks;
  MissionStreamSender sender(id, mo.name, FastSender(), [&](const vilma::mission_chunk_t& c) { chunks.push_back(c); });
  for (const MissionDelta& d : deltas) REQUIRE(sender.Send(d));
  REQUIRE(sender.End());
  auto deliver = [&](std::size_t from, std::size_t to) {
    for (std::size_t i = from; i < to; ++i) server.OnChunk(chunks[i]);
    server.Flush();
    for (const auto& a : acks) sender.OnAck(a);
  };
  deliver(0, 5);
  CHECK(acks.back().ack_seq == 4);
  // Writes fail: the ack stays at 4 and says DISK_FULL.
  fail_writes = ENOSPC;
  deliver(5, 8);
  CHECK(acks.back().ack_seq == 4);
  CHECK(acks.back().status == vilma::mission_ack_t::DISK_FULL);
  CHECK(server.counters().disk_full_errors >= 1);
  CHECK(sender.counters().disk_full_acks >= 1);
  // fsync fails: the written records are cut back, still acked at 4.
  fail_writes = 0;
  fail_syncs = ENOSPC;
  deliver(5, 8);
  CHECK(acks.back().ack_seq == 4);
  CHECK(acks.back().status == vilma::mission_ack_t::DISK_FULL);
  // Space again: the sender's retransmissions fill the journal and the mission completes.
  fail_syncs = 0;
  deliver(5, chunks.size());
  CHECK(acks.back().status == vilma::mission_ack_t::COMPLETE);
  CHECK(sender.finished());
  RequireMapsEqual(Expected(deltas, true), LoadMap(server.MissionFolder(id)));
  // A new mission on a full disk: the journal cannot even be created.
  fail_writes = ENOSPC;
  SyntheticMissionOptions mo2 = mo;
  mo2.seed = 2;
  const auto deltas2 = MakeSyntheticMissionDeltas(mo2);
  chunks.clear();
  MissionStreamSender sender2(deltas2[0].mission.id, "two", FastSender(),
                              [&](const vilma::mission_chunk_t& c) { chunks.push_back(c); });
  REQUIRE(sender2.Send(deltas2[0]));
  server.OnChunk(chunks[0]);
  CHECK(acks.back().status == vilma::mission_ack_t::DISK_FULL);
  CHECK(acks.back().ack_seq == -1);
  CHECK(server.missions_open() == 0);
}

TEST_CASE("a mission whose sender is gone is finalized as incomplete and loads", "[mapstore_stream]") {
  SyntheticMissionOptions mo;
  mo.vertices = 12;
  mo.keypoints_per_frame = 10;
  mo.landmarks_per_vertex = 2;
  auto deltas = MakeSyntheticMissionDeltas(mo);
  const MissionId id = deltas[0].mission.id;
  MapStoreServerOptions so;
  so.root = FreshRoot("incomplete");
  so.incomplete_timeout_s = 0.05;
  MapStoreServer server(so, [](const vilma::mission_ack_t&) {}, nullptr);
  server.Start();
  MissionStreamSender sender(id, mo.name, FastSender(), [&](const vilma::mission_chunk_t& c) { server.OnChunk(c); });
  for (int i = 0; i < 7; ++i) REQUIRE(sender.Send(deltas[i]));
  server.Flush();
  server.FinalizeStale();
  CHECK(server.missions_open() == 1);  // not stale yet
  std::this_thread::sleep_for(std::chrono::milliseconds(80));
  server.FinalizeStale();
  CHECK(server.missions_open() == 0);
  CHECK(server.counters().missions_incomplete == 1);
  const VIMap loaded = LoadMap(server.MissionFolder(id));
  CHECK_FALSE(loaded.mission(id).complete);
  deltas.resize(7);
  RequireMapsEqual(Expected(deltas, false), loaded);
}


TEST_CASE("a map folder appears whole: saved in staging, renamed into place, a crash's staging is removed",
          "[mapstore_stream]") {
  SyntheticMissionOptions mo;
  mo.vertices = 5;
  mo.keypoints_per_frame = 4;
  mo.landmarks_per_vertex = 1;
  mo.name = "staged";
  const auto deltas = MakeSyntheticMissionDeltas(mo);
  const MissionId id = deltas[0].mission.id;
  MapStoreServerOptions so;
  so.root = FreshRoot("staging");
  MapStoreServer server(so, [](const vilma::mission_ack_t&) {}, nullptr);
  server.Start();
  // What a kill -9 during an earlier SaveMap of this mission leaves: a half-written folder.
  const std::string staging = so.root + "/.journal/" + id.Hex() + ".staging";
  REQUIRE(std::system(("mkdir -p '" + staging + "/missions' && echo x > '" + staging + "/junk'").c_str()) == 0);
  MissionStreamSender sender(id, mo.name, FastSender(), [&](const vilma::mission_chunk_t& c) { server.OnChunk(c); });
  for (const MissionDelta& d : deltas) REQUIRE(sender.Send(d));
  REQUIRE(sender.End());
  server.Flush();
  CHECK(server.counters().missions_completed == 1);
  CHECK(server.MissionFolder(id) == so.root + "/staged");  // its own name, not staged_<id>
  CHECK(::access(staging.c_str(), F_OK) != 0);             // moved into place
  CHECK(::access((so.root + "/staged/junk").c_str(), F_OK) != 0);
  RequireMapsEqual(Expected(deltas, true), LoadMap(so.root + "/staged"));
}

TEST_CASE("shutdown keeps open missions in journals unless asked to finalize", "[mapstore_stream]") {
  SyntheticMissionOptions mo;
  mo.vertices = 4;
  mo.keypoints_per_frame = 4;
  mo.landmarks_per_vertex = 1;
  const auto deltas = MakeSyntheticMissionDeltas(mo);
  const MissionId id = deltas[0].mission.id;
  MapStoreServerOptions so;
  so.root = FreshRoot("shutdown");
  for (const bool finalize : {false, true}) {
    so.finalize_incomplete_at_shutdown = finalize;
    MapStoreServer server(so, [](const vilma::mission_ack_t&) {}, nullptr);
    server.Start();
    if (!finalize) {
      MissionStreamSender sender(id, mo.name, FastSender(), [&](const vilma::mission_chunk_t& c) { server.OnChunk(c); }, 5);
      for (const MissionDelta& d : deltas) REQUIRE(sender.Send(d));
    } else {
      CHECK(server.missions_open() == 1);  // recovered
    }
    server.Shutdown();
    CHECK(server.missions_open() == (finalize ? 0u : 1u));
  }
  CHECK_FALSE(LoadMap(so.root + "/" + mo.name).mission(id).complete);
}

