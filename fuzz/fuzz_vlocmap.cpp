// Localization map files (.vlocmap, localizer/localization_map.h) as vilma-estimatord and
// `vilma localize` load them. The file ends with the CRC-32 of everything before it; the
// harness appends that checksum to the input, so that the bytes reach the field checks
// instead of stopping at the checksum (a corrupted file with a wrong CRC is the easy case).
#include <cstddef>
#include <cstdint>
#include <cstring>
#include <exception>
#include <filesystem>
#include <string>
#include <vector>

#include "fuzz_util.h"
#include "vilma/mapping/locmap/localization_map_builder.h"
#include "vilma/mapstore/checksum.h"
#include "vilma/mapstore/stream/synthetic_mission.h"

// Seed: a localization map of a small synthetic mission, without its trailing checksum.
extern "C" int LLVMFuzzerInitialize(int*, char***) {
  vilma::fuzz::WriteSeedsIfAsked([] {
    const std::filesystem::path path = vilma::fuzz::ScratchDir("vlocmap") / "seed.vlocmap";
    vilma::mapstore::SyntheticMissionOptions mission;
    mission.vertices = 4;
    mission.keypoints_per_frame = 8;
    mission.landmarks_per_vertex = 4;
    const vilma::mapstore::VIMap vimap =
        vilma::mapstore::ApplyDeltas(vilma::mapstore::MakeSyntheticMissionDeltas(mission));
    vilma::localizer::LocalizationMapOptions options;
    options.min_observations = 1;  // the synthetic mission's landmarks have one observer each
    vilma::localizer::SaveLocalizationMap(vilma::mapping::BuildLocalizationMap(vimap, options),
                                          path.string());
    std::string bytes = vilma::fuzz::ReadText(path);
    bytes.resize(bytes.size() >= 4 ? bytes.size() - 4 : 0);
    return std::vector<std::string>{bytes};
  });
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  std::string bytes(reinterpret_cast<const char*>(data), size);
  const uint32_t crc = vilma::mapstore::Crc32(bytes.data(), bytes.size());
  char crc_bytes[4];
  std::memcpy(crc_bytes, &crc, 4);  // little endian, as the file stores it
  bytes.append(crc_bytes, 4);
  const std::filesystem::path path = vilma::fuzz::ScratchDir("vlocmap") / "map.vlocmap";
  vilma::fuzz::WriteBytes(path, reinterpret_cast<const uint8_t*>(bytes.data()), bytes.size());
  try {
    vilma::localizer::LoadLocalizationMap(path.string());
  } catch (const std::exception&) {
  }
  return 0;
}
