// LCM log files in lcm-logger's format (read by lcm-logplayer, lcm-logplayer-gui, and the
// language bindings' log readers), on top of lcm::LogFile.
//
// An event is (timestamp [us], channel, payload). lcm-logger stamps events with the receive
// time; vilma's writers (vilma-replay --to-log) stamp them with the message's own utime, so
// that lcm-logplayer replays at the original rate and offline readers are deterministic.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

namespace lcm {
class LogFile;
}

namespace vilma {

struct LcmLogEvent {
  int64_t timestamp_us = 0;  // event time [us]
  std::string channel;
  std::vector<uint8_t> data;  // the encoded message, as published
};

// Writes a log. To leave nothing half-written under the final name, events go to
// "<path>.partial", which Close() flushes, fsyncs and renames to `path`; if the writer is
// destroyed without Close() (an exception unwinding), the ".partial" file stays for inspection.
class LcmLogWriter {
 public:
  // Throws InputError naming the path if the file cannot be created.
  explicit LcmLogWriter(const std::string& path);
  ~LcmLogWriter();
  LcmLogWriter(const LcmLogWriter&) = delete;
  LcmLogWriter& operator=(const LcmLogWriter&) = delete;

  // Throws InputError on a write error (e.g. a full disk).
  void Write(const std::string& channel, const void* data, int size, int64_t timestamp_us);

  // Encodes an lcm-gen message and writes it.
  template <typename Msg>
  void WriteMessage(const std::string& channel, const Msg& msg, int64_t timestamp_us) {
    buffer_.resize(static_cast<size_t>(msg.getEncodedSize()));
    msg.encode(buffer_.data(), 0, static_cast<int>(buffer_.size()));
    Write(channel, buffer_.data(), static_cast<int>(buffer_.size()), timestamp_us);
  }

  // Finishes the file (see above). Idempotent. Throws InputError on failure.
  void Close();

  int64_t num_events() const { return num_events_; }
  int64_t num_bytes() const { return num_bytes_; }  // payload bytes written
  const std::string& path() const { return path_; }

 private:
  std::string path_;
  std::string partial_path_;
  std::unique_ptr<lcm::LogFile> log_;
  std::vector<uint8_t> buffer_;
  int64_t num_events_ = 0;
  int64_t num_bytes_ = 0;
};

// Reads a log event by event.
class LcmLogReader {
 public:
  // Throws InputError naming the path if the file cannot be opened.
  explicit LcmLogReader(const std::string& path);
  ~LcmLogReader();
  LcmLogReader(const LcmLogReader&) = delete;
  LcmLogReader& operator=(const LcmLogReader&) = delete;

  // The next event into `event`; false at the end of the log (a truncated last event, as left
  // by a killed lcm-logger, or a corrupted header claiming more bytes than the file holds,
  // also ends the log).
  bool Next(LcmLogEvent* event);

 private:
  std::string path_;
  std::unique_ptr<lcm::LogFile> log_;
};

// All events of a log (for tests and small logs).
std::vector<LcmLogEvent> ReadLcmLog(const std::string& path);

}  // namespace vilma
