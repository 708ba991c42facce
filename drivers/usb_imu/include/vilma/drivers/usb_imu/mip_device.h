// The configuration dialogue with a MIP IMU over a ByteTransport: set to idle, ping, read the
// IMU base rate, set the IMU message format (scaled accel, scaled gyro, timestamp at
// base rate / decimation), the low-pass filters, enable the IMU data stream, resume.
// Each command waits for its ACK (reply field 0xF1); data packets arriving meanwhile are
// dropped (the device is idle for most of it).
#pragma once

#include <cstdint>
#include <stdexcept>
#include <string>
#include <vector>

#include "vilma/drivers/usb_imu/mip_protocol.h"
#include "vilma/drivers/usb_imu/transport.h"

namespace vilma::usb_imu {

enum class LowpassMode { kAuto, kOff, kManual };
bool ParseLowpassMode(const std::string& text, LowpassMode* mode);  // "auto" / "off" / "manual"
const char* LowpassModeName(LowpassMode mode);

struct MipConfig {
  MipFamily family = MipFamily::kGx5;
  double rate_hz = 200.0;            // wanted sample rate; the device gives base / decimation
  LowpassMode lowpass = LowpassMode::kAuto;
  double lowpass_cutoff_hz = 0.0;    // with kManual: -3 dB cutoff of accel and gyro [Hz]
  int command_timeout_ms = 500;      // per try
  int command_retries = 3;           // tries per command
};

struct MipConfigResult {
  uint16_t base_rate_hz = 0;
  uint16_t decimation = 0;
  double rate_hz = 0.0;  // base_rate_hz / decimation: what the device streams
};

// The device refused or did not answer (a runtime failure, exit code 1).
class MipCommandError : public std::runtime_error {
 public:
  using std::runtime_error::runtime_error;
};

// Decimation for `rate_hz` from `base_rate_hz`: the nearest integer >= 1. Throws
// MipCommandError when the nearest achievable rate is more than 1 % off (names the rates the
// device can give near it).
uint16_t ChooseDecimation(uint16_t base_rate_hz, double rate_hz);

class MipDevice {
 public:
  // Borrows both; `framer` keeps counting what arrives during the dialogue.
  MipDevice(ByteTransport* transport, MipFramer* framer) : transport_(transport), framer_(framer) {}

  // The whole configuration; throws MipCommandError or TransportError.
  MipConfigResult Configure(const MipConfig& config);

  // Sends `command` and returns the packet carrying its ACK (which also carries any reply
  // fields). Throws MipCommandError on a NACK or when no ACK came within timeout x retries.
  MipPacket Command(const MipPacket& command, const std::string& name, int timeout_ms,
                    int retries);

  int64_t dropped_during_configuration() const { return dropped_packets_; }
  // Packets that arrived after the last command's ACK in the same read: after Configure(),
  // the stream's first samples, which the caller should not lose.
  std::vector<MipPacket> TakeLeftovers() { return std::move(leftovers_); }

 private:
  ByteTransport* transport_;
  MipFramer* framer_;
  int64_t dropped_packets_ = 0;
  std::vector<MipPacket> leftovers_;
};

}  // namespace vilma::usb_imu
