#include "vilma/mapstore/stream/mission_stream_sender.h"

#include <catch2/catch.hpp>

#include <thread>
#include <vector>

#include "vilma/mapstore/checksum.h"

using namespace vilma::mapstore;
using Clock = MissionStreamSender::Clock;

namespace {

MissionId TestMission() { return IdGenerator(42).Next(); }

vilma::mission_ack_t AckOf(const MissionStreamSender& s, int64_t seq,
                           int8_t status = vilma::mission_ack_t::OK) {
  vilma::mission_ack_t ack;
  ack.mission_id = s.mission_id().Hex();
  ack.session_id = s.session_id();
  ack.ack_seq = seq;
  ack.status = status;
  return ack;
}

}  // namespace

TEST_CASE("sender numbers chunks, flags and checksums them", "[mapstore_stream]") {
  std::vector<vilma::mission_chunk_t> out;
  MissionStreamSender s(TestMission(), "m", {}, [&](const vilma::mission_chunk_t& c) { out.push_back(c); }, 7);
  REQUIRE(s.SendSerialized("abc"));
  REQUIRE(s.SendSerialized("defg"));
  REQUIRE(s.End());
  REQUIRE(out.size() == 3);
  CHECK(out[0].seq == 0);
  CHECK(out[0].flags == (vilma::mission_chunk_t::FLAG_BEGIN | vilma::mission_chunk_t::FLAG_DATA));
  CHECK(out[1].flags == vilma::mission_chunk_t::FLAG_DATA);
  CHECK(out[2].flags == vilma::mission_chunk_t::FLAG_END);
  CHECK(out[2].payload_size == 0);
  CHECK(out[1].session_id == 7);
  CHECK(out[1].mission_id == TestMission().Hex());
  CHECK(static_cast<uint32_t>(out[1].checksum) == Crc32("defg"));
  CHECK_FALSE(s.SendSerialized("late"));  // after End()
  CHECK(s.window_chunks() == 3);
}

TEST_CASE("sender window is bounded and freed by cumulative acks", "[mapstore_stream]") {
  MissionStreamSenderOptions o;
  o.max_window_chunks = 3;
  int published = 0;
  MissionStreamSender s(TestMission(), "m", o, [&](const vilma::mission_chunk_t&) { ++published; }, 1);
  CHECK(s.SendSerialized("0"));
  CHECK(s.SendSerialized("1"));
  CHECK(s.SendSerialized("2"));
  CHECK_FALSE(s.SendSerialized("3"));
  CHECK(s.counters().window_full == 1);
  s.OnAck(AckOf(s, 1));
  CHECK(s.window_chunks() == 1);
  CHECK(s.acked_seq() == 1);
  CHECK(s.counters().acked == 2);
  CHECK(s.SendSerialized("3"));
  // Acks of another session, another mission or of unsent chunks change nothing.
  vilma::mission_ack_t other = AckOf(s, 3);
  other.session_id = 2;
  s.OnAck(other);
  other = AckOf(s, 3);
  other.mission_id = IdGenerator(1).Next().Hex();
  s.OnAck(other);
  s.OnAck(AckOf(s, 17));
  CHECK(s.acked_seq() == 1);
  CHECK(s.counters().ignored_acks == 3);
  s.OnAck(AckOf(s, 3, vilma::mission_ack_t::DISK_FULL));
  CHECK(s.counters().disk_full_acks == 1);
  CHECK(s.window_chunks() == 0);
  CHECK(published == 4);
}

TEST_CASE("sender limits chunks in flight and sends the rest as acks come", "[mapstore_stream]") {
  MissionStreamSenderOptions o;
  o.max_in_flight_chunks = 2;
  std::vector<int64_t> seqs;
  MissionStreamSender s(TestMission(), "m", o, [&](const vilma::mission_chunk_t& c) { seqs.push_back(c.seq); }, 1);
  for (int i = 0; i < 5; ++i) REQUIRE(s.SendSerialized("x"));
  CHECK(seqs == std::vector<int64_t>{0, 1});
  s.OnAck(AckOf(s, 0));
  CHECK(seqs == std::vector<int64_t>{0, 1, 2});
  s.OnAck(AckOf(s, 2));
  CHECK(seqs == std::vector<int64_t>{0, 1, 2, 3, 4});
}

