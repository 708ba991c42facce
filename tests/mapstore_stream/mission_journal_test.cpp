#include "vilma/mapstore/stream/mission_journal.h"

#include <catch2/catch.hpp>
#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <fstream>
#include <sstream>

#include "vilma/core/error.h"
#include "vilma/mapstore/checksum.h"

using namespace vilma::mapstore;

namespace {

std::string FreshPath(const std::string& name) {
  const std::string dir = "/tmp/vilma_mapstore_stream_test_" + std::to_string(::getpid());
  ::mkdir(dir.c_str(), 0755);
  const std::string path = dir + "/" + name + ".journal";
  ::unlink(path.c_str());
  return path;
}

std::string ReadBytes(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}
void WriteBytes(const std::string& path, const std::string& bytes) {
  std::ofstream out(path, std::ios::binary | std::ios::trunc);
  out.write(bytes.data(), static_cast<std::streamsize>(bytes.size()));
}

std::string Payload(int i) { return std::string(static_cast<std::size_t>(10 + 37 * i), static_cast<char>('a' + i)); }

// A journal with a header and records 0..n-1; returns the file size after each record.
std::vector<uint64_t> WriteJournal(const std::string& path, int n) {
  auto journal = MissionJournal::Create(path, "mission_id=x\n");
  std::vector<uint64_t> sizes{journal->size()};
  for (int i = 0; i < n; ++i) {
    REQUIRE(journal->Append(i, i + 1 == n ? JournalRecordType::kEnd : JournalRecordType::kData,
                            Payload(i)) == 0);
    sizes.push_back(journal->size());
  }
  REQUIRE(journal->Sync() == 0);
  return sizes;
}

}  // namespace

TEST_CASE("journal records round trip", "[mapstore_stream]") {
  const std::string path = FreshPath("round_trip");
  const auto sizes = WriteJournal(path, 5);
  JournalRecovery recovery;
  const auto records = MissionJournal::Read(path, &recovery);
  REQUIRE(records.size() == 6);
  CHECK(records[0].type == JournalRecordType::kHeader);
  CHECK(records[0].payload == "mission_id=x\n");
  for (int i = 0; i < 5; ++i) {
    CHECK(records[i + 1].seq == i);
    CHECK(records[i + 1].payload == Payload(i));
  }
  CHECK(records[5].type == JournalRecordType::kEnd);
  CHECK(recovery.discarded_bytes == 0);
  CHECK(recovery.valid_bytes == sizes.back());
  CHECK(recovery.reason.empty());
  // Creating over an existing journal is refused.
  CHECK_THROWS_AS(MissionJournal::Create(path, "x"), vilma::InputError);
}

TEST_CASE("journal recovery cuts a torn tail at every offset", "[mapstore_stream]") {
  const std::string path = FreshPath("torn");
  const auto sizes = WriteJournal(path, 4);
  const std::string full = ReadBytes(path);
  // Cut the file at every byte inside the last two records: the valid prefix survives.
  for (uint64_t cut = sizes[2] + 1; cut < sizes.back(); ++cut) {
    WriteBytes(path, full.substr(0, cut));
    std::vector<JournalRecord> records;
    JournalRecovery recovery;
    auto journal = MissionJournal::Recover(path, &records, &recovery);
    const uint64_t expected_size = cut >= sizes[3] ? sizes[3] : sizes[2];
    INFO("cut at " << cut);
    REQUIRE(recovery.valid_bytes == expected_size);
    CHECK(recovery.discarded_bytes == cut - expected_size);
    CHECK(records.size() == (expected_size == sizes[3] ? 4u : 3u));
    CHECK((recovery.discarded_bytes == 0) == recovery.reason.empty());
    // Appending after recovery continues a valid journal.
    REQUIRE(journal->Append(99, JournalRecordType::kData, "next") == 0);
    REQUIRE(journal->Sync() == 0);
    journal.reset();
    const auto again = MissionJournal::Read(path, &recovery);
    CHECK(recovery.discarded_bytes == 0);
    REQUIRE(again.back().seq == 99);
    CHECK(again.back().payload == "next");
    CHECK(again.size() == records.size() + 1);
  }
}

TEST_CASE("journal detects CRC corruption and keeps the cut bytes", "[mapstore_stream]") {
  const std::string path = FreshPath("crc");
  const auto sizes = WriteJournal(path, 4);
  std::string bytes = ReadBytes(path);
  const std::size_t flip = sizes[2] + 20;  // inside record seq 2's payload
  bytes[flip] = static_cast<char>(bytes[flip] ^ 0x01);
  WriteBytes(path, bytes);
  JournalRecovery recovery;
  const auto read = MissionJournal::Read(path, &recovery);
  CHECK(read.size() == 3);  // header, seq 0, seq 1
  CHECK(recovery.reason == "CRC mismatch at offset " + std::to_string(sizes[2]));
  CHECK(ReadBytes(path).size() == bytes.size());  // Read does not modify
  std::vector<JournalRecord> records;
  MissionJournal::Recover(path, &records, &recovery);
  CHECK(records.size() == 3);
  CHECK(ReadBytes(path).size() == sizes[2]);
  CHECK(ReadBytes(path + ".discarded-" + std::to_string(sizes[2])) == bytes.substr(sizes[2]));
}

