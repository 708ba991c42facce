#include "vilma/drivers/usb_imu/mip_device.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iterator>
#include <sstream>

namespace vilma::usb_imu {

bool ParseLowpassMode(const std::string& text, LowpassMode* mode) {
  if (text == "auto") {
    *mode = LowpassMode::kAuto;
  } else if (text == "off") {
    *mode = LowpassMode::kOff;
  } else if (text == "manual") {
    *mode = LowpassMode::kManual;
  } else {
    return false;
  }
  return true;
}

const char* LowpassModeName(LowpassMode mode) {
  switch (mode) {
    case LowpassMode::kAuto: return "auto";
    case LowpassMode::kOff: return "off";
    case LowpassMode::kManual: return "manual";
  }
  return "?";
}

uint16_t ChooseDecimation(uint16_t base_rate_hz, double rate_hz) {
  if (base_rate_hz == 0) throw MipCommandError("the device reported an IMU base rate of 0 Hz");
  const double exact = static_cast<double>(base_rate_hz) / rate_hz;
  const long nearest = std::max(1L, std::lround(exact));
  const double achieved = static_cast<double>(base_rate_hz) / static_cast<double>(nearest);
  if (nearest > 65535 || std::abs(achieved - rate_hz) > 0.01 * rate_hz) {
    std::ostringstream out;
    out << "rate_hz " << rate_hz << " is not base rate " << base_rate_hz
        << " Hz / an integer; near it: ";
    const long lo = std::max(1L, static_cast<long>(std::floor(exact)));
    out << static_cast<double>(base_rate_hz) / static_cast<double>(lo) << " Hz";
    if (lo + 1 <= 65535) {
      out << " or " << static_cast<double>(base_rate_hz) / static_cast<double>(lo + 1) << " Hz";
    }
    throw MipCommandError(out.str());
  }
  return static_cast<uint16_t>(nearest);
}

MipPacket MipDevice::Command(const MipPacket& command, const std::string& name, int timeout_ms,
                             int retries) {
  const std::vector<uint8_t> bytes = EncodeMipPacket(command);
  const uint8_t set = CommandSet(command);
  const uint8_t descriptor = CommandDescriptor(command);
  uint8_t buffer[1024];
  leftovers_.clear();
  for (int attempt = 0; attempt < retries; ++attempt) {
    transport_->Write(bytes.data(), bytes.size());
    const auto deadline =
        std::chrono::steady_clock::now() + std::chrono::milliseconds(timeout_ms);
    while (std::chrono::steady_clock::now() < deadline) {
      const auto left = std::chrono::duration_cast<std::chrono::milliseconds>(
                            deadline - std::chrono::steady_clock::now())
                            .count();
      const std::size_t n =
          transport_->Read(buffer, sizeof(buffer), static_cast<int>(std::max<int64_t>(1, left)));
      std::vector<MipPacket> packets = framer_->Push(buffer, n);
      for (std::size_t i = 0; i < packets.size(); ++i) {
        uint8_t code = 0;
        if (!FindMipAck(packets[i], set, descriptor, &code)) {
          ++dropped_packets_;  // streamed data or a late reply to an earlier try
          continue;
        }
        if (code != 0) {
          throw MipCommandError(name + ": " + MipErrorName(code) + " from " +
                                transport_->Describe());
        }
        // What came after the ACK in the same read (after "resume": the first samples).
        leftovers_.assign(std::make_move_iterator(packets.begin() + static_cast<std::ptrdiff_t>(i) + 1),
                          std::make_move_iterator(packets.end()));
        return packets[i];
      }
      if (transport_->AtEnd()) break;
    }
  }
  std::ostringstream out;
  out << name << ": no reply from " << transport_->Describe() << " within " << timeout_ms
      << " ms (" << retries << " tries); is it a MicroStrain MIP device"
      << " (and at this baud rate)?";
  throw MipCommandError(out.str());
}

MipConfigResult MipDevice::Configure(const MipConfig& config) {
  const int timeout = config.command_timeout_ms;
  const int retries = config.command_retries;
  // Idle first: a streaming device answers commands too, but its replies then share the
  // link with data; idle makes the dialogue quick and the settings take effect on resume.
  Command(MipSetToIdleCommand(), "set to idle (0x01,0x02)", timeout, retries);
  Command(MipPingCommand(), "ping (0x01,0x01)", timeout, retries);

  MipConfigResult result;
  const MipPacket rate_reply =
      Command(MipGetBaseRateCommand(config.family),
              config.family == MipFamily::kGx5 ? "get IMU base rate (0x0C,0x06)"
                                               : "get base rate (0x0C,0x0E)",
              timeout, retries);
  if (!DecodeMipBaseRate(rate_reply, config.family, &result.base_rate_hz)) {
    throw MipCommandError(std::string("get base rate: the ACK carried no base-rate field (") +
                          (config.family == MipFamily::kGx5 ? "0x83" : "0x8E") +
                          "): is family '" + MipFamilyName(config.family) + "' right?");
  }
  result.decimation = ChooseDecimation(result.base_rate_hz, config.rate_hz);
  result.rate_hz = static_cast<double>(result.base_rate_hz) / result.decimation;

  Command(MipImuMessageFormatCommand(config.family, result.decimation),
          config.family == MipFamily::kGx5 ? "IMU message format (0x0C,0x08)"
                                           : "message format (0x0C,0x0F)",
          timeout, retries);
  const bool enable = config.lowpass != LowpassMode::kOff;
  const bool manual = config.lowpass == LowpassMode::kManual;
  for (uint8_t field : {mip::kScaledAccel, mip::kScaledGyro}) {
    Command(MipLowpassFilterCommand(config.family, field, enable, manual,
                                    manual ? config.lowpass_cutoff_hz : 0.0),
            std::string(config.family == MipFamily::kGx5 ? "IMU low-pass filter (0x0C,0x50)"
                                                         : "low-pass filter (0x0C,0x54)") +
                (field == mip::kScaledAccel ? " accel" : " gyro"),
            timeout, retries);
  }
  Command(MipEnableImuStreamCommand(config.family, true), "enable IMU stream (0x0C,0x11)",
          timeout, retries);
  Command(MipResumeCommand(), "resume (0x01,0x06)", timeout, retries);
  return result;
}

}  // namespace vilma::usb_imu
