// MicroStrain MIP ("MicroStrain Inertial Protocol", the data communications protocol of the
// 3DM-GX5 and 3DM-CV7 families): packets, fields, the byte-stream framer and the IMU data and
// command-reply decoders. No I/O here (transports: transport.h; device dialogue: mip_device.h).
//
// Packet (all multi-byte values big-endian):
//   0x75 0x65 | descriptor set (1) | payload length L (1) | payload (L) | checksum (2)
// payload = fields, each  | field length n (1, including these 2 bytes) | descriptor (1) | data (n-2) |
// checksum = Fletcher-16 over everything before it: a += byte, b += a (mod 256); sent a then b.
//
// What this driver uses (docs/drivers.md "vilma-usb-imu" names the manual pages):
//   base commands (set 0x01): ping 0x01, set to idle 0x02, resume 0x06; reply field ACK/NACK
//     0xF1 = [echoed command descriptor, error code (0 = ACK)]
//   3DM commands (set 0x0C), by family:
//                        GX5 (legacy IMU commands)        CV7 (generic)
//     base rate          0x06 -> reply 0x83 [u16 Hz]       0x0E [set] -> reply 0x8E [set, u16 Hz]
//     message format     0x08 [fn, n, (desc, u16 dec)*n]   0x0F [fn, set, n, (desc, u16 dec)*n]
//     low-pass filter    0x50 [fn, desc, en, manual,       0x54 [fn, set, desc, en, manual,
//                              u16 Hz, 0]                          float Hz]
//     data stream        0x11 [fn, 0x01 (IMU), enable]     0x11 [fn, 0x80, enable]
//   sensor data (set 0x80): scaled accel 0x04 [3 float, g], scaled gyro 0x05 [3 float, rad/s],
//     GPS timestamp 0x12 [double tow s, u16 week, u16 flags] (GX5),
//     reference timestamp 0xD5 [u64 ns since power-up, never jumps] (CV7, shared field).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace vilma::usb_imu {

constexpr uint8_t kMipSync1 = 0x75;
constexpr uint8_t kMipSync2 = 0x65;
constexpr std::size_t kMipHeaderBytes = 4;
constexpr std::size_t kMipChecksumBytes = 2;
constexpr std::size_t kMipMaxPayloadBytes = 255;

// Descriptor sets and field descriptors.
namespace mip {
constexpr uint8_t kBaseCommandSet = 0x01;
constexpr uint8_t kPing = 0x01;
constexpr uint8_t kSetToIdle = 0x02;
constexpr uint8_t kResume = 0x06;
constexpr uint8_t k3dmCommandSet = 0x0C;
constexpr uint8_t kGx5GetImuBaseRate = 0x06;
constexpr uint8_t kGx5ImuMessageFormat = 0x08;
constexpr uint8_t kGetBaseRate = 0x0E;
constexpr uint8_t kMessageFormat = 0x0F;
constexpr uint8_t kDatastreamControl = 0x11;
constexpr uint8_t kGx5ImuLowpassFilter = 0x50;
constexpr uint8_t kLowpassFilter = 0x54;
constexpr uint8_t kGx5ImuBaseRateReply = 0x83;
constexpr uint8_t kBaseRateReply = 0x8E;
constexpr uint8_t kAckNackField = 0xF1;
constexpr uint8_t kFunctionWrite = 0x01;
constexpr uint8_t kGx5LegacyImuStream = 0x01;
constexpr uint8_t kSensorDataSet = 0x80;
constexpr uint8_t kScaledAccel = 0x04;
constexpr uint8_t kScaledGyro = 0x05;
constexpr uint8_t kGpsTimestamp = 0x12;
constexpr uint8_t kReferenceTimestamp = 0xD5;
}  // namespace mip

// Standard gravity: scaled accelerometer [g] -> [m/s^2] (the MIP manuals define g this way).
constexpr double kStandardGravity = 9.80665;
constexpr int64_t kGpsWeekNs = 604800LL * 1000000000LL;

enum class MipFamily { kGx5, kCv7 };
// "gx5" / "cv7"; false for anything else.
bool ParseMipFamily(const std::string& text, MipFamily* family);
const char* MipFamilyName(MipFamily family);

struct MipField {
  uint8_t descriptor = 0;
  std::vector<uint8_t> data;  // without the length and descriptor bytes
};

struct MipPacket {
  uint8_t descriptor_set = 0;
  std::vector<MipField> fields;
};

// Fletcher-16 of MIP (a in the high byte, b in the low byte).
uint16_t MipChecksum(const uint8_t* data, std::size_t size);

// The wire bytes of `packet`. Throws std::invalid_argument when a field's data exceeds 253
// bytes or the payload 255 bytes.
std::vector<uint8_t> EncodeMipPacket(const MipPacket& packet);

// Big-endian helpers for building fields.
void AppendU16(std::vector<uint8_t>* out, uint16_t value);
void AppendU32(std::vector<uint8_t>* out, uint32_t value);
void AppendU64(std::vector<uint8_t>* out, uint64_t value);
void AppendFloat(std::vector<uint8_t>* out, float value);
void AppendDouble(std::vector<uint8_t>* out, double value);

