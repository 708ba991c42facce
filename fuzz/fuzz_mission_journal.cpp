// The mission journal's recovery (mapstore/stream/mission_journal.h): vilma-mapstored reads a
// journal it finds after a crash, cuts a torn tail and appends from there.
#include <cstddef>
#include <cstdint>
#include <exception>
#include <filesystem>
#include <vector>

#include "fuzz_util.h"
#include "vilma/mapstore/stream/mission_journal.h"
#include <string>
#include "vilma/mapstore/map_io.h"
#include "vilma/mapstore/stream/synthetic_mission.h"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  vilma::fuzz::WriteSeedsIfAsked([] {
    const std::filesystem::path path = vilma::fuzz::ScratchDir("journal") / "seed.journal";
    std::filesystem::remove(path);
    vilma::mapstore::SyntheticMissionOptions options;
    options.vertices = 4;
    options.vertices_per_delta = 2;
    options.keypoints_per_frame = 8;
    options.landmarks_per_vertex = 3;
    options.imu_samples_per_edge = 2;
    auto journal = vilma::mapstore::MissionJournal::Create(path.string(), "seed header");
    int64_t seq = 1;
    for (const auto& delta : vilma::mapstore::MakeSyntheticMissionDeltas(options)) {
      journal->Append(seq++, vilma::mapstore::JournalRecordType::kData,
                      vilma::mapstore::SerializeMissionDelta(delta));
    }
    journal->Append(seq, vilma::mapstore::JournalRecordType::kEnd, "");
    journal->Sync();
    journal.reset();
    return std::vector<std::string>{vilma::fuzz::ReadText(path)};
  });
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  const std::filesystem::path path = vilma::fuzz::ScratchDir("journal") / "mission.journal";
  vilma::fuzz::WriteBytes(path, data, size);
  try {
    vilma::mapstore::JournalRecovery read_recovery;
    vilma::mapstore::MissionJournal::Read(path.string(), &read_recovery);
    vilma::mapstore::JournalRecovery recovery;
    std::vector<vilma::mapstore::JournalRecord> records;
    auto journal = vilma::mapstore::MissionJournal::Recover(path.string(), &records, &recovery);
    if (journal) {
      journal->Append(1000000, vilma::mapstore::JournalRecordType::kData, "after recovery");
      journal->Sync();
    }
  } catch (const std::exception&) {
  }
  return 0;
}
