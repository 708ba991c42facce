// A simulated MicroStrain MIP IMU for the vilma-usb-imu tests: it answers the configuration
// commands the driver sends (ACK/NACK fields, base-rate replies) and builds sensor data packets
// (scaled accel, scaled gyro, the family's timestamp) whose values encode the sample index, so
// that a receiver can check every value it gets. SimTransport runs it in process behind the
// ByteTransport interface; the pty test runs it on a pseudo-terminal's master side.
#pragma once

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdint>
#include <deque>
#include <thread>
#include <vector>

#include "vilma/drivers/usb_imu/mip_protocol.h"
#include "vilma/drivers/usb_imu/transport.h"

namespace vilma::usb_imu::test {

// Sample k's readings: accel [g], gyro [rad/s]. k is recoverable from accel x.
inline void SimReadings(int64_t k, double accel_g[3], double gyro_rad_s[3]) {
  accel_g[0] = 0.001 * static_cast<double>(k % 4000);
  accel_g[1] = -0.25 + 0.0001 * static_cast<double>(k % 7);
  accel_g[2] = 1.0;
  gyro_rad_s[0] = 0.01 * std::sin(0.01 * static_cast<double>(k));
  gyro_rad_s[1] = -0.5;
  gyro_rad_s[2] = 0.002 * static_cast<double>(k % 11);
}

struct SimMipDeviceOptions {
  MipFamily family = MipFamily::kGx5;
  uint16_t base_rate_hz = 1000;
  bool answer_commands = true;  // false: a device that never replies
  uint8_t nack_descriptor = 0;  // a 3DM command (set 0x0C) descriptor answered with NACK 0x03
  int64_t device_start_ns = 5 * 1000000000LL;  // device clock at sample 0 (e.g. since power-up)
};

class SimMipDevice {
 public:
  explicit SimMipDevice(const SimMipDeviceOptions& options) : o_(options) {}

  // Bytes the host wrote; returns the device's replies.
  std::vector<uint8_t> OnHostBytes(const uint8_t* data, std::size_t size) {
    std::vector<uint8_t> out;
    for (const MipPacket& command : framer_.Push(data, size)) {
      commands_.push_back(command);
      if (!o_.answer_commands) continue;
      const std::vector<uint8_t> reply = EncodeMipPacket(Reply(command));
      out.insert(out.end(), reply.begin(), reply.end());
    }
    return out;
  }

  // Streams once the format is set, the stream enabled and the device resumed.
  bool streaming() const { return resumed_ && stream_enabled_ && decimation_ > 0; }
  uint16_t decimation() const { return decimation_; }
  double rate_hz() const {
    return decimation_ > 0 ? static_cast<double>(o_.base_rate_hz) / decimation_ : 0.0;
  }
  const std::vector<MipPacket>& commands() const { return commands_; }

  // The data packet of sample k at device time `device_ns`. Values are nudged (gyro z by
  // 1e-6 rad/s steps) until no 0x75 0x65 pair appears inside the packet, so that fault counts
  // in the tests are exact (no false sync inside a corrupted packet).
  std::vector<uint8_t> DataPacket(int64_t k, int64_t device_ns) const {
    double accel[3];
    double gyro[3];
    SimReadings(k, accel, gyro);
    for (int nudge = 0;; ++nudge) {
      MipPacket p;
      p.descriptor_set = mip::kSensorDataSet;
      MipField a{mip::kScaledAccel, {}};
      MipField g{mip::kScaledGyro, {}};
      for (int i = 0; i < 3; ++i) AppendFloat(&a.data, static_cast<float>(accel[i]));
      for (int i = 0; i < 3; ++i) {
        AppendFloat(&g.data, static_cast<float>(gyro[i] + (i == 2 ? 1e-6 * nudge : 0.0)));
      }
      MipField t{MipTimestampField(o_.family), {}};
      if (o_.family == MipFamily::kGx5) {
        const int64_t week = device_ns / kGpsWeekNs;
        AppendDouble(&t.data, static_cast<double>(device_ns - week * kGpsWeekNs) * 1e-9);
        AppendU16(&t.data, static_cast<uint16_t>(week));
        AppendU16(&t.data, 0x0004);  // time initialized, no PPS
      } else {
        AppendU64(&t.data, static_cast<uint64_t>(device_ns));
      }
      p.fields = {a, g, t};
      std::vector<uint8_t> bytes = EncodeMipPacket(p);
      bool inner_sync = false;
      for (std::size_t i = 1; i + 1 < bytes.size(); ++i) {
        inner_sync = inner_sync || (bytes[i] == kMipSync1 && bytes[i + 1] == kMipSync2);
      }
      if (!inner_sync) return bytes;
    }
  }

