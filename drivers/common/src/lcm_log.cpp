#include "vilma/drivers/lcm_log.h"

#include <sys/stat.h>
#include <unistd.h>

#include <cerrno>
#include <cstdint>
#include <cstdio>
#include <cstring>
#include <lcm/lcm-cpp.hpp>

#include "vilma/core/atomic_file.h"
#include "vilma/core/error.h"

namespace vilma {

LcmLogWriter::LcmLogWriter(const std::string& path)
    : path_(path), partial_path_(path + ".partial") {
  log_ = std::make_unique<lcm::LogFile>(partial_path_, "w");
  if (!log_->good()) {
    const std::string reason = std::strerror(errno);
    log_.reset();
    throw InputError(FormatInputError(partial_path_, "", "a writable file (" + reason + ")"));
  }
}

LcmLogWriter::~LcmLogWriter() = default;  // closes the FILE*, leaves <path>.partial

void LcmLogWriter::Write(const std::string& channel, const void* data, int size,
                         int64_t timestamp_us) {
  if (!log_) throw InputError(FormatInputError(path_, "", "an open log (already closed)"));
  lcm::LogEvent event;
  event.eventnum = num_events_;
  event.timestamp = timestamp_us;
  event.channel = channel;
  event.datalen = size;
  event.data = const_cast<void*>(data);
  if (log_->writeEvent(&event) != 0) {
    throw InputError(FormatInputError(partial_path_, "event " + std::to_string(num_events_),
                                      std::string("a successful write (") +
                                          std::strerror(errno) + ")"));
  }
  ++num_events_;
  num_bytes_ += size;
}

void LcmLogWriter::Close() {
  if (!log_) return;
  FILE* file = log_->getFilePtr();
  const bool flushed = std::fflush(file) == 0;
  const int flush_errno = errno;
  log_.reset();
  if (!flushed) {
    throw InputError(FormatInputError(path_, "", std::string("a completed log (") +
                                                     std::strerror(flush_errno) + ")"));
  }
  // fsync, rename over the final name, fsync of the folder: core's one atomic writer.
  CommitFileAtomically(partial_path_, path_);
}

LcmLogReader::LcmLogReader(const std::string& path) : path_(path) {
  log_ = std::make_unique<lcm::LogFile>(path, "r");
  if (!log_->good()) {
    const std::string reason = std::strerror(errno);
    log_.reset();
    throw InputError(FormatInputError(path, "", "a readable LCM log file (" + reason + ")"));
  }
}

LcmLogReader::~LcmLogReader() = default;

namespace {

// liblcm's reader allocates the data length an event header claims before reading it (up to
// 2 GB from a few corrupted bytes: a hang under ASan, a failed allocation on a small robot
// computer; found by fuzz/fuzz_lcm_log). This finds the next event header the way liblcm
// does (scan for the sync word) and checks its lengths against the bytes left in the file,
// then rewinds to the sync word. False: no valid event follows (the end of the log).
bool NextEventHeaderIsPlausible(FILE* file) {
  constexpr uint32_t kSyncWord = 0xEDA1DA01;
  constexpr int32_t kMaxChannelLength = 1000;  // liblcm's own limit (eventlog.c)
  const long start = std::ftell(file);
  struct stat info;
  if (start < 0 || ::fstat(::fileno(file), &info) != 0) return true;  // let liblcm decide
  uint32_t word = 0;
  long sync_at = -1;
  for (int c; (c = std::fgetc(file)) != EOF;) {
    word = (word << 8) | static_cast<uint32_t>(c);
    if (word == kSyncWord) {
      sync_at = std::ftell(file) - 4;
      break;
    }
  }
  bool plausible = false;
  uint8_t header[24];  // event number, timestamp, channel length, data length (big endian)
  if (sync_at >= 0 && std::fread(header, 1, sizeof(header), file) == sizeof(header)) {
    const auto be32 = [&header](int at) {
      return static_cast<int32_t>((uint32_t{header[at]} << 24) | (uint32_t{header[at + 1]} << 16) |
                                  (uint32_t{header[at + 2]} << 8) | uint32_t{header[at + 3]});
    };
    const int32_t channel_length = be32(16);
    const int32_t data_length = be32(20);
    const int64_t left = static_cast<int64_t>(info.st_size) - (sync_at + 4 + 24);
    plausible = channel_length > 0 && channel_length < kMaxChannelLength && data_length >= 0 &&
                int64_t{channel_length} + data_length <= left;
  }
  std::fseek(file, sync_at >= 0 ? sync_at : start, SEEK_SET);
  return plausible;
}

}  // namespace

bool LcmLogReader::Next(LcmLogEvent* event) {
  if (!NextEventHeaderIsPlausible(log_->getFilePtr())) return false;
  const lcm::LogEvent* e = log_->readNextEvent();
  if (e == nullptr) return false;
  event->timestamp_us = e->timestamp;
  event->channel = e->channel;
  const auto* bytes = static_cast<const uint8_t*>(e->data);
  event->data.assign(bytes, bytes + e->datalen);
  return true;
}

std::vector<LcmLogEvent> ReadLcmLog(const std::string& path) {
  LcmLogReader reader(path);
  std::vector<LcmLogEvent> events;
  LcmLogEvent event;
  while (reader.Next(&event)) events.push_back(event);
  return events;
}

}  // namespace vilma
