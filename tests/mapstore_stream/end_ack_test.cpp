// The END's acknowledgement (soak 2026-11-26: the daemon reported "NOT acknowledged by
// mapstored" although mapstored completed the mission): mapstored finalizes a mission by
// replaying its whole journal and writing the map folder, ~2 min for an hour of mapping, and
// acknowledged the END only with COMPLETE after that, long after the sender's end_timeout_s.
// Now the END is acknowledged as durable (OK, ack_seq = END) before the finalization, and the
// sender knows the mission is safe (end_durable) even when COMPLETE comes late or is lost.
#include <catch2/catch.hpp>
#include <sys/stat.h>
#include <unistd.h>

#include <cstdlib>
#include <deque>
#include <string>

#include "vilma/mapstore/stream/map_store_server.h"
#include "vilma/mapstore/stream/mission_stream_sender.h"
#include "vilma/mapstore/stream/synthetic_mission.h"

using namespace vilma::mapstore;

namespace {

std::string FreshRoot(const std::string& name) {
  const std::string dir = "/tmp/vilma_end_ack_test_" + std::to_string(::getpid());
  ::mkdir(dir.c_str(), 0755);
  const std::string root = dir + "/" + name;
  REQUIRE(std::system(("rm -rf '" + root + "'").c_str()) == 0);
  return root;
}

TEST_CASE("mapstored acknowledges the END as durable before finalizing, the sender knows",
          "[mapstore_stream]") {
  SyntheticMissionOptions mo;
  mo.vertices = 20;
  mo.keypoints_per_frame = 10;
  mo.landmarks_per_vertex = 2;
  const auto deltas = MakeSyntheticMissionDeltas(mo);
  const MissionId id = deltas[0].mission.id;
  MapStoreServerOptions so;
  so.root = FreshRoot("end_ack");
  std::deque<vilma::mission_chunk_t> wire;
  std::deque<vilma::mission_ack_t> back;
  MissionStreamSenderOptions sender_options;
  sender_options.keepalive_period_s = 0.0;
  MissionStreamSender sender(id, mo.name, sender_options,
                             [&](const vilma::mission_chunk_t& c) { wire.push_back(c); });
  MapStoreServer server(so, [&](const vilma::mission_ack_t& a) { back.push_back(a); }, nullptr);
  server.Start();
  for (const auto& d : deltas) REQUIRE(sender.Send(d));
  REQUIRE(sender.End());
  const int64_t end_seq = sender.next_seq() - 1;
  while (!wire.empty()) {
    server.OnChunk(wire.front());
    wire.pop_front();
  }
  // Where the map folder is written; the acks in the order they were published.
  const std::size_t acks_before = back.size();
  server.Flush();
  CHECK(server.counters().missions_completed == 1);
  REQUIRE(back.size() >= acks_before + 2);
  const vilma::mission_ack_t& durable = back[back.size() - 2];
  const vilma::mission_ack_t& complete = back.back();
  // The END, durable, acknowledged first (before the fix the only ack of the END was COMPLETE,
  // sent after the finalization).
  CHECK(durable.status == vilma::mission_ack_t::OK);
  CHECK(durable.ack_seq == end_seq);
  CHECK(complete.status == vilma::mission_ack_t::COMPLETE);
  CHECK(complete.ack_seq == end_seq);

  // COMPLETE lost (or still minutes away): the durable ack alone tells the sender the mission
  // is safe; it is not "finished" (no folder confirmed) and resends nothing.
  back.pop_back();
  while (!back.empty()) {
    sender.OnAck(back.front());
    back.pop_front();
  }
  CHECK(sender.end_durable());
  CHECK_FALSE(sender.finished());
  CHECK(sender.window_chunks() == 0);
  sender.Poll(MissionStreamSender::Clock::now() + std::chrono::seconds(10));
  CHECK(wire.empty());
}

TEST_CASE("a sender is not end_durable before its END is acknowledged", "[mapstore_stream]") {
  SyntheticMissionOptions mo;
  mo.vertices = 6;
  const auto deltas = MakeSyntheticMissionDeltas(mo);
  const MissionId id = deltas[0].mission.id;
  std::deque<vilma::mission_chunk_t> wire;
  MissionStreamSender sender(id, mo.name, MissionStreamSenderOptions(),
                             [&](const vilma::mission_chunk_t& c) { wire.push_back(c); });
  for (const auto& d : deltas) REQUIRE(sender.Send(d));
  const int64_t last_data = sender.next_seq() - 1;
  vilma::mission_ack_t ack;
  ack.mission_id = id.Hex();
  ack.session_id = sender.session_id();
  ack.status = vilma::mission_ack_t::OK;
  ack.ack_seq = last_data;
  sender.OnAck(ack);  // every data chunk durable, no END yet
  CHECK_FALSE(sender.end_durable());
  REQUIRE(sender.End());
  CHECK_FALSE(sender.end_durable());
  ack.ack_seq = last_data + 1;
  ack.status = vilma::mission_ack_t::DISK_FULL;  // not a durable END
  sender.OnAck(ack);
  CHECK_FALSE(sender.end_durable());
}

}  // namespace
