// vilma-mapstored's handling of mission-stream messages (mapstore/stream/map_store_server.h):
// the input is a sequence of LCM-encoded mission_chunk_t, each behind a 2-byte little-endian
// length; every chunk that decodes goes to a fresh server (its own root folder), which acks,
// journals, reorders, applies the deltas and finalizes the mission at the end. No finalization
// may fail (the scratch folder is on tmpfs: no I/O error to expect), and every map folder it
// finalizes must then load and pass check_map_consistency.
#include <cstddef>
#include <cstdint>
#include <exception>
#include <filesystem>
#include <string>
#include <vector>

#include <vilma/mission_ack_t.hpp>
#include <vilma/mission_chunk_t.hpp>

#include "fuzz_util.h"
#include "vilma/drivers/lcm_safe_decode.h"
#include "vilma/mapstore/consistency.h"
#include "vilma/mapstore/map_io.h"
#include "vilma/mapstore/stream/map_store_server.h"
#include "vilma/mapstore/stream/mission_stream_sender.h"
#include "vilma/mapstore/stream/synthetic_mission.h"

namespace fs = std::filesystem;

// Seed: the chunks of a small synthetic mission as vilma-estimatord's sender publishes them.
extern "C" int LLVMFuzzerInitialize(int*, char***) {
  vilma::fuzz::WriteSeedsIfAsked([] {
    vilma::mapstore::SyntheticMissionOptions options;
    options.vertices = 4;
    options.vertices_per_delta = 2;
    options.keypoints_per_frame = 8;
    options.landmarks_per_vertex = 3;
    options.imu_samples_per_edge = 2;
    std::string stream;
    const auto publish = [&stream](const vilma::mission_chunk_t& chunk) {
      const int size = chunk.getEncodedSize();
      std::string bytes(static_cast<std::size_t>(size), '\0');
      chunk.encode(bytes.data(), 0, size);
      stream.push_back(static_cast<char>(size & 0xff));
      stream.push_back(static_cast<char>((size >> 8) & 0xff));
      stream += bytes;
    };
    vilma::mapstore::IdGenerator ids(7);
    const vilma::mapstore::MissionId id = ids.Next();
    vilma::mapstore::MissionStreamSender sender(id, "fuzz", vilma::mapstore::MissionStreamSenderOptions(),
                                               publish, 42);
    for (const auto& delta : vilma::mapstore::MakeSyntheticMissionDeltas(options)) sender.Send(delta);
    sender.End();
    return std::vector<std::string>{stream};
  });
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  std::vector<vilma::mission_chunk_t> chunks;
  for (std::size_t at = 0; at + 2 <= size;) {
    const std::size_t length = data[at] | (static_cast<std::size_t>(data[at + 1]) << 8);
    at += 2;
    if (length > size - at) break;
    vilma::mission_chunk_t chunk;  // decoded as vilma-mapstored does
    if (vilma::DecodeMissionChunk(data + at, static_cast<int>(length), &chunk).empty()) {
      chunks.push_back(chunk);
    }
    at += length;
  }
  if (chunks.empty()) return 0;
  const fs::path root = vilma::fuzz::ScratchDir("mission_stream") / "root";
  fs::remove_all(root);
  fs::create_directories(root);
  try {
    vilma::mapstore::MapStoreServerOptions options;
    options.root = root.string();
    options.max_reorder_chunks = 64;
    vilma::mapstore::MapStoreServer server(
        options, [](const vilma::mission_ack_t&) {}, [](const std::string&) {});
    server.Start();
    for (const vilma::mission_chunk_t& chunk : chunks) server.OnChunk(chunk);
    server.Flush();
    // Oracle: only the disk can fail a finalization (mapstore/mission_repair.h); whatever the
    // chunks carry is repaired, never a reason to retry for ever (before 2026-11-27 an edge
    // from a vertex never sent or a record that is not a delta failed it every time).
    if (server.counters().finalize_errors > 0) __builtin_trap();
    server.Shutdown();
  } catch (const std::exception&) {
  }
  // Oracle: whatever mapstored finalized must load and be consistent (a mission name that
  // was not UTF-8 once made a map folder that saved but never loaded).
  for (const auto& entry : fs::directory_iterator(root)) {
    const std::string name = entry.path().filename().string();
    if (name.empty() || name[0] == '.' || !entry.is_directory()) continue;
    try {
      if (!vilma::mapstore::CheckMapConsistency(vilma::mapstore::LoadMap(entry.path().string())).ok()) {
        __builtin_trap();
      }
    } catch (const std::exception&) {
      __builtin_trap();
    }
  }
  return 0;
}
