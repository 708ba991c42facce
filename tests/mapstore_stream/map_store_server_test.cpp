#include "vilma/mapstore/stream/map_store_server.h"

#include <catch2/catch.hpp>
#include <lcm/lcm-cpp.hpp>
#include <unistd.h>

#include <deque>
#include <random>
#include <thread>

#include "map_store_server_fixture.h"
#include "mapstore/synthetic_map.h"  // RequireMapsEqual
#include "vilma/mapstore/checksum.h"
#include "vilma/mapstore/consistency.h"
#include "vilma/mapstore/stream/mission_stream_sender.h"
#include "vilma/mapstore/stream/synthetic_mission.h"

using namespace vilma::mapstore;
using namespace vilma::mapstore::server_test;  // NOLINT: the shared fixture of the server tests
using vilma::mapstore::testing::RequireMapsEqual;

namespace {

// A lossy, duplicating, reordering link in both directions (seeded): messages wait in a queue
// and are delivered in random order; each may be dropped or delivered twice.
template <typename Message>
class LossyLink {
 public:
  LossyLink(uint64_t seed, double loss, double duplication) : rng_(seed), loss_(loss), dup_(duplication) {}
  void Push(const Message& m) { queue_.push_back(m); }
  template <typename Deliver>
  void DeliverAll(Deliver deliver) {
    std::shuffle(queue_.begin(), queue_.end(), rng_);  // reordering
    std::deque<Message> queue;
    queue.swap(queue_);
    std::uniform_real_distribution<double> u(0.0, 1.0);
    for (const Message& m : queue) {
      if (u(rng_) < loss_) {
        ++dropped;
        continue;
      }
      deliver(m);
      if (u(rng_) < dup_) {
        ++duplicated;
        deliver(m);
      }
    }
  }
  int dropped = 0;
  int duplicated = 0;

 private:
  std::deque<Message> queue_;
  std::mt19937_64 rng_;
  double loss_, dup_;
};

}  // namespace

TEST_CASE("stream over a lossy, duplicating, reordering link stores the exact mission", "[mapstore_stream]") {
  SyntheticMissionOptions mo;
  mo.vertices = 120;
  mo.vertices_per_delta = 2;
  mo.keypoints_per_frame = 20;
  mo.landmarks_per_vertex = 5;
  const auto deltas = MakeSyntheticMissionDeltas(mo);
  const MissionId id = deltas[0].mission.id;

  const double loss = GENERATE(0.0, 0.2);
  LossyLink<vilma::mission_chunk_t> chunks(11, loss, 0.1);
  LossyLink<vilma::mission_ack_t> acks(12, loss, 0.1);
  MapStoreServerOptions so;
  so.root = FreshRoot("lossy" + std::to_string(static_cast<int>(loss * 100)));
  MapStoreServer server(so, [&](const vilma::mission_ack_t& a) { acks.Push(a); }, {});
  server.Start();
  MissionStreamSender sender(id, mo.name, FastSender(), [&](const vilma::mission_chunk_t& c) { chunks.Push(c); });

  std::size_t next = 0;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(20);
  while (!sender.finished() && std::chrono::steady_clock::now() < deadline) {
    while (next < deltas.size() && sender.Send(deltas[next])) ++next;
    if (next == deltas.size()) sender.End();
    chunks.DeliverAll([&](const vilma::mission_chunk_t& c) { server.OnChunk(c); });
    server.Flush();
    acks.DeliverAll([&](const vilma::mission_ack_t& a) { sender.OnAck(a); });
    sender.Poll();
    std::this_thread::sleep_for(std::chrono::microseconds(200));
  }
  REQUIRE(sender.finished());
  CHECK(sender.counters().acked == deltas.size() + 1);
  if (loss > 0) {
    CHECK(chunks.dropped > 0);
    CHECK(sender.counters().retransmitted > 0);
    CHECK(server.counters().chunks_out_of_order > 0);
  }
  CHECK(chunks.duplicated > 0);
  CHECK(server.counters().chunks_duplicate > 0);
  CHECK(server.counters().chunks_journaled == deltas.size() + 1);
  CHECK(server.counters().missions_completed == 1);
  CHECK(server.missions_open() == 0);
  const std::string folder = server.MissionFolder(id);
  CHECK(folder == so.root + "/" + mo.name);
  RequireMapsEqual(Expected(deltas, true), LoadMap(folder));
}

