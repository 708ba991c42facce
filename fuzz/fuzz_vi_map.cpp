// VI-map folders (mapstore/map_io.h): the manifest and the protobuf chunks. A small synthetic
// map is saved once; each input replaces one of its files (the first byte picks which). For a
// data file the manifest's size and CRC-32 are patched to match, so that the bytes reach the
// protobuf parser and the map's reference checks instead of stopping at the checksum.
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
};

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
    const vilma::mapstore::VIMap map = vilma::mapstore::ApplyDeltas(
        vilma::mapstore::MakeSyntheticMissionDeltas(options));
    vilma::mapstore::SaveMap(map, s.folder.string());
    s.manifest = vilma::fuzz::ReadText(s.folder / "manifest.yaml");
    const std::regex entry(R"(path: ([^,}]+),)");
    for (std::sregex_iterator it(s.manifest.begin(), s.manifest.end(), entry), end; it != end;
         ++it) {
      s.files.push_back((*it)[1]);
    }
    return s;
  }();
  return seed;
}

std::string Hex8(uint32_t value) {
  char buffer[9];
  std::snprintf(buffer, sizeof(buffer), "%08x", value);
  return buffer;
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
    const std::string& file = seed.files[choice];
    replaced = seed.folder / file;
    original = vilma::fuzz::ReadText(replaced);
    const std::regex entry("path: " + std::regex_replace(file, std::regex(R"([.^$|()\[\]{}*+?\\])"), R"(\$&)") +
                           R"(, size: [0-9]+, crc32: "[0-9a-fA-F]+")");
    manifest = std::regex_replace(
        manifest, entry,
        "path: " + file + ", size: " + std::to_string(num_bytes) + ", crc32: \"" +
            Hex8(vilma::mapstore::Crc32(bytes, num_bytes)) + "\"");
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
