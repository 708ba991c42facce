#include "vilma/drivers/lcm_log.h"

#include <unistd.h>

#include <cerrno>
#include <cstdio>
#include <cstring>
#include <lcm/lcm-cpp.hpp>

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
  const bool flushed = std::fflush(file) == 0 && ::fsync(fileno(file)) == 0;
  log_.reset();
  if (!flushed || std::rename(partial_path_.c_str(), path_.c_str()) != 0) {
    throw InputError(FormatInputError(path_, "", std::string("a completed log (") +
                                                     std::strerror(errno) + ")"));
  }
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

bool LcmLogReader::Next(LcmLogEvent* event) {
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