TEST_CASE("a streamed keypoint that refers to a landmark the stream never sent is cleared, the map is consistent",
          "[mapstore_stream]") {
  // fuzz_mission_stream (2026-11-27): chunks with valid CRCs whose deltas give a keypoint a
  // landmark id that no delta holds were finalized into a map that check_map_consistency
  // rejected ("refers to missing landmark"). vilma-estimatord never streams such a reference.
  SyntheticMissionOptions mo;
  mo.vertices = 6;
  mo.vertices_per_delta = 2;
  mo.keypoints_per_frame = 10;
  mo.landmarks_per_vertex = 3;
  std::vector<MissionDelta> deltas = MakeSyntheticMissionDeltas(mo);
  const MissionId id = deltas[0].mission.id;
  REQUIRE_FALSE(deltas[0].vertices.empty());
  VisualFrame& frame = deltas[0].vertices[0].frames.at(0);
  // Two keypoints without a landmark (so that no landmark observes them).
  std::vector<std::size_t> free_keypoints;
  for (std::size_t k = 0; k < frame.landmark_ids.size(); ++k) {
    if (!frame.landmark_ids[k].IsValid()) free_keypoints.push_back(k);
  }
  REQUIRE(free_keypoints.size() >= 2);
  LandmarkId missing;
  REQUIRE(LandmarkId::FromHex("00000000000000000200000000000000", &missing));
  frame.landmark_ids[free_keypoints[0]] = missing;  // a landmark no delta holds
  LandmarkId other;
  for (const MissionDelta& d : deltas) {
    if (!d.landmarks.empty()) other = d.landmarks[0].id;
  }
  REQUIRE(other.IsValid());
  frame.landmark_ids[free_keypoints[1]] = other;  // a landmark that does not observe this keypoint

  MapStoreServerOptions so;
  so.root = FreshRoot("dangling");
  std::vector<std::string> log;
  MapStoreServer server(so, [](const vilma::mission_ack_t&) {}, [&](const std::string& line) { log.push_back(line); });
  server.Start();
  MissionStreamSender sender(id, mo.name, FastSender(), [&](const vilma::mission_chunk_t& c) { server.OnChunk(c); });
  for (const MissionDelta& d : deltas) REQUIRE(sender.Send(d));
  sender.End();
  server.Flush();
  REQUIRE(server.counters().missions_completed == 1);

  const VIMap loaded = LoadMap(server.MissionFolder(id));
  INFO(CheckMapConsistency(loaded).FullReport());
  CHECK(CheckMapConsistency(loaded).ok());
  // Only the two references are gone; everything else is what was streamed.
  deltas[0].vertices[0].frames[0].landmark_ids[free_keypoints[0]] = LandmarkId();
  deltas[0].vertices[0].frames[0].landmark_ids[free_keypoints[1]] = LandmarkId();
  RequireMapsEqual(Expected(deltas, true), loaded);
  bool logged = false;
  for (const std::string& line : log) logged |= line.find("2 keypoint reference(s)") != std::string::npos;
  CHECK(logged);
}