TEST_CASE("sender retransmits on timeout with exponential backoff", "[mapstore_stream]") {
  MissionStreamSenderOptions o;
  o.retransmit_timeout_s = 0.1;
  o.max_retransmit_timeout_s = 0.4;
  std::vector<int64_t> seqs;
  MissionStreamSender s(TestMission(), "m", o, [&](const vilma::mission_chunk_t& c) { seqs.push_back(c.seq); }, 1);
  const auto t0 = Clock::now();
  REQUIRE(s.SendSerialized("a"));
  REQUIRE(s.SendSerialized("b"));
  seqs.clear();
  auto at = [&](double s_) { return t0 + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s_)); };
  s.Poll(at(0.05));
  CHECK(seqs.empty());
  s.Poll(at(0.11));  // first timeout (0.1 s): both resent
  CHECK(seqs == std::vector<int64_t>{0, 1});
  s.Poll(at(0.25));  // next timeout is 0.2 s after 0.11
  CHECK(seqs.size() == 2);
  s.Poll(at(0.32));
  CHECK(seqs.size() == 4);
  s.Poll(at(0.32 + 0.39));  // capped at 0.4 s
  CHECK(seqs.size() == 4);
  s.Poll(at(0.32 + 0.41));
  CHECK(seqs.size() == 6);
  CHECK(s.counters().retransmitted == 6);
  // Progress resets the backoff and stops resending what is acknowledged.
  s.OnAck(AckOf(s, 0));
  seqs.clear();
  s.Poll(Clock::now() + std::chrono::milliseconds(110));
  CHECK(seqs == std::vector<int64_t>{1});
}

TEST_CASE("sender finishes only on the COMPLETE ack of its END", "[mapstore_stream]") {
  MissionStreamSender s(TestMission(), "m", {}, [](const vilma::mission_chunk_t&) {}, 1);
  REQUIRE(s.SendSerialized("a"));
  REQUIRE(s.End());
  s.OnAck(AckOf(s, 1, vilma::mission_ack_t::OK));
  CHECK_FALSE(s.finished());  // acknowledged on disk but not yet stored
  s.OnAck(AckOf(s, 1, vilma::mission_ack_t::COMPLETE));
  CHECK(s.finished());
}

TEST_CASE("sender options are validated", "[mapstore_stream]") {
  MissionStreamSenderOptions o;
  CHECK(o.Validate().empty());
  o.max_retransmit_timeout_s = 0.01;
  CHECK(o.Validate() == "max_retransmit_timeout_s: expected >= retransmit_timeout_s");
  CHECK_THROWS_AS(MissionStreamSender(TestMission(), "m", o, [](const vilma::mission_chunk_t&) {}),
                  std::invalid_argument);
  CHECK_THROWS_AS(MissionStreamSender(MissionId(), "m", {}, [](const vilma::mission_chunk_t&) {}),
                  std::invalid_argument);
}

TEST_CASE("an idle sender sends a keepalive naming its last acknowledged chunk", "[mapstore_stream]") {
  MissionStreamSenderOptions o;
  o.keepalive_period_s = 1.0;
  o.retransmit_timeout_s = 10.0;  // no retransmission in this test's 2.3 s
  o.max_retransmit_timeout_s = 10.0;
  std::vector<vilma::mission_chunk_t> out;
  MissionStreamSender s(TestMission(), "m", o, [&](const vilma::mission_chunk_t& c) { out.push_back(c); }, 3);
  const auto t0 = Clock::now();
  auto at = [&](double s_) { return t0 + std::chrono::duration_cast<Clock::duration>(std::chrono::duration<double>(s_)); };
  s.Poll(at(5.0));
  CHECK(out.empty());  // nothing sent, nothing acknowledged: mapstored does not know the mission
  REQUIRE(s.SendSerialized("a"));
  REQUIRE(s.SendSerialized("b"));
  s.OnAck(AckOf(s, 0));
  out.clear();
  s.Poll(at(0.5));
  CHECK(out.empty());  // chunk 1 unacknowledged: retransmission's business, not a keepalive
  s.OnAck(AckOf(s, 1));
  s.Poll(at(0.9));
  CHECK(out.empty());  // idle for less than the period
  s.Poll(at(1.2));
  REQUIRE(out.size() == 1);
  CHECK(out[0].flags == vilma::mission_chunk_t::FLAG_KEEPALIVE);
  CHECK(out[0].seq == 1);
  CHECK(out[0].payload_size == 0);
  CHECK(static_cast<uint32_t>(out[0].checksum) == Crc32(std::string()));
  s.Poll(at(1.5));
  CHECK(out.size() == 1);  // one per period
  s.Poll(at(2.3));
  CHECK(out.size() == 2);
  CHECK(s.counters().keepalives == 2);
  CHECK(s.next_seq() == 2);  // keepalives take no sequence number
  CHECK(s.window_chunks() == 0);

  o.keepalive_period_s = 0.0;  // off
  std::vector<vilma::mission_chunk_t> none;
  MissionStreamSender quiet(TestMission(), "m", o, [&](const vilma::mission_chunk_t& c) { none.push_back(c); }, 4);
  REQUIRE(quiet.SendSerialized("a"));
  quiet.OnAck(AckOf(quiet, 0));
  none.clear();
  quiet.Poll(at(100.0));
  CHECK(none.empty());
  o.keepalive_period_s = -1.0;
  CHECK(o.Validate() == "keepalive_period_s: expected 0 (never) .. 3600");
}
