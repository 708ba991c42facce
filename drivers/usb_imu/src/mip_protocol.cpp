#include "vilma/drivers/usb_imu/mip_protocol.h"

#include <cmath>
#include <cstring>
#include <limits>
#include <stdexcept>

namespace vilma::usb_imu {

bool ParseMipFamily(const std::string& text, MipFamily* family) {
  if (text == "gx5") {
    *family = MipFamily::kGx5;
    return true;
  }
  if (text == "cv7") {
    *family = MipFamily::kCv7;
    return true;
  }
  return false;
}

const char* MipFamilyName(MipFamily family) { return family == MipFamily::kGx5 ? "gx5" : "cv7"; }

uint16_t MipChecksum(const uint8_t* data, std::size_t size) {
  uint8_t a = 0;
  uint8_t b = 0;
  for (std::size_t i = 0; i < size; ++i) {
    a = static_cast<uint8_t>(a + data[i]);
    b = static_cast<uint8_t>(b + a);
  }
  return static_cast<uint16_t>((a << 8) | b);
}

std::vector<uint8_t> EncodeMipPacket(const MipPacket& packet) {
  std::vector<uint8_t> out = {kMipSync1, kMipSync2, packet.descriptor_set, 0};
  for (const MipField& field : packet.fields) {
    if (field.data.size() > 253) {
      throw std::invalid_argument("MIP field data longer than 253 bytes");
    }
    out.push_back(static_cast<uint8_t>(field.data.size() + 2));
    out.push_back(field.descriptor);
    out.insert(out.end(), field.data.begin(), field.data.end());
  }
  const std::size_t payload = out.size() - kMipHeaderBytes;
  if (payload > kMipMaxPayloadBytes) {
    throw std::invalid_argument("MIP payload longer than 255 bytes");
  }
  out[3] = static_cast<uint8_t>(payload);
  AppendU16(&out, MipChecksum(out.data(), out.size()));
  return out;
}

void AppendU16(std::vector<uint8_t>* out, uint16_t value) {
  out->push_back(static_cast<uint8_t>(value >> 8));
  out->push_back(static_cast<uint8_t>(value));
}

void AppendU32(std::vector<uint8_t>* out, uint32_t value) {
  for (int shift = 24; shift >= 0; shift -= 8) out->push_back(static_cast<uint8_t>(value >> shift));
}

void AppendU64(std::vector<uint8_t>* out, uint64_t value) {
  for (int shift = 56; shift >= 0; shift -= 8) out->push_back(static_cast<uint8_t>(value >> shift));
}

void AppendFloat(std::vector<uint8_t>* out, float value) {
  uint32_t bits = 0;
  std::memcpy(&bits, &value, sizeof(bits));
  AppendU32(out, bits);
}

void AppendDouble(std::vector<uint8_t>* out, double value) {
  uint64_t bits = 0;
  std::memcpy(&bits, &value, sizeof(bits));
  AppendU64(out, bits);
}

namespace {

uint64_t ReadU(const uint8_t* p, int bytes) {
  uint64_t v = 0;
  for (int i = 0; i < bytes; ++i) v = (v << 8) | p[i];
  return v;
}

float ReadFloat(const uint8_t* p) {
  const auto bits = static_cast<uint32_t>(ReadU(p, 4));
  float value = 0;
  std::memcpy(&value, &bits, sizeof(value));
  return value;
}

double ReadDouble(const uint8_t* p) {
  const uint64_t bits = ReadU(p, 8);
  double value = 0;
  std::memcpy(&value, &bits, sizeof(value));
  return value;
}

}  // namespace

bool SplitMipFields(const uint8_t* payload, std::size_t size, std::vector<MipField>* fields) {
  fields->clear();
  std::size_t at = 0;
  while (at < size) {
    const std::size_t length = payload[at];
    if (length < 2 || at + length > size) return false;
    MipField field;
    field.descriptor = payload[at + 1];
    field.data.assign(payload + at + 2, payload + at + length);
    fields->push_back(std::move(field));
    at += length;
  }
  return true;
}

int MipFramer::CheckCandidate(std::size_t at) const {
  const std::size_t available = buffer_.size() - at;
  if (available < kMipHeaderBytes) return 0;
  const std::size_t total = kMipHeaderBytes + buffer_[at + 3] + kMipChecksumBytes;
  if (available < total) return 0;
  const uint16_t listed =
      static_cast<uint16_t>((buffer_[at + total - 2] << 8) | buffer_[at + total - 1]);
  return MipChecksum(buffer_.data() + at, total - kMipChecksumBytes) == listed ? 1 : -1;
}

bool MipFramer::WholeWithWrongLength(std::size_t at, std::size_t end) const {
  // [at, end) is a whole packet whose length byte alone was corrupted if its checksum holds
  // with the length that fits: then the candidate was not cut short.
  const std::size_t total = end - at;
  if (total < kMipHeaderBytes + kMipChecksumBytes ||
      total - kMipHeaderBytes - kMipChecksumBytes > kMipMaxPayloadBytes) {
    return false;
  }
  std::vector<uint8_t> copy(buffer_.begin() + static_cast<std::ptrdiff_t>(at),
                            buffer_.begin() + static_cast<std::ptrdiff_t>(end));
  copy[3] = static_cast<uint8_t>(total - kMipHeaderBytes - kMipChecksumBytes);
  const uint16_t listed = static_cast<uint16_t>((copy[total - 2] << 8) | copy[total - 1]);
  return MipChecksum(copy.data(), total - kMipChecksumBytes) == listed;
}

std::vector<MipPacket> MipFramer::Push(const uint8_t* data, std::size_t size) {
  stats_.bytes += static_cast<int64_t>(size);
  buffer_.insert(buffer_.end(), data, data + size);
  return Parse(false);
}

std::vector<MipPacket> MipFramer::Flush() {
  std::vector<MipPacket> packets = Parse(true);
  stats_.garbage_bytes += static_cast<int64_t>(buffer_.size());  // nothing left but noise
  buffer_.clear();
  return packets;
}

std::vector<MipPacket> MipFramer::Parse(bool at_end) {
  std::vector<MipPacket> packets;
  std::size_t pos = 0;
  const std::size_t n = buffer_.size();
  while (pos < n) {
    if (buffer_[pos] != kMipSync1) {
      ++stats_.garbage_bytes;
      ++pos;
      continue;
    }
    if (pos + 1 >= n) {  // a lone first sync byte: wait for the next read
      if (at_end) {
        ++stats_.garbage_bytes;
        ++pos;
      }
      break;
    }
    if (buffer_[pos + 1] != kMipSync2) {
      ++stats_.garbage_bytes;
      ++pos;
      continue;
    }
    const int check = CheckCandidate(pos);
    if (check == 0 && at_end) {
      // Cut by the end of the stream; packets may still hide in its bytes (a corrupted
      // length byte announced more than is there): search again after its first byte.
      ++stats_.truncated_packets;
      ++stats_.resyncs;
      ++stats_.garbage_bytes;
      ++pos;
      continue;
    }
    if (check == 0) break;  // not complete yet
    const std::size_t total = kMipHeaderBytes + buffer_[pos + 3] + kMipChecksumBytes;
    if (check > 0) {
      MipPacket packet;
      packet.descriptor_set = buffer_[pos + 2];
      if (packet.descriptor_set != 0 &&
          SplitMipFields(buffer_.data() + pos + kMipHeaderBytes, buffer_[pos + 3],
                         &packet.fields)) {
        ++stats_.packets;
        packets.push_back(std::move(packet));
      } else {
        // Right checksum, impossible content (a sender bug): dropped whole.
        ++stats_.malformed_packets;
        stats_.garbage_bytes += static_cast<int64_t>(total);
      }
      pos += total;
      continue;
    }
    // Bad checksum. A sync pair inside the candidate that starts a valid packet means this
    // one was cut short (the sender restarted mid-packet), unless the bytes before it are a
    // whole packet with a corrupted length byte; decide only when that inner packet is
    // complete, so that the count does not depend on how reads split the stream.
    bool truncated = false;
    bool wait = false;
    for (std::size_t j = pos + 1; j + 1 < pos + total && j + 1 < n; ++j) {
      if (buffer_[j] == kMipSync1 && buffer_[j + 1] == kMipSync2) {
        const int inner = CheckCandidate(j);
        wait = inner == 0;
        truncated = inner > 0 && !WholeWithWrongLength(pos, j);
        break;
      }
    }
    if (wait && !at_end) break;
    if (truncated) {
      ++stats_.truncated_packets;
    } else {
      ++stats_.checksum_errors;
    }
    ++stats_.resyncs;
    ++stats_.garbage_bytes;  // the first sync byte; the rest is searched again
    ++pos;
  }
  buffer_.erase(buffer_.begin(), buffer_.begin() + static_cast<std::ptrdiff_t>(pos));
  return packets;
}

bool DecodeMipImuSample(const MipPacket& packet, MipImuSample* sample, MipDecodeStats* stats) {
  if (packet.descriptor_set != mip::kSensorDataSet) return false;
  *sample = MipImuSample();
  for (const MipField& field : packet.fields) {
    const uint8_t* d = field.data.data();
    const std::size_t size = field.data.size();
    switch (field.descriptor) {
      case mip::kScaledAccel:
      case mip::kScaledGyro: {
        if (size != 12) {
          ++stats->bad_field_lengths;
          break;
        }
        double* out = field.descriptor == mip::kScaledAccel ? sample->accel_g : sample->gyro_rad_s;
        bool finite = true;
        for (int i = 0; i < 3; ++i) {
          out[i] = ReadFloat(d + 4 * i);
          finite = finite && std::isfinite(out[i]);
        }
        if (!finite) {
          ++stats->bad_values;
          break;
        }
        (field.descriptor == mip::kScaledAccel ? sample->has_accel : sample->has_gyro) = true;
        break;
      }
      case mip::kGpsTimestamp: {
        if (size != 12) {
          ++stats->bad_field_lengths;
          break;
        }
        const double tow_s = ReadDouble(d);
        const auto week = static_cast<int64_t>(ReadU(d + 8, 2));
        sample->gps_flags = static_cast<uint16_t>(ReadU(d + 10, 2));
        // A week has 6.048e14 ns; a time of week outside [0, 604800] s is corrupt.
        if (!(std::isfinite(tow_s) && tow_s >= 0.0 && tow_s <= 604800.0)) {
          ++stats->bad_values;
          break;
        }
        sample->device_ns = week * kGpsWeekNs + static_cast<int64_t>(std::llround(tow_s * 1e9));
        sample->has_timestamp = true;
        break;
      }
      case mip::kReferenceTimestamp: {
        if (size != 8) {
          ++stats->bad_field_lengths;
          break;
        }
        const uint64_t ns = ReadU(d, 8);
        if (ns > static_cast<uint64_t>(std::numeric_limits<int64_t>::max())) {
          ++stats->bad_values;
          break;
        }
        sample->device_ns = static_cast<int64_t>(ns);
        sample->has_timestamp = true;
        break;
      }
      default:
        ++stats->unknown_fields;
    }
  }
  return true;
}

bool FindMipAck(const MipPacket& packet, uint8_t command_set, uint8_t command_descriptor,
                uint8_t* error_code) {
  if (packet.descriptor_set != command_set) return false;
  for (const MipField& field : packet.fields) {
    if (field.descriptor == mip::kAckNackField && field.data.size() == 2 &&
        field.data[0] == command_descriptor) {
      *error_code = field.data[1];
      return true;
    }
  }
  return false;
}

std::string MipErrorName(uint8_t code) {
  switch (code) {
    case 0x00: return "ACK";
    case 0x01: return "NACK: unknown command";
    case 0x02: return "NACK: invalid checksum";
    case 0x03: return "NACK: invalid parameter";
    case 0x04: return "NACK: command failed";
    case 0x05: return "NACK: device timeout";
    default: return "NACK: code " + std::to_string(code);
  }
}

namespace {

MipPacket Command(uint8_t set, uint8_t descriptor, std::vector<uint8_t> data = {}) {
  MipPacket p;
  p.descriptor_set = set;
  p.fields.push_back(MipField{descriptor, std::move(data)});
  return p;
}

}  // namespace

MipPacket MipPingCommand() { return Command(mip::kBaseCommandSet, mip::kPing); }
MipPacket MipSetToIdleCommand() { return Command(mip::kBaseCommandSet, mip::kSetToIdle); }
MipPacket MipResumeCommand() { return Command(mip::kBaseCommandSet, mip::kResume); }

MipPacket MipGetBaseRateCommand(MipFamily family) {
  if (family == MipFamily::kGx5) return Command(mip::k3dmCommandSet, mip::kGx5GetImuBaseRate);
  return Command(mip::k3dmCommandSet, mip::kGetBaseRate, {mip::kSensorDataSet});
}

uint8_t MipTimestampField(MipFamily family) {
  return family == MipFamily::kGx5 ? mip::kGpsTimestamp : mip::kReferenceTimestamp;
}

MipPacket MipImuMessageFormatCommand(MipFamily family, uint16_t decimation) {
  std::vector<uint8_t> d = {mip::kFunctionWrite};
  if (family == MipFamily::kCv7) d.push_back(mip::kSensorDataSet);
  d.push_back(3);
  for (uint8_t field : {mip::kScaledAccel, mip::kScaledGyro, MipTimestampField(family)}) {
    d.push_back(field);
    AppendU16(&d, decimation);
  }
  return Command(mip::k3dmCommandSet,
                 family == MipFamily::kGx5 ? mip::kGx5ImuMessageFormat : mip::kMessageFormat,
                 std::move(d));
}

MipPacket MipLowpassFilterCommand(MipFamily family, uint8_t field, bool enable, bool manual,
                                  double cutoff_hz) {
  std::vector<uint8_t> d = {mip::kFunctionWrite};
  if (family == MipFamily::kGx5) {
    d.insert(d.end(), {field, static_cast<uint8_t>(enable), static_cast<uint8_t>(manual)});
    AppendU16(&d, static_cast<uint16_t>(std::lround(cutoff_hz)));
    d.push_back(0);  // reserved
    return Command(mip::k3dmCommandSet, mip::kGx5ImuLowpassFilter, std::move(d));
  }
  d.insert(d.end(), {mip::kSensorDataSet, field, static_cast<uint8_t>(enable),
                     static_cast<uint8_t>(manual)});
  AppendFloat(&d, static_cast<float>(cutoff_hz));
  return Command(mip::k3dmCommandSet, mip::kLowpassFilter, std::move(d));
}

MipPacket MipEnableImuStreamCommand(MipFamily family, bool enable) {
  const uint8_t stream =
      family == MipFamily::kGx5 ? mip::kGx5LegacyImuStream : mip::kSensorDataSet;
  return Command(mip::k3dmCommandSet, mip::kDatastreamControl,
                 {mip::kFunctionWrite, stream, static_cast<uint8_t>(enable)});
}

bool DecodeMipBaseRate(const MipPacket& packet, MipFamily family, uint16_t* rate_hz) {
  if (packet.descriptor_set != mip::k3dmCommandSet) return false;
  for (const MipField& field : packet.fields) {
    if (family == MipFamily::kGx5 && field.descriptor == mip::kGx5ImuBaseRateReply &&
        field.data.size() == 2) {
      *rate_hz = static_cast<uint16_t>(ReadU(field.data.data(), 2));
      return true;
    }
    if (family == MipFamily::kCv7 && field.descriptor == mip::kBaseRateReply &&
        field.data.size() == 3 && field.data[0] == mip::kSensorDataSet) {
      *rate_hz = static_cast<uint16_t>(ReadU(field.data.data() + 1, 2));
      return true;
    }
  }
  return false;
}

}  // namespace vilma::usb_imu
