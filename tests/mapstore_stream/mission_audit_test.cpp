// vilma-mission-audit (the crash campaign's check, docs/reliability.md): a recorded stream whose
// acknowledged chunks re-send a vertex (the daemon's incremental stream sends a vertex first
// without landmark ids, then in its final form) counts that vertex once; a vertex missing from
// the stored maps is counted lost and fails the audit.
#include <sys/wait.h>

#include <catch2/catch.hpp>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>
#include <vilma/mission_ack_t.hpp>
#include <vilma/mission_chunk_t.hpp>

#include "vilma/drivers/lcm_log.h"
#include "vilma/mapstore/map_io.h"
#include "vilma/mapstore/stream/synthetic_mission.h"

namespace fs = std::filesystem;

namespace vilma {
namespace {

vilma::mission_chunk_t Chunk(const mapstore::MissionDelta& delta, int64_t seq) {
  vilma::mission_chunk_t chunk;
  chunk.mission_id = delta.mission.id.Hex();
  chunk.mission_name = "audit";
  chunk.session_id = 5;
  chunk.seq = seq;
  chunk.flags = static_cast<int8_t>(vilma::mission_chunk_t::FLAG_DATA |
                                    (seq == 0 ? vilma::mission_chunk_t::FLAG_BEGIN : 0));
  const std::string payload = mapstore::SerializeMissionDelta(delta);
  chunk.payload.assign(payload.begin(), payload.end());
  chunk.payload_size = static_cast<int32_t>(payload.size());
  chunk.checksum = 0;  // the audit trusts what mapstored acknowledged; it does not check CRCs
  return chunk;
}

// Runs the tool; its stdout and exit status.
std::pair<std::string, int> Audit(const fs::path& log, const fs::path& root) {
  const fs::path out = log.parent_path() / "audit.txt";
  const std::string cmd = std::string(VILMA_BINARY_DIR) + "/bin/vilma-mission-audit " +
                          log.string() + " " + root.string() + " > " + out.string() + " 2>&1";
  const int status = std::system(cmd.c_str());
  std::ifstream in(out);
  std::stringstream text;
  text << in.rdbuf();
  return {text.str(), WIFEXITED(status) ? WEXITSTATUS(status) : -1};
}

TEST_CASE("mission audit: a vertex re-sent in a later acknowledged chunk counts once",
          "[mapstore][stream][audit]") {
  const fs::path dir = fs::path(VILMA_BINARY_DIR) / "test-cache" / "mission_audit";
  fs::remove_all(dir);
  fs::create_directories(dir / "root");
  mapstore::SyntheticMissionOptions options;
  options.vertices = 3;
  options.vertices_per_delta = 1;
  options.keypoints_per_frame = 10;
  options.landmarks_per_vertex = 2;
  const std::vector<mapstore::MissionDelta> deltas = mapstore::MakeSyntheticMissionDeltas(options);
  REQUIRE(deltas.size() == 3);

  // Chunks 0, 1, 2 = deltas 0, 1, 2, then chunk 3 re-sends delta 1's vertex; all acknowledged.
  const fs::path log = dir / "stream.lcmlog";
  {
    LcmLogWriter writer(log.string());
    for (int64_t seq = 0; seq < 3; ++seq) {
      writer.WriteMessage("VILMA_MISSION", Chunk(deltas[static_cast<std::size_t>(seq)], seq),
                          seq);
    }
    writer.WriteMessage("VILMA_MISSION", Chunk(deltas[1], 3), 3);
    vilma::mission_ack_t ack;
    ack.mission_id = deltas[0].mission.id.Hex();
    ack.session_id = 5;
    ack.ack_seq = 3;
    ack.status = vilma::mission_ack_t::OK;
    writer.WriteMessage("VILMA_MISSION_ACK", ack, 4);
    writer.Close();
  }

  SECTION("every vertex stored: 3 acknowledged (not 4), 0 lost, exit 0") {
    mapstore::SaveMap(mapstore::ApplyDeltas(deltas), (dir / "root" / "audit").string());
    const auto [text, status] = Audit(log, dir / "root");
    INFO(text);
    CHECK(text.find("acknowledged vertices 3, stored 3, lost 0") != std::string::npos);
    CHECK(text.find("audit: missions 1, acknowledged vertices 3, lost 0, unloadable maps 0") !=
          std::string::npos);
    CHECK(status == 0);
  }
  SECTION("the last vertex missing: 1 lost, exit 1") {
    mapstore::SaveMap(mapstore::ApplyDeltas({deltas[0], deltas[1]}),
                      (dir / "root" / "audit").string());
    const auto [text, status] = Audit(log, dir / "root");
    INFO(text);
    CHECK(text.find("acknowledged vertices 3, stored 2, lost 1") != std::string::npos);
    CHECK(status == 1);
  }
  fs::remove_all(dir);
}

}  // namespace
}  // namespace vilma