TEST_CASE("keepalives keep a silent sender's mission open, they never journal or open a mission",
          "[mapstore_stream]") {
  SyntheticMissionOptions mo;
  mo.vertices = 6;
  mo.keypoints_per_frame = 4;
  mo.landmarks_per_vertex = 1;
  auto deltas = MakeSyntheticMissionDeltas(mo);
  const MissionId id = deltas[0].mission.id;
  MapStoreServerOptions so;
  so.root = FreshRoot("keepalive");
  so.incomplete_timeout_s = 0.2;
  std::vector<vilma::mission_ack_t> acks;
  MapStoreServer server(so, [&](const vilma::mission_ack_t& a) { acks.push_back(a); }, nullptr);
  server.Start();
  MissionStreamSenderOptions o = FastSender();
  o.keepalive_period_s = 0.05;
  std::vector<vilma::mission_chunk_t> wire;
  MissionStreamSender sender(id, mo.name, o, [&](const vilma::mission_chunk_t& c) { wire.push_back(c); }, 9);
  auto deliver = [&] {
    std::vector<vilma::mission_chunk_t> chunks;
    chunks.swap(wire);
    for (const auto& c : chunks) server.OnChunk(c);
    server.Flush();
    std::vector<vilma::mission_ack_t> out;
    out.swap(acks);
    for (const auto& a : out) sender.OnAck(a);
  };
  for (int i = 0; i < 3; ++i) REQUIRE(sender.Send(deltas[i]));
  deliver();
  REQUIRE(sender.acked_seq() == 2);
  const uint64_t journaled = server.counters().chunks_journaled;
  // 0.6 s of silence (three times the timeout), with the sender polled every 20 ms.
  const auto end = std::chrono::steady_clock::now() + std::chrono::milliseconds(600);
  while (std::chrono::steady_clock::now() < end) {
    sender.Poll();
    deliver();
    server.FinalizeStale();
    std::this_thread::sleep_for(std::chrono::milliseconds(20));
  }
  CHECK(server.missions_open() == 1);
  CHECK(server.counters().missions_incomplete == 0);
  CHECK(server.counters().keepalives >= 5);
  CHECK(server.counters().chunks_journaled == journaled);
  CHECK(sender.counters().keepalives == server.counters().keepalives);
  // The mission goes on after the pause and completes.
  for (std::size_t i = 3; i < deltas.size(); ++i) REQUIRE(sender.Send(deltas[i]));
  REQUIRE(sender.End());
  deliver();
  deliver();
  CHECK(sender.finished());
  RequireMapsEqual(Expected(deltas, true), LoadMap(server.MissionFolder(id)));

  // A keepalive of a mission mapstored does not know opens nothing; one with a payload is
  // malformed.
  vilma::mission_chunk_t stray;
  stray.mission_id = IdGenerator(77).Next().Hex();
  stray.session_id = 5;
  stray.seq = 0;
  stray.flags = vilma::mission_chunk_t::FLAG_KEEPALIVE;
  stray.checksum = static_cast<int32_t>(Crc32(std::string()));
  server.OnChunk(stray);
  CHECK(server.missions_open() == 0);
  CHECK(server.counters().chunks_unknown_mission == 1);
  stray.payload = {1, 2};
  stray.payload_size = 2;
  stray.checksum = static_cast<int32_t>(Crc32(std::string("\x01\x02", 2)));
  const uint64_t malformed = server.counters().chunks_malformed;
  server.OnChunk(stray);
  CHECK(server.counters().chunks_malformed == malformed + 1);
}

TEST_CASE("malformed chunks are counted, never stored", "[mapstore_stream]") {
  MapStoreServerOptions so;
  so.root = FreshRoot("malformed");
  std::vector<vilma::mission_ack_t> acks;
  std::vector<std::string> log;
  MapStoreServer server(so, [&](const vilma::mission_ack_t& a) { acks.push_back(a); },
                        [&](const std::string& line) { log.push_back(line); });
  server.Start();
  vilma::mission_chunk_t c;
  c.mission_id = "not hex";
  c.seq = 0;
  c.flags = vilma::mission_chunk_t::FLAG_DATA;
  c.payload = {1, 2, 3};
  c.payload_size = 3;
  c.checksum = static_cast<int32_t>(Crc32(c.payload.data(), 3));
  server.OnChunk(c);
  c.mission_id = IdGenerator(3).Next().Hex();
  c.checksum ^= 1;
  server.OnChunk(c);  // bad checksum
  c.checksum ^= 1;
  c.seq = 5;
  server.OnChunk(c);  // unknown mission not starting at 0: error ack
  CHECK(server.counters().chunks_malformed == 2);
  CHECK(server.counters().chunks_unknown_mission == 1);
  CHECK(server.missions_open() == 0);
  REQUIRE(acks.size() == 1);
  CHECK(acks[0].status == vilma::mission_ack_t::ERROR);
  CHECK(log.size() == 3);
}

