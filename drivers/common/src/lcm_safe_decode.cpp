#include "vilma/drivers/lcm_safe_decode.h"

#include <cstdint>
#include <exception>
#include <string>

namespace vilma {
namespace {

// Walks an LCM encoding (big-endian; strings as int32 length including the NUL, then the
// bytes) and checks every length against the bytes left.
class EncodingWalker {
 public:
  EncodingWalker(const void* data, int size)
      : data_(static_cast<const uint8_t*>(data)), size_(data == nullptr ? 0 : size) {}

  bool Skip(int64_t bytes) {
    if (!ok_ || bytes < 0 || bytes > size_ - at_) return Fail();
    at_ += bytes;
    return true;
  }
  bool Int32(int32_t* value) {
    if (!ok_ || size_ - at_ < 4) return Fail();
    const uint32_t v = (uint32_t{data_[at_]} << 24) | (uint32_t{data_[at_ + 1]} << 16) |
                       (uint32_t{data_[at_ + 2]} << 8) | uint32_t{data_[at_ + 3]};
    *value = static_cast<int32_t>(v);
    at_ += 4;
    return true;
  }
  // A string: its length field counts the terminating NUL, so it is at least 1.
  bool String(const char* field) {
    int32_t length = 0;
    if (!Int32(&length)) return Fail(field, "truncated before the string length");
    if (length < 1) return Fail(field, "string length " + std::to_string(length) + " < 1");
    if (length > size_ - at_) {
      return Fail(field, "string length " + std::to_string(length) + " beyond the message");
    }
    at_ += length;
    return true;
  }
  // An int32 element count followed by that many `element_bytes`-byte elements.
  bool CountedArray(const char* field, int element_bytes) {
    int32_t count = 0;
    if (!Int32(&count)) return Fail(field, "truncated before the count");
    if (count < 0) return Fail(field, "count " + std::to_string(count) + " < 0");
    if (static_cast<int64_t>(count) * element_bytes > size_ - at_) {
      return Fail(field, "count " + std::to_string(count) + " beyond the message");
    }
    at_ += static_cast<int64_t>(count) * element_bytes;
    return true;
  }
  // An int32 count followed by that many strings (lcm-gen resizes the array to the count
  // before reading it: each string takes at least 5 bytes, so the count is bounded first).
  bool CountedStrings(const char* field, int32_t* count) {
    if (!Int32(count)) return Fail(field, "truncated before the count");
    if (*count < 0) return Fail(field, "count " + std::to_string(*count) + " < 0");
    if (static_cast<int64_t>(*count) * 5 > size_ - at_) {
      return Fail(field, "count " + std::to_string(*count) + " beyond the message");
    }
    for (int32_t i = 0; i < *count; ++i) {
      if (!String(field)) return false;
    }
    return true;
  }
  // "" when the walk used the whole buffer, else what went wrong.
  std::string Finish(const char* type_name) const {
    if (!ok_) return std::string(type_name) + ": " + (error_.empty() ? "truncated" : error_);
    if (at_ != size_) {
      return std::string(type_name) + ": " + std::to_string(size_ - at_) +
             " bytes after the last field";
    }
    return "";
  }

 private:
  bool Fail() {
    ok_ = false;
    return false;
  }
  bool Fail(const char* field, const std::string& what) {
    if (ok_ || error_.empty()) error_ = std::string(field) + ": " + what;
    ok_ = false;
    return false;
  }

  const uint8_t* data_;
  int64_t size_;
  int64_t at_ = 0;
  bool ok_ = true;
  std::string error_;
};

template <typename Msg>
std::string DecodeChecked(const void* data, int size, const char* type_name, Msg* msg) {
  try {
    if (msg->decode(data, 0, size) != size) {
      return std::string(type_name) + ": does not decode (wrong type hash?)";
    }
  } catch (const std::exception& e) {  // not expected after the walk; never into LCM
    return std::string(type_name) + ": decode failed: " + e.what();
  }
  return "";
}

}  // namespace

std::string DecodeMissionChunk(const void* data, int size, mission_chunk_t* msg) {
  // hash, utime, mission_id, mission_name, session_id, seq, flags, payload, checksum.
  EncodingWalker walk(data, size);
  // Each step stops at the first failure; Finish() reports it.
  (void)(walk.Skip(8) && walk.Skip(8) && walk.String("mission_id") &&
         walk.String("mission_name") && walk.Skip(8) && walk.Skip(8) && walk.Skip(1) &&
         walk.CountedArray("payload", 1) && walk.Skip(4));
  if (std::string error = walk.Finish("mission_chunk_t"); !error.empty()) return error;
  return DecodeChecked(data, size, "mission_chunk_t", msg);
}

std::string DecodeMissionAck(const void* data, int size, mission_ack_t* msg) {
  // hash, utime, mission_id, session_id, ack_seq, status, message.
  EncodingWalker walk(data, size);
  (void)(walk.Skip(8) && walk.Skip(8) && walk.String("mission_id") && walk.Skip(8) &&
         walk.Skip(8) && walk.Skip(1) && walk.String("message"));
  if (std::string error = walk.Finish("mission_ack_t"); !error.empty()) return error;
  return DecodeChecked(data, size, "mission_ack_t", msg);
}

std::string DecodeStatusMessage(const void* data, int size, status_t* msg) {
  // hash, utime, node, state, message, num_counters, counter_names[], counter_values[],
  // num_metrics, metric_names[], metric_values[].
  EncodingWalker walk(data, size);
  int32_t counters = 0, metrics = 0;
  (void)(walk.Skip(8) && walk.Skip(8) && walk.String("node") && walk.Skip(4) &&
         walk.String("message") && walk.CountedStrings("counter_names", &counters) &&
         walk.Skip(8 * static_cast<int64_t>(counters)) &&
         walk.CountedStrings("metric_names", &metrics) &&
         walk.Skip(8 * static_cast<int64_t>(metrics)));
  if (std::string error = walk.Finish("status_t"); !error.empty()) return error;
  return DecodeChecked(data, size, "status_t", msg);
}

}  // namespace vilma
