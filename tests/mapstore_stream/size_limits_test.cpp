// Size limits of vilma-mapstored on untrusted chunks (docs/reliability.md "Size limits"): a
// payload above kMaxChunkPayloadBytes is malformed, and the reorder buffer holds at most
// max_reorder_bytes of payload per mission (beyond, chunks are left to retransmission).
#include "vilma/mapstore/stream/map_store_server.h"

#include <catch2/catch.hpp>
#include <sys/stat.h>
#include <unistd.h>

#include <string>
#include <vector>

#include "vilma/mapstore/checksum.h"
#include "vilma/mapstore/id.h"

using namespace vilma::mapstore;

namespace {

std::string FreshRoot(const std::string& name) {
  const std::string dir = "/tmp/vilma_size_limits_test_" + std::to_string(::getpid());
  ::mkdir(dir.c_str(), 0755);
  const std::string root = dir + "/" + name;
  REQUIRE(std::system(("rm -rf '" + root + "'").c_str()) == 0);
  return root;
}

vilma::mission_chunk_t Chunk(const std::string& mission_id, int64_t seq, std::size_t payload_bytes) {
  vilma::mission_chunk_t c;
  c.mission_id = mission_id;
  c.mission_name = "limits";
  c.session_id = 7;
  c.seq = seq;
  c.flags = vilma::mission_chunk_t::FLAG_DATA | (seq == 0 ? vilma::mission_chunk_t::FLAG_BEGIN : 0);
  c.payload.assign(payload_bytes, static_cast<uint8_t>(seq));
  c.payload_size = static_cast<int32_t>(payload_bytes);
  c.checksum = static_cast<int32_t>(Crc32(c.payload.data(), c.payload.size()));
  return c;
}

}  // namespace

TEST_CASE("mapstored: a chunk payload above 64 MiB is malformed, not journaled", "[mapstore_stream]") {
  MapStoreServerOptions so;
  so.root = FreshRoot("large_chunk");
  std::vector<std::string> log;
  std::vector<vilma::mission_ack_t> acks;
  MapStoreServer server(so, [&](const vilma::mission_ack_t& a) { acks.push_back(a); },
                        [&](const std::string& line) { log.push_back(line); });
  server.Start();
  const std::string id = IdGenerator(11).Next().Hex();
  server.OnChunk(Chunk(id, 0, MapStoreServerOptions::kMaxChunkPayloadBytes + 1));
  CHECK(server.counters().chunks_malformed == 1);
  CHECK(server.counters().chunks_journaled == 0);
  CHECK(server.missions_open() == 0);
  REQUIRE(log.size() == 1);
  CHECK_THAT(log[0], Catch::Contains("payload of 67108865 bytes, expected <= 67108864"));
  // The largest allowed payload is taken.
  server.OnChunk(Chunk(id, 0, MapStoreServerOptions::kMaxChunkPayloadBytes));
  server.Flush();
  CHECK(server.counters().chunks_journaled == 1);
  CHECK(server.missions_open() == 1);
}

TEST_CASE("mapstored: the reorder buffer is bounded in bytes, the rest is retransmitted",
          "[mapstore_stream]") {
  MapStoreServerOptions so;
  so.root = FreshRoot("reorder_bytes");
  so.max_reorder_bytes = MapStoreServerOptions::kMaxChunkPayloadBytes;  // 64 MiB
  std::vector<vilma::mission_ack_t> acks;
  MapStoreServer server(so, [&](const vilma::mission_ack_t& a) { acks.push_back(a); },
                        [](const std::string&) {});
  server.Start();
  const std::string id = IdGenerator(12).Next().Hex();
  const std::size_t kChunk = std::size_t{25} << 20;
  server.OnChunk(Chunk(id, 0, 16));
  // Seq 1 is late: 2 and 3 fit the 64 MiB buffer (50 MiB), 4 does not (75 MiB).
  for (int64_t seq : {2, 3, 4}) server.OnChunk(Chunk(id, seq, kChunk));
  CHECK(server.counters().chunks_out_of_order == 3);
  server.OnChunk(Chunk(id, 1, 16));
  server.Flush();
  REQUIRE_FALSE(acks.empty());
  CHECK(acks.back().ack_seq == 3);  // 0..3 durable; 4 waits for its retransmission
  CHECK(server.counters().chunks_journaled == 4);
  server.OnChunk(Chunk(id, 4, kChunk));  // the retransmission
  server.Flush();
  CHECK(acks.back().ack_seq == 4);
  // The buffer's bytes were released: another gap of the same size is kept again.
  for (int64_t seq : {6, 7}) server.OnChunk(Chunk(id, seq, kChunk));
  server.OnChunk(Chunk(id, 5, 16));
  server.Flush();
  CHECK(acks.back().ack_seq == 7);
}

TEST_CASE("mapstored options: max_reorder_bytes holds at least one largest chunk", "[mapstore_stream]") {
  MapStoreServerOptions so;
  so.root = "/tmp";
  CHECK(so.Validate() == "");
  so.max_reorder_bytes = MapStoreServerOptions::kMaxChunkPayloadBytes - 1;
  CHECK_THAT(so.Validate(), Catch::Contains("max_reorder_bytes: expected >= 67108864"));
}
