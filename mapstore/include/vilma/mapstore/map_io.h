// Map folders (docs/vi-map.md):
//   <map>/manifest.yaml                         format version, generation, missions, every
//                                               data file with its size and CRC-32
//   <map>/missions/<mission>/g<generation>/mission.pb
//   <map>/missions/<mission>/g<generation>/{vertices,edges,landmarks}_<chunk>.pb
//   <map>/resources/<type>/<id>.<extension>
// A save writes every data file of a new generation (each atomically: temporary file, fsync,
// rename, directory fsync), then the manifest, last, the same way; only then are the previous
// generation's files deleted. A crash at any point leaves the previous manifest and every file
// it lists intact, so the previous map still loads.
#pragma once

#include <cstdint>
#include <string>

#include "vilma/mapstore/vi_map.h"

namespace vilma {
namespace mapstore {

// Version of the folder layout and protobuf schema this code writes. Readers accept versions
// 1..kMapFormatVersion and reject newer ones with a message asking for a newer vilma.
constexpr uint32_t kMapFormatVersion = 1;

struct MapSaveOptions {
  uint32_t vertices_per_chunk = 1000;   // vertices per vertices_<chunk>.pb
  uint32_t edges_per_chunk = 2000;      // edges per edges_<chunk>.pb
  uint32_t landmarks_per_chunk = 20000; // landmarks per landmarks_<chunk>.pb
  // Crash simulation for tests: write all data files of the new generation but neither the
  // manifest nor the cleanup (as if the process died right before the manifest's rename).
  bool stop_before_manifest = false;
  // Empty if valid, else "field: expectation".
  std::string Validate() const;
};

struct MapLoadOptions {
  ResourceCacheOptions resource_cache;
  // Verify every data file's CRC-32 against the manifest (costs about one pass over the
  // bytes; turn off only for trusted, freshly written maps).
  bool verify_checksums = true;
  std::string Validate() const;
};

struct MapSaveSummary {
  uint64_t generation = 0;
  uint64_t files_written = 0;
  uint64_t bytes_written = 0;
};

// Saves the whole map into `folder` (created if needed). Throws InputError on I/O errors and
// std::invalid_argument for invalid options or a map that cannot be serialized (e.g. a
// visual frame whose arrays disagree).
MapSaveSummary SaveMap(const VIMap& map, const std::string& folder,
                       const MapSaveOptions& options = {});

// Loads a map folder. Throws InputError "FILE: FIELD: expected ..." for a missing, truncated,
// corrupted (checksum), unparsable or wrong-version file, or a duplicate id. Resources are only
// indexed here and read on demand.
VIMap LoadMap(const std::string& folder, const MapLoadOptions& options = {});

// --- live mission stream ---
// A mission delta: the mission header plus new or changed vertices, edges and landmarks of one
// mission (the map builder emits one per batch; mapstored applies them in order).
struct MissionDelta {
  Mission mission;
  std::vector<Vertex> vertices;
  std::vector<Edge> edges;
  std::vector<Landmark> landmarks;
};
// Protobuf bytes of the delta (deterministic for equal deltas).
std::string SerializeMissionDelta(const MissionDelta& delta);
// Throws InputError naming `source_name` when the bytes are not a delta of a known version.
MissionDelta ParseMissionDelta(const std::string& bytes, const std::string& source_name);
// Upserts the mission, then vertices, edges, landmarks (in this order, so a delta may carry a
// vertex and the edge or landmarks that refer to it).
void ApplyMissionDelta(const MissionDelta& delta, VIMap* map);

}  // namespace mapstore
}  // namespace vilma
