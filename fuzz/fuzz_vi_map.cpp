// VI-map folders (mapstore/map_io.h): the manifest and the protobuf chunks. A small synthetic
// map is saved once; each input replaces one of its files (the first byte picks which). For a
// data file the manifest's size and CRC-32 are patched to match, so that the bytes reach the
// protobuf parser and the map's reference checks instead of stopping at the checksum. Half of
// the seed map's vertices carry refined keypoint sigmas (the optional field of 195aa8e).
#include <cstddef>
#include <cstdint>
#include <exception>
#include <filesystem>
#include <regex>
#include <string>
#include <vector>

#include "fuzz_util.h"
#include "vilma/mapstore/checksum.h"
#include "vilma/mapstore/consistency.h"
#include "vilma/mapstore/map_io.h"
#include "vilma/mapstore/stream/synthetic_mission.h"

namespace fs = std::filesystem;

namespace {

struct SeedMap {
  fs::path folder;
  std::string manifest;             // original manifest text
  std::vector<std::string> files;   // data files listed in the manifest (relative paths)
  std::vector<std::string> contents;  // their original bytes
  // The manifest around each file's entry `path: <file>, size: N, crc32: "XXXXXXXX"`, found
  // once here (std::regex per input took about half of the harness's own time).
  std::vector<std::string> before_entry, after_entry;
};

// The manifest with file `index`'s entry giving `size` and `crc`.
std::string PatchedManifest(const SeedMap& s, std::size_t index, std::size_t size, uint32_t crc) {
  return s.before_entry[index] + "path: " + s.files[index] + ", size: " + std::to_string(size) +
         ", crc32: \"" + vilma::mapstore::Crc32Hex(crc) + "\"" + s.after_entry[index];
}

const SeedMap& Seed() {
  static const SeedMap seed = [] {
    SeedMap s;
    s.folder = vilma::fuzz::ScratchDir("vi_map") / "map";
    vilma::mapstore::SyntheticMissionOptions options;
    options.vertices = 6;
    options.vertices_per_delta = 2;
    options.keypoints_per_frame = 12;
    options.landmarks_per_vertex = 4;
    options.imu_samples_per_edge = 3;
    vilma::mapstore::VIMap map = vilma::mapstore::ApplyDeltas(
        vilma::mapstore::MakeSyntheticMissionDeltas(options));
    // Refined keypoints' sigmas on every other vertex, so that the seeds carry the optional
    // `keypoint_sigmas_px` field (written only when a frame differs from the default).
    int k = 0;
    for (const auto& mission_id : map.mission_ids()) {
      for (const auto& vertex_id : map.vertex_ids(mission_id)) {
        if (k++ % 2 != 0) continue;
        for (auto& frame : map.vertex(vertex_id).frames) {
          for (std::size_t i = 0; i < frame.keypoints.size(); ++i) {
            frame.keypoints[i].sigma_px = 0.15 + 0.05 * static_cast<double>(i % 3);
          }
        }
      }
    }
    vilma::mapstore::SaveMap(map, s.folder.string());
    s.manifest = vilma::fuzz::ReadText(s.folder / "manifest.yaml");
    const std::regex entry(R"(path: ([^,}]+),)");
    for (std::sregex_iterator it(s.manifest.begin(), s.manifest.end(), entry), end; it != end;
         ++it) {
      s.files.push_back((*it)[1]);
    }
    for (const std::string& file : s.files) {
      s.contents.push_back(vilma::fuzz::ReadText(s.folder / file));
      const std::regex listed("path: " + std::regex_replace(file, std::regex(R"([.^$|()\[\]{}*+?\\])"), R"(\$&)") +
                              R"(, size: [0-9]+, crc32: "[0-9a-fA-Fx]+")");
      std::smatch match;
      if (!std::regex_search(s.manifest, match, listed)) __builtin_trap();
      s.before_entry.push_back(match.prefix());
      s.after_entry.push_back(match.suffix());
      // The splice must give what the manifest's writer gives for the same size and CRC, or
      // the replaced bytes stop at the size and CRC check. (Until 2026-11-27 a regex without
      // the writer's "0x" matched nothing: no data file input ever reached the parser.)
      const std::size_t i = s.before_entry.size() - 1;
      if (PatchedManifest(s, i, s.contents[i].size(), vilma::mapstore::Crc32(s.contents[i])) !=
          s.manifest) {
        __builtin_trap();
      }
    }
    return s;
  }();
  return seed;
}

}  // namespace

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  vilma::fuzz::WriteSeedsIfAsked([] {
    const SeedMap& seed = Seed();
    std::vector<std::string> seeds;
    for (std::size_t i = 0; i < seed.files.size(); ++i) {
      seeds.push_back(vilma::fuzz::WithPrefix(static_cast<uint8_t>(i),
                                              vilma::fuzz::ReadText(seed.folder / seed.files[i])));
    }
    seeds.push_back(vilma::fuzz::WithPrefix(static_cast<uint8_t>(seed.files.size()), seed.manifest));
    return seeds;
  });
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const SeedMap& seed = Seed();
  const std::size_t choice = data[0] % (seed.files.size() + 1);
  const uint8_t* bytes = data + 1;
  const std::size_t num_bytes = size - 1;
  std::string manifest = seed.manifest;
  fs::path replaced;
  std::string original;
  if (choice == seed.files.size()) {
    replaced = seed.folder / "manifest.yaml";
    original = seed.manifest;
  } else {
    replaced = seed.folder / seed.files[choice];
    original = seed.contents[choice];
    manifest = PatchedManifest(seed, choice, num_bytes, vilma::mapstore::Crc32(bytes, num_bytes));
    vilma::fuzz::WriteBytes(seed.folder / "manifest.yaml",
                            reinterpret_cast<const uint8_t*>(manifest.data()), manifest.size());
  }
  vilma::fuzz::WriteBytes(replaced, bytes, num_bytes);
  try {
    const vilma::mapstore::VIMap map = vilma::mapstore::LoadMap(seed.folder.string());
    vilma::mapstore::CheckMapConsistency(map);
  } catch (const std::exception&) {
  }
  // Restore the seed for the next input.
  vilma::fuzz::WriteBytes(replaced, reinterpret_cast<const uint8_t*>(original.data()),
                          original.size());
  vilma::fuzz::WriteBytes(seed.folder / "manifest.yaml",
                          reinterpret_cast<const uint8_t*>(seed.manifest.data()),
                          seed.manifest.size());
  return 0;
}
