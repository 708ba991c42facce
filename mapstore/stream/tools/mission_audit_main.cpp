// vilma-mission-audit: were the acknowledged vertices of a mission stream kept? For the crash
// campaign (scripts/crash-campaign.sh, docs/reliability.md): lcm-logger records the mission
// stream (VILMA_MISSION chunks and VILMA_MISSION_ACK acks) while processes are killed; the
// audit takes, per mission, the highest ack_seq mapstored sent (chunks 0..ack_seq durable), the
// vertex ids of those chunks (the chunks' payloads are mission deltas), and looks them up in
// the map folders under mapstored's root.
#include <cstdint>
#include <filesystem>
#include <iostream>
#include <map>
#include <set>
#include <string>

#include "vilma/drivers/lcm_log.h"
#include "vilma/drivers/lcm_safe_decode.h"
#include "vilma/mapstore/map_io.h"

namespace fs = std::filesystem;

namespace {

const char kUsage[] = R"(Usage: vilma-mission-audit LOG ROOT [--channel-suffix S]

LOG is an lcm-logger file of the mission stream (VILMA_MISSION and VILMA_MISSION_ACK, with
the suffix); ROOT is vilma-mapstored's --root. For every mission in LOG: the highest ack_seq
acknowledged with status OK or COMPLETE, the vertices of the chunks 0..ack_seq (their payloads
parsed as mission deltas; each vertex counted once, also when a later chunk re-sends it), and
whether each of them is in a map folder under ROOT that loads.
Prints one line per mission and a summary:
  mission <id> "<name>": acked seq 12, acknowledged vertices 118, stored 118, lost 0
  audit: missions 2, acknowledged vertices 230, lost 0, unloadable maps 0, unseen chunks 0
"unseen chunks": acknowledged chunks the logger did not record (their vertices cannot be
checked; UDP loss at the logger).

Exit status: 0 when no acknowledged vertex is lost and every map folder loads, 1 otherwise
or on an unreadable log, 2 on bad options.
)";

struct MissionAudit {
  std::string name;
  int64_t acked_seq = -1;
  std::map<int64_t, std::set<std::string>> vertices_by_seq;  // chunk seq -> vertex ids (hex)
};

}  // namespace

int main(int argc, char** argv) {
  std::string log_path, root, suffix;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      std::cout << kUsage;
      return 0;
    } else if (a == "--channel-suffix" && i + 1 < argc) {
      suffix = argv[++i];
    } else if (!a.empty() && a[0] != '-' && log_path.empty()) {
      log_path = a;
    } else if (!a.empty() && a[0] != '-' && root.empty()) {
      root = a;
    } else {
      std::cerr << "vilma-mission-audit: unexpected argument '" << a << "'\n(see --help)\n";
      return 2;
    }
  }
  if (log_path.empty() || root.empty()) {
    std::cerr << "vilma-mission-audit: LOG and ROOT are required\n(see --help)\n";
    return 2;
  }
  const std::string chunk_channel = "VILMA_MISSION" + suffix;
  const std::string ack_channel = "VILMA_MISSION_ACK" + suffix;
  std::map<std::string, MissionAudit> missions;  // by mission id (hex)
  int64_t undecodable = 0;
  try {
    vilma::LcmLogReader reader(log_path);
    vilma::LcmLogEvent event;
    while (reader.Next(&event)) {
      const int size = static_cast<int>(event.data.size());
      if (event.channel == chunk_channel) {
        vilma::mission_chunk_t chunk;
        if (!vilma::DecodeMissionChunk(event.data.data(), size, &chunk).empty()) {
          ++undecodable;
          continue;
        }
        MissionAudit& m = missions[chunk.mission_id];
        if (!chunk.mission_name.empty()) m.name = chunk.mission_name;
        std::set<std::string>& ids = m.vertices_by_seq[chunk.seq];  // END: an empty set
        if ((chunk.flags & vilma::mission_chunk_t::FLAG_DATA) == 0 || !ids.empty()) continue;
        try {
          const std::string payload(chunk.payload.begin(), chunk.payload.end());
          const vilma::mapstore::MissionDelta delta =
              vilma::mapstore::ParseMissionDelta(payload, "chunk " + std::to_string(chunk.seq));
          for (const auto& v : delta.vertices) ids.insert(v.id.Hex());
        } catch (const std::exception&) {
          ++undecodable;  // mapstored rejects it as well (checksum / parse): never acknowledged
        }
      } else if (event.channel == ack_channel) {
        vilma::mission_ack_t ack;
        if (!vilma::DecodeMissionAck(event.data.data(), size, &ack).empty()) {
          ++undecodable;
          continue;
        }
        if (ack.status != vilma::mission_ack_t::OK && ack.status != vilma::mission_ack_t::COMPLETE) {
          continue;
        }
        MissionAudit& m = missions[ack.mission_id];
        m.acked_seq = std::max(m.acked_seq, ack.ack_seq);
      }
    }
  } catch (const std::exception& e) {
    std::cerr << "vilma-mission-audit: error: " << e.what() << "\n";
    return 1;
  }

  // Every vertex stored under ROOT, by mission id; folders that do not load are counted.
  std::map<std::string, std::set<std::string>> stored;
  int64_t unloadable = 0;
  if (fs::is_directory(root)) {
    for (const fs::directory_entry& entry : fs::directory_iterator(root)) {
      // Map folders; ".journal" (mapstored's open missions) and other dot folders are not maps.
      if (!entry.is_directory() || entry.path().filename().string().rfind('.', 0) == 0) continue;
      try {
        const vilma::mapstore::VIMap map = vilma::mapstore::LoadMap(entry.path().string());
        for (const auto& mission_id : map.mission_ids()) {
          for (const auto& vertex_id : map.vertex_ids(mission_id)) {
            stored[mission_id.Hex()].insert(vertex_id.Hex());
          }
        }
      } catch (const std::exception& e) {
        ++unloadable;
        std::cout << "unloadable map " << entry.path().string() << ": " << e.what() << "\n";
      }
    }
  }
  int64_t total_acked = 0, total_lost = 0, unseen = 0;
  for (const auto& [id, m] : missions) {
    // Distinct vertices: the incremental stream sends a vertex twice (first without landmark
    // ids, then in its final form), which must count once.
    std::set<std::string> acked_ids;
    for (int64_t seq = 0; seq <= m.acked_seq; ++seq) {
      const auto it = m.vertices_by_seq.find(seq);
      if (it == m.vertices_by_seq.end()) {
        ++unseen;
        continue;
      }
      acked_ids.insert(it->second.begin(), it->second.end());
    }
    const int64_t acked = static_cast<int64_t>(acked_ids.size());
    int64_t lost = 0;
    for (const std::string& v : acked_ids) lost += stored[id].count(v) == 0;
    std::cout << "mission " << id << " \"" << m.name << "\": acked seq " << m.acked_seq
              << ", acknowledged vertices " << acked << ", stored " << stored[id].size()
              << ", lost " << lost << "\n";
    total_acked += acked;
    total_lost += lost;
  }
  std::cout << "audit: missions " << missions.size() << ", acknowledged vertices " << total_acked
            << ", lost " << total_lost << ", unloadable maps " << unloadable << ", unseen chunks "
            << unseen << ", undecodable events " << undecodable << "\n";
  return total_lost == 0 && unloadable == 0 ? 0 : 1;
}