TEST_CASE("sender and server talk over LCM (memq://)", "[mapstore_stream]") {
  lcm::LCM lcm("memq://");
  REQUIRE(lcm.good());
  SyntheticMissionOptions mo;
  mo.vertices = 25;
  mo.keypoints_per_frame = 8;
  mo.landmarks_per_vertex = 2;
  const auto deltas = MakeSyntheticMissionDeltas(mo);
  MapStoreServerOptions so;
  so.root = FreshRoot("memq");
  MapStoreServer server(so, [&](const vilma::mission_ack_t& a) { lcm.publish("VILMA_MISSION_ACK", &a); }, nullptr);
  server.Start();
  lcm.subscribeFunction(
      "VILMA_MISSION",
      +[](const lcm::ReceiveBuffer*, const std::string&, const vilma::mission_chunk_t* c, MapStoreServer* s) {
        s->OnChunk(*c);
        s->Flush();
      },
      &server);
  // memq:// is lossless, so nothing may be retransmitted. The server fsyncs every chunk inside
  // lcm.handle() on this one thread, so on a loaded machine acks can take longer than the
  // default 0.25 s timeout: a timeout far above that makes "no retransmission" a property of
  // the protocol, not of the machine's load.
  MissionStreamSenderOptions sender_options;
  sender_options.retransmit_timeout_s = 30.0;
  sender_options.max_retransmit_timeout_s = 30.0;
  LcmMissionStreamSender stream(&lcm, "VILMA_MISSION", "VILMA_MISSION_ACK", deltas[0].mission.id,
                                mo.name, sender_options);
  for (const MissionDelta& d : deltas) REQUIRE(stream.sender().Send(d));
  REQUIRE(stream.WaitAcked(5.0));
  REQUIRE(stream.EndAndWait(5.0));
  CHECK(stream.sender().counters().retransmitted == 0);
  RequireMapsEqual(Expected(deltas, true), LoadMap(server.MissionFolder(deltas[0].mission.id)));
}

// Benchmark (hidden): journaling throughput of the server with one fsync per batch of chunks
// (batch 1 = fsync per chunk), finalization time, and recovery time of an open mission.
//   vilma_mapstore_stream_tests "[.benchmark]" -s
TEST_CASE("mission stream benchmark: journal throughput, finalization, recovery",
          "[.benchmark][mapstore_stream]") {
  using Clock = std::chrono::steady_clock;
  SyntheticMissionOptions mo;
  mo.vertices = 2000;  // 200 s of mapping at 10 Hz
  mo.keypoints_per_frame = 100;
  mo.landmarks_per_vertex = 10;
  const auto deltas = MakeSyntheticMissionDeltas(mo);
  // Every chunk of the mission, taken straight from a sender without flow control.
  std::vector<vilma::mission_chunk_t> chunks;
  {
    MissionStreamSenderOptions o;
    o.max_in_flight_chunks = 1 << 20;
    o.max_window_chunks = 1 << 20;
    MissionStreamSender all(deltas[0].mission.id, mo.name, o,
                            [&](const vilma::mission_chunk_t& c) { chunks.push_back(c); });
    for (const MissionDelta& d : deltas) REQUIRE(all.Send(d));
    REQUIRE(all.End());
  }
  uint64_t bytes = 0;
  for (const auto& c : chunks) bytes += c.payload.size();
  std::printf("mission: %zu chunks, %.1f MB, %.1f KB/chunk\n", chunks.size(), bytes / 1e6,
              bytes / 1e3 / chunks.size());
  for (const int batch : {1, 8, 64, 256}) {
    MapStoreServerOptions so;
    so.root = FreshRoot("bench_batch" + std::to_string(batch));
    int acks = 0;
    MapStoreServer server(so, [&](const vilma::mission_ack_t&) { ++acks; }, nullptr);
    server.Start();
    const auto t0 = Clock::now();
    for (std::size_t i = 0; i + 1 < chunks.size(); ++i) {  // all but the END
      server.OnChunk(chunks[i]);
      if ((i + 1) % batch == 0) server.Flush();
    }
    server.Flush();
    const double journal_s = std::chrono::duration<double>(Clock::now() - t0).count();
    // Recovery: a new server over the same root replays the open journal.
    const auto t1 = Clock::now();
    MapStoreServer recovered(so, [](const vilma::mission_ack_t&) {}, nullptr);
    recovered.Start();
    const double recovery_s = std::chrono::duration<double>(Clock::now() - t1).count();
    REQUIRE(recovered.missions_open() == 1);
    const auto t2 = Clock::now();
    recovered.OnChunk(chunks.back());
    recovered.Flush();
    const double finalize_s = std::chrono::duration<double>(Clock::now() - t2).count();
    REQUIRE(recovered.counters().missions_completed == 1);
    std::printf("batch %3d: %7.0f chunks/s, %6.1f MB/s, %5d fsyncs | recovery %.3f s | "
                "finalize (apply + SaveMap) %.3f s\n",
                batch, (chunks.size() - 1) / journal_s, bytes / journal_s / 1e6,
                static_cast<int>(server.counters().fsyncs), recovery_s, finalize_s);
  }
}