TEST_CASE("journal rejects foreign files", "[mapstore_stream]") {
  const std::string path = FreshPath("foreign");
  WriteBytes(path, "NOTAJOURNAL.....");
  JournalRecovery recovery;
  REQUIRE_THROWS_WITH(MissionJournal::Read(path, &recovery),
                      Catch::Contains(path) && Catch::Contains("magic"));
  std::string bytes = "VILMAJNL";
  bytes += std::string("\x07\x00\x00\x00", 4);
  WriteBytes(path, bytes);
  REQUIRE_THROWS_WITH(MissionJournal::Read(path, &recovery), Catch::Contains("version"));
}

TEST_CASE("journal write errors leave no partial record", "[mapstore_stream]") {
  const std::string path = FreshPath("enospc");
  int fail_with = 0;
  auto journal = MissionJournal::Create(path, "h", [&](const char*) { return fail_with; });
  REQUIRE(journal->Append(0, JournalRecordType::kData, "zero") == 0);
  const uint64_t size = journal->size();
  fail_with = ENOSPC;
  CHECK(journal->Append(1, JournalRecordType::kData, "one") == ENOSPC);
  CHECK(journal->Sync() == ENOSPC);
  CHECK(journal->size() == size);
  fail_with = 0;
  REQUIRE(journal->Append(1, JournalRecordType::kData, "one") == 0);
  REQUIRE(journal->Sync() == 0);
  // Creating a journal on a full disk reports the errno instead of throwing when asked.
  int err = 0;
  fail_with = ENOSPC;
  CHECK(MissionJournal::Create(FreshPath("enospc2"), "h", [&](const char*) { return fail_with; }, &err) == nullptr);
  CHECK(err == ENOSPC);
  JournalRecovery recovery;
  const auto records = MissionJournal::Read(path, &recovery);
  REQUIRE(records.size() == 3);
  CHECK(records[2].payload == "one");
}

TEST_CASE("journal record bytes: length, CRC over seq + type + payload, seq, type, payload",
          "[mapstore_stream]") {
  const std::string path = FreshPath("record_bytes");
  // A large payload (several MB: more than one write may be needed) and an empty one.
  std::string large(static_cast<std::size_t>(3) << 20, '\0');
  for (std::size_t i = 0; i < large.size(); ++i) large[i] = static_cast<char>((i * 131) % 251);
  uint64_t header_end = 0;
  {
    auto journal = MissionJournal::Create(path, "mission_id=y\n");
    header_end = journal->size();
    REQUIRE(journal->Append(41, JournalRecordType::kData, large) == 0);
    REQUIRE(journal->Append(42, JournalRecordType::kEnd, std::string()) == 0);
    CHECK(journal->size() == header_end + 17 + large.size() + 17);
    REQUIRE(journal->Sync() == 0);
  }
  const std::string bytes = ReadBytes(path);
  REQUIRE(bytes.size() == header_end + 17 + large.size() + 17);
  auto u32 = [&](std::size_t at) {
    uint32_t v = 0;
    for (int k = 3; k >= 0; --k) v = (v << 8) | static_cast<uint8_t>(bytes[at + k]);
    return v;
  };
  auto u64 = [&](std::size_t at) {
    uint64_t v = 0;
    for (int k = 7; k >= 0; --k) v = (v << 8) | static_cast<uint8_t>(bytes[at + k]);
    return v;
  };
  const std::size_t r = header_end;
  CHECK(u32(r) == large.size());
  CHECK(u64(r + 8) == 41);
  CHECK(static_cast<uint8_t>(bytes[r + 16]) == static_cast<uint8_t>(JournalRecordType::kData));
  CHECK(bytes.compare(r + 17, large.size(), large) == 0);
  // The CRC of the contiguous bytes seq .. end of payload, as the reader checks it.
  CHECK(u32(r + 4) == Crc32(bytes.data() + r + 8, 9 + large.size()));
  const std::size_t e = r + 17 + large.size();
  CHECK(u32(e) == 0);
  CHECK(u64(e + 8) == 42);
  CHECK(u32(e + 4) == Crc32(bytes.data() + e + 8, 9));
  const auto records = MissionJournal::Read(path, nullptr);
  REQUIRE(records.size() == 3);
  CHECK(records[1].payload == large);
  CHECK(records[2].type == JournalRecordType::kEnd);
}
