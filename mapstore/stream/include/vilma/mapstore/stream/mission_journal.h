// Append-only journal of one streamed mission, kept by vilma-mapstored under
// <root>/.journal/<mission id>.journal (docs/mapstore.md "Journal format").
//
//   file   = magic "VILMAJNL" (8 bytes) | version u32 LE (= 1) | record*
//   record = length u32 LE | crc u32 LE | seq i64 LE | type u8 | payload[length]
//            crc = CRC-32 (mapstore/checksum.h) over seq, type and payload (13 + length bytes
//            after the crc field), so a torn or flipped byte anywhere in the record is caught.
//
// Records are written with one write() each and made durable with Sync() (fsync) before the
// server acknowledges them: acknowledged data is on disk. Recovery reads the longest valid
// prefix and cuts the file there (a torn tail is data that was never acknowledged); the cut
// bytes are kept beside the journal in <journal>.discarded-<offset> for forensics, since a CRC
// error in the middle of the file (media corruption) would otherwise vanish without trace.
#pragma once

#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <vector>

namespace vilma {
namespace mapstore {

enum class JournalRecordType : uint8_t { kHeader = 1, kData = 2, kEnd = 3 };

struct JournalRecord {
  int64_t seq = -1;
  JournalRecordType type = JournalRecordType::kData;
  std::string payload;
};

struct JournalRecovery {
  uint64_t records = 0;          // valid records kept
  uint64_t valid_bytes = 0;      // file size after recovery
  uint64_t discarded_bytes = 0;  // bytes cut from the tail
  std::string reason;            // why the tail was cut ("" if nothing was)
};

// Fault injection for tests: called before every write ("write") and fsync ("fsync"); a
// non-zero return is taken as that call's errno (e.g. ENOSPC) without touching the file.
using JournalFaultHook = std::function<int(const char* operation)>;

class MissionJournal {
 public:
  // Creates a new journal at `path` (which must not exist) whose first record is a kHeader
  // with `header_payload`, synced. Throws InputError naming the path on I/O errors.
  // With `error` given, failures return nullptr and set *error to the errno instead.
  static std::unique_ptr<MissionJournal> Create(const std::string& path,
                                                const std::string& header_payload,
                                                JournalFaultHook fault_hook = {},
                                                int* error = nullptr);
  // Opens an existing journal for appending after recovering it: reads the valid prefix into
  // `records`, truncates the rest. Throws InputError when the file cannot be opened or has a
  // wrong magic or version.
  static std::unique_ptr<MissionJournal> Recover(const std::string& path,
                                                 std::vector<JournalRecord>* records,
                                                 JournalRecovery* recovery,
                                                 JournalFaultHook fault_hook = {});
  // Read-only: the valid prefix of the journal at `path` (does not modify the file).
  static std::vector<JournalRecord> Read(const std::string& path, JournalRecovery* recovery);

  ~MissionJournal();
  MissionJournal(const MissionJournal&) = delete;
  MissionJournal& operator=(const MissionJournal&) = delete;

  // Appends one record (not yet durable). Returns 0 or the errno of the failure; after a
  // failure the file is cut back to its previous size so that no partial record remains.
  int Append(int64_t seq, JournalRecordType type, const std::string& payload);
  // fsync. Returns 0 or errno. After a failed fsync the kernel may have dropped the dirty
  // pages while marking them clean, so the caller cuts the file back (TruncateTo) to the last
  // size that was synced and has the data sent again.
  int Sync();
  // Cuts the file to `size` bytes (a record boundary) and appends from there. 0 or errno.
  int TruncateTo(uint64_t size);

  const std::string& path() const { return path_; }
  uint64_t size() const { return size_; }

 private:
  MissionJournal(std::string path, int fd, uint64_t size, JournalFaultHook hook);
  std::string path_;
  int fd_ = -1;
  uint64_t size_ = 0;
  JournalFaultHook fault_hook_;
};

}  // namespace mapstore
}  // namespace vilma