// Issue 18: what the server keeps for a mission in flight must not grow with the mission.
// A long mission over a lossy, reordering link: the reorder buffer never holds more than its
// bound, nothing is held once the mission ends, and the mission is stored exactly.
TEST_CASE("a long mission's server state stays bounded", "[mapstore_stream]") {
  SyntheticMissionOptions mo;
  mo.vertices = 3000;
  mo.vertices_per_delta = 1;
  mo.keypoints_per_frame = 2;
  mo.landmarks_per_vertex = 1;
  const auto deltas = MakeSyntheticMissionDeltas(mo);
  const MissionId id = deltas[0].mission.id;

  LossyLink<vilma::mission_chunk_t> chunks(21, 0.1, 0.05);
  LossyLink<vilma::mission_ack_t> acks(22, 0.1, 0.05);
  MapStoreServerOptions so;
  so.root = FreshRoot("long");
  so.max_reorder_chunks = 8;
  MapStoreServer server(so, [&](const vilma::mission_ack_t& a) { acks.Push(a); }, {});
  server.Start();
  MissionStreamSender sender(id, mo.name, FastSender(), [&](const vilma::mission_chunk_t& c) { chunks.Push(c); });

  std::size_t next = 0, max_held = 0, max_open = 0;
  const auto deadline = std::chrono::steady_clock::now() + std::chrono::seconds(60);
  while (!sender.finished() && std::chrono::steady_clock::now() < deadline) {
    while (next < deltas.size() && sender.Send(deltas[next])) ++next;
    if (next == deltas.size()) sender.End();
    chunks.DeliverAll([&](const vilma::mission_chunk_t& c) {
      server.OnChunk(c);
      max_held = std::max(max_held, server.reorder_chunks_held());
    });
    max_open = std::max(max_open, server.missions_open());
    server.Flush();
    acks.DeliverAll([&](const vilma::mission_ack_t& a) { sender.OnAck(a); });
    sender.Poll();
  }
  REQUIRE(sender.finished());
  CHECK(server.counters().chunks_out_of_order > 0);
  CHECK(max_held > 0);
  CHECK(max_held <= so.max_reorder_chunks);
  CHECK(max_open == 1);
  CHECK(server.reorder_chunks_held() == 0);
  CHECK(server.reorder_bytes_held() == 0);
  CHECK(server.missions_open() == 0);
  CHECK(server.done_missions_remembered() == 1);
  RequireMapsEqual(Expected(deltas, true), LoadMap(server.MissionFolder(id)));
}