  int64_t device_start_ns() const { return o_.device_start_ns; }

 private:
  MipPacket Reply(const MipPacket& command) {
    const uint8_t set = CommandSet(command);
    const uint8_t desc = CommandDescriptor(command);
    const std::vector<uint8_t>& d = command.fields.empty() ? empty_ : command.fields.front().data;
    uint8_t code = 0;
    MipPacket reply;
    reply.descriptor_set = set;
    std::vector<MipField> extra;
    if (set == mip::kBaseCommandSet) {
      if (desc == mip::kSetToIdle) resumed_ = false;
      if (desc == mip::kResume) resumed_ = true;
      if (desc != mip::kPing && desc != mip::kSetToIdle && desc != mip::kResume) code = 0x01;
    } else if (set == mip::k3dmCommandSet) {
      const bool gx5 = o_.family == MipFamily::kGx5;
      if (desc == (gx5 ? mip::kGx5GetImuBaseRate : mip::kGetBaseRate)) {
        MipField rate{gx5 ? mip::kGx5ImuBaseRateReply : mip::kBaseRateReply, {}};
        if (!gx5) rate.data.push_back(mip::kSensorDataSet);
        AppendU16(&rate.data, o_.base_rate_hz);
        extra.push_back(rate);
      } else if (desc == (gx5 ? mip::kGx5ImuMessageFormat : mip::kMessageFormat)) {
        // [fn, (set,) n, (desc, u16 dec)*n]: take the decimation of the first descriptor.
        const std::size_t first = gx5 ? 2 : 3;
        if (d.size() >= first + 3) decimation_ = static_cast<uint16_t>((d[first + 1] << 8) | d[first + 2]);
      } else if (desc == mip::kDatastreamControl) {
        if (d.size() >= 3) stream_enabled_ = d[2] != 0;
      } else if (desc != (gx5 ? mip::kGx5ImuLowpassFilter : mip::kLowpassFilter)) {
        code = 0x01;  // a command of the other family: unknown here
      }
      if (desc == o_.nack_descriptor) code = 0x03;
    } else {
      code = 0x01;
    }
    reply.fields.push_back(MipField{mip::kAckNackField, {desc, code}});
    if (code == 0) reply.fields.insert(reply.fields.end(), extra.begin(), extra.end());
    return reply;
  }

  SimMipDeviceOptions o_;
  MipFramer framer_;
  std::vector<MipPacket> commands_;
  const std::vector<uint8_t> empty_;
  uint16_t decimation_ = 0;
  bool stream_enabled_ = false;
  bool resumed_ = true;  // a device powers up streaming its stored format (none here)
};

// SimMipDevice behind ByteTransport, in process: writes go to the device, reads return its
// replies and, once streaming, `samples_per_read` data packets per Read (no real time).
class SimTransport : public ByteTransport {
 public:
  SimTransport(const SimMipDeviceOptions& options, int samples_per_read = 4)
      : device_(options), samples_per_read_(samples_per_read) {}
  void Open() override { open_ = true; }
  void Close() override { open_ = false; }
  std::size_t Read(uint8_t* data, std::size_t size, int /*timeout_ms*/) override {
    if (pending_.empty() && device_.streaming()) {
      for (int i = 0; i < samples_per_read_; ++i) {
        const int64_t period_ns = static_cast<int64_t>(1e9 / device_.rate_hz());
        const std::vector<uint8_t> p =
            device_.DataPacket(k_, device_.device_start_ns() + k_ * period_ns);
        ++k_;
        pending_.insert(pending_.end(), p.begin(), p.end());
      }
    }
    const std::size_t n = std::min(size, pending_.size());
    if (n == 0) std::this_thread::sleep_for(std::chrono::milliseconds(1));  // a quiet line
    std::copy(pending_.begin(), pending_.begin() + static_cast<std::ptrdiff_t>(n), data);
    pending_.erase(pending_.begin(), pending_.begin() + static_cast<std::ptrdiff_t>(n));
    return n;
  }
  void Write(const uint8_t* data, std::size_t size) override {
    const std::vector<uint8_t> reply = device_.OnHostBytes(data, size);
    pending_.insert(pending_.end(), reply.begin(), reply.end());
  }
  std::string Describe() const override { return "simulated MIP device"; }
  SimMipDevice& device() { return device_; }

 private:
  SimMipDevice device_;
  int samples_per_read_;
  std::deque<uint8_t> pending_;
  int64_t k_ = 0;
  bool open_ = false;
};

}  // namespace vilma::usb_imu::test