// Counts of the framer, one per error class. Every byte pushed is either in a good packet, in
// garbage_bytes (skipped: noise, bytes of rejected candidates), or still buffered;
// checksum_errors, truncated_packets and malformed_packets count candidates, not bytes.
struct MipFramerStats {
  int64_t packets = 0;            // good packets emitted
  int64_t bytes = 0;              // bytes pushed
  int64_t garbage_bytes = 0;      // bytes skipped while looking for a sync pair
  int64_t checksum_errors = 0;    // candidates whose checksum did not match
  int64_t truncated_packets = 0;  // candidates cut short: a valid packet started inside them
  int64_t malformed_packets = 0;  // checksum right, but field lengths do not fill the payload
  int64_t resyncs = 0;            // times the framer lost sync and searched again
};

// Byte stream -> packets. Robust to anything: garbage between packets, packets split across
// reads at any byte, corrupted bytes, packets cut short by a reset of the sender. On a bad
// candidate it drops only its first sync byte and searches again, so a good packet that
// started inside a bad one is still found.
class MipFramer {
 public:
  // Appends bytes and returns the packets completed by them (in order).
  std::vector<MipPacket> Push(const uint8_t* data, std::size_t size);
  // End of the stream: a started packet that cannot complete is counted as truncated and
  // searched for packets inside it (returned); all other buffered bytes count as garbage.
  std::vector<MipPacket> Flush();
  void Clear() { buffer_.clear(); }
  const MipFramerStats& stats() const { return stats_; }
  std::size_t buffered() const { return buffer_.size(); }

 private:
  // 1: a checksum-valid complete packet at buffer_[at]; -1: a wrong checksum; 0: incomplete.
  int CheckCandidate(std::size_t at) const;
  // Emits the complete packets at the front of buffer_; at_end: nothing more will come.
  std::vector<MipPacket> Parse(bool at_end);
  // Bytes [at, end) are a complete packet except for a wrong length byte.
  bool WholeWithWrongLength(std::size_t at, std::size_t end) const;

  std::vector<uint8_t> buffer_;
  MipFramerStats stats_;
};

// Splits a checksum-valid payload into fields; false if the field lengths do not add up.
bool SplitMipFields(const uint8_t* payload, std::size_t size, std::vector<MipField>* fields);

// One IMU sample of a sensor data packet (set 0x80), in the device's frame and clock.
struct MipImuSample {
  double accel_g[3] = {0, 0, 0};      // scaled accelerometer [g]
  double gyro_rad_s[3] = {0, 0, 0};   // scaled gyroscope [rad/s]
  bool has_accel = false;
  bool has_gyro = false;
  bool has_timestamp = false;
  int64_t device_ns = 0;              // device timestamp [ns] (see DecodeMipImuSample)
  uint16_t gps_flags = 0;             // valid flags of the GPS timestamp field (0x12)
};

struct MipDecodeStats {
  int64_t unknown_fields = 0;     // fields of the sensor set this driver does not use
  int64_t bad_field_lengths = 0;  // known descriptors with the wrong data length
  int64_t bad_values = 0;         // NaN/inf readings or a time of week outside a week
};

// Decodes a sensor data packet. Device time: 0xD5 as is; 0x12 as week * 604800 s + tow (GPS
// time when the device is PPS-synced, else its internal clock). Returns false when the packet
// is not of set 0x80.
bool DecodeMipImuSample(const MipPacket& packet, MipImuSample* sample, MipDecodeStats* stats);

// ACK/NACK field of a reply packet to command `command_descriptor` of `command_set`: true and
// *error_code (0 = ACK) if the packet is that reply.
bool FindMipAck(const MipPacket& packet, uint8_t command_set, uint8_t command_descriptor,
                uint8_t* error_code);
// "ACK" / "unknown command" / "invalid parameter" / ... for a MIP reply code.
std::string MipErrorName(uint8_t code);

// Command packets of the configuration (the payload layouts above).
MipPacket MipPingCommand();
MipPacket MipSetToIdleCommand();
MipPacket MipResumeCommand();
MipPacket MipGetBaseRateCommand(MipFamily family);
// Streams scaled accel, scaled gyro and the family's timestamp at base_rate / decimation.
MipPacket MipImuMessageFormatCommand(MipFamily family, uint16_t decimation);
// Low-pass filter of `field` (accel 0x04 or gyro 0x05): off, auto (half the stream rate) or a
// manual -3 dB cutoff [Hz].
MipPacket MipLowpassFilterCommand(MipFamily family, uint8_t field, bool enable, bool manual,
                                  double cutoff_hz);
MipPacket MipEnableImuStreamCommand(MipFamily family, bool enable);
// The command's (set, descriptor): what its ACK echoes.
inline uint8_t CommandSet(const MipPacket& p) { return p.descriptor_set; }
inline uint8_t CommandDescriptor(const MipPacket& p) {
  return p.fields.empty() ? 0 : p.fields.front().descriptor;
}

// Base rate [Hz] from the reply of MipGetBaseRateCommand: true if `packet` carries it.
bool DecodeMipBaseRate(const MipPacket& packet, MipFamily family, uint16_t* rate_hz);

// The timestamp field the family streams (0x12 for GX5, 0xD5 for CV7).
uint8_t MipTimestampField(MipFamily family);

}  // namespace vilma::usb_imu
