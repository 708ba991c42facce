#include "vilma/drivers/usb_imu/usb_imu_options.h"

#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <sstream>

#include "vilma/core/arg_cursor.h"
#include "vilma/core/clock_sync_yaml.h"
#include "vilma/core/error.h"
#include "vilma/core/options_fields.h"
#include "vilma/core/validate.h"
#include "vilma/drivers/driver_status.h"
#include "vilma/drivers/lcm_url.h"
#include "vilma/drivers/usb_imu/imu_stream.h"
#include "vilma/drivers/usb_imu/mip_device.h"
#include "vilma/drivers/usb_imu/mip_protocol.h"
#include "vilma/drivers/usb_imu/transport.h"

namespace vilma::usb_imu {
namespace {

std::string CheckId(const char* field, int id) {
  if (id < 0 || id > 0xFFFF) return std::string(field) + ": expected a 16-bit id (0 .. 0xffff)";
  return "";
}

// "0x199b", "6555" -> the number; UsageError naming the flag otherwise.
int ParseUsbId(const std::string& flag, const std::string& text) {
  errno = 0;
  char* end = nullptr;
  const long value = std::strtol(text.c_str(), &end, 0);
  if (text.empty() || end == nullptr || *end != '\0' || errno != 0 || value < 0 ||
      value > 0xFFFF) {
    throw UsageError(flag + ": expected a 16-bit USB id like 0x199b, got '" + text + "'");
  }
  return static_cast<int>(value);
}

std::vector<int> ParseUsbIdList(const std::string& flag, const std::string& text) {
  std::vector<int> ids;
  std::stringstream in(text);
  std::string part;
  while (std::getline(in, part, ',')) ids.push_back(ParseUsbId(flag, part));
  if (ids.empty()) throw UsageError(flag + ": expected one or more ids like 0x3065,0x3d65");
  return ids;
}

std::string Hex(int id) {
  std::ostringstream out;
  out << "0x" << std::hex << id;
  return out.str();
}

}  // namespace


std::string UsbImuOptions::Validate() const {
  if (transport != "serial" && transport != "usb" && transport != "replay") {
    return "transport: expected serial, usb or replay";
  }
  if (transport == "serial" && serial_device.empty()) return "serial_device: expected a tty path";
  if (!IsSupportedBaud(baud)) {
    return "baud: expected one of 9600 19200 38400 57600 115200 230400 460800 921600";
  }
  VILMA_RETURN_IF_ERROR(CheckId("usb_vendor_id", usb_vendor_id));
  if (usb_product_ids.empty()) return "usb_product_ids: expected at least one product id";
  for (int id : usb_product_ids) VILMA_RETURN_IF_ERROR(CheckId("usb_product_ids", id));
  if (transport == "replay" && replay_file.empty()) {
    return "replay_file: expected the recorded byte stream (transport replay)";
  }
  VILMA_RETURN_IF_ERROR(ValidateNonNegative("replay_rate", replay_rate));
  MipFamily f;
  if (!ParseMipFamily(family, &f)) return "family: expected gx5 or cv7";
  if (!(std::isfinite(rate_hz) && rate_hz > 0.0 && rate_hz <= 10000.0)) {
    return "rate_hz: expected 0 < rate <= 10000 [Hz]";
  }
  LowpassMode mode;
  if (!ParseLowpassMode(lowpass, &mode)) return "lowpass: expected auto, off or manual";
  if (mode == LowpassMode::kManual &&
      !(std::isfinite(lowpass_cutoff_hz) && lowpass_cutoff_hz > 0.0 && lowpass_cutoff_hz <= 65535.0)) {
    return "lowpass_cutoff_hz: expected 0 < cutoff <= 65535 [Hz] with lowpass manual";
  }
  if (command_timeout_ms < 10 || command_timeout_ms > 60000) {
    return "command_timeout_ms: expected 10 .. 60000";
  }
  if (command_retries < 1 || command_retries > 100) return "command_retries: expected 1 .. 100";
  TimeSource source;
  if (!ParseTimeSource(time_source, &source)) return "time_source: expected host_sync or device";
  if (transport == "replay" && source == TimeSource::kHostSync && replay_rate != 1.0) {
    return "time_source: expected device when replay_rate is not 1 (host arrival times of a "
           "sped-up replay are not a clock)";
  }
  if (transport == "replay" && configure) {
    return "configure: expected false with transport replay (a recording cannot answer commands)";
  }
  VILMA_RETURN_IF_ERROR(ValidateNonNegative("transport_latency_us", transport_latency_us));
  const std::string clock_error = clock_sync.Validate();
  if (!clock_error.empty()) return "clock_sync." + clock_error;
  VILMA_RETURN_IF_ERROR(ValidateLcm());
  VILMA_RETURN_IF_ERROR(ValidatePositive("stall_timeout_s", stall_timeout_s));
  VILMA_RETURN_IF_ERROR(ValidateAtLeast("reconnect_max_backoff_s", reconnect_max_backoff_s, 0.1));
  return "";
}

// The field list (core/options_fields.h): reader and --print-config's writer. USB ids are
// written in hex, as lsusb shows them (YAML reads 0x199b as an integer).
template <typename Options, typename Visitor>
void VisitUsbImuFields(Options& o, Visitor&& v) {
  v("", "transport", o.transport);
  v("", "serial_device", o.serial_device);
  v("", "baud", o.baud);
  v("", "usb_vendor_id",
    WithCodec(o.usb_vendor_id,
              [](const YamlNode& node, const char* key, int* id) { *id = node.Get<int>(key); },
              [](int id) { return Hex(id); }));
  v("", "usb_product_ids",
    WithCodec(o.usb_product_ids,
              [](const YamlNode& node, const char* key, std::vector<int>* ids) {
                const char* expected = "expected a list of 16-bit ids like [0x3065, 0x3d65]";
                const YAML::Node list = SequenceOrFail(node, key, expected);
                ids->clear();
                for (const YAML::Node& id : list) {
                  try {
                    ids->push_back(id.as<int>());
                  } catch (const YAML::Exception&) {
                    node.Fail(key, expected);
                  }
                }
              },
              [](const std::vector<int>& ids) {
                std::string text = "[";
                for (std::size_t i = 0; i < ids.size(); ++i) text += (i ? ", " : "") + Hex(ids[i]);
                return text + "]";
              }));
  v("", "usb_serial", o.usb_serial);
  v("", "replay_file", o.replay_file);
  v("", "replay_rate", o.replay_rate);
  v("", "family", o.family);
  v("", "configure", o.configure);
  v("", "rate_hz", o.rate_hz);
  v("", "lowpass", o.lowpass);
  v("", "lowpass_cutoff_hz", o.lowpass_cutoff_hz);
  v("", "command_timeout_ms", o.command_timeout_ms);
  v("", "command_retries", o.command_retries);
  v("", "time_source", o.time_source);
  v("", "transport_latency_us", o.transport_latency_us);
  VisitClockSyncFields(o.clock_sync, InSection("clock_sync", v));
  v("", "stall_timeout_s", o.stall_timeout_s);
  v("", "reconnect_max_backoff_s", o.reconnect_max_backoff_s);
  VisitDriverLcmFields(o, v);
}

UsbImuOptions ReadUsbImuOptions(const YamlNode& node) {
  UsbImuOptions o;
  if (!node.raw().IsNull() && !node.IsMap()) node.Fail("", "expected a map of vilma-usb-imu options");
  ReadOptionFields(node, MissingKey::kKeepDefault, &o,
                   [](auto& options, auto&& v) { VisitUsbImuFields(options, v); });
  node.CheckValid(o.Validate());
  return o;
}

UsbImuOptions LoadUsbImuOptions(const std::string& path) {
  return ReadUsbImuOptions(YamlNode::LoadFile(path));
}

std::string UsbImuOptionsToYaml(const UsbImuOptions& o) {
  return OptionFieldsToYaml(o, [](auto& options, auto&& v) { VisitUsbImuFields(options, v); });
}

UsbImuCommandLine ParseUsbImuCommandLine(int argc, const char* const* argv) {
  const std::vector<std::string> args(argv + 1, argv + argc);
  UsbImuCommandLine cl;
  // The config file first, wherever --config stands: flags override it.
  for (ArgCursor arg(args); arg.Next();) {
    if (arg.name() == "--config") {
      cl.options = LoadUsbImuOptions(arg.Value());
    } else if (arg.name() == "--help" || arg.name() == "-h") {
      cl.help = true;
      return cl;
    }
  }
  UsbImuOptions& o = cl.options;
  for (ArgCursor arg(args); arg.Next();) {
    const std::string& name = arg.name();
    if (name == "--config") {
      arg.Value();
    } else if (name == "--serial") {
      o.transport = "serial";
      o.serial_device = arg.Value();
    } else if (name == "--baud") {
      o.baud = arg.IntValue(1);
    } else if (name == "--usb") {
      arg.Flag();
      o.transport = "usb";
    } else if (name == "--vendor-id") {
      o.usb_vendor_id = ParseUsbId(name, arg.Value());
    } else if (name == "--product-id") {
      o.usb_product_ids = ParseUsbIdList(name, arg.Value());
    } else if (name == "--usb-serial") {
      o.usb_serial = arg.Value();
    } else if (name == "--replay-bytes") {
      o.transport = "replay";
      o.replay_file = arg.Value();
      o.configure = false;
    } else if (name == "--replay-rate") {
      o.replay_rate = arg.DoubleValue();
    } else if (name == "--family") {
      o.family = arg.Value();
    } else if (name == "--no-configure") {
      arg.Flag();
      o.configure = false;
    } else if (name == "--rate-hz") {
      o.rate_hz = arg.DoubleValue();
    } else if (name == "--lowpass") {
      o.lowpass = arg.Value();
    } else if (name == "--lowpass-cutoff-hz") {
      o.lowpass_cutoff_hz = arg.DoubleValue();
    } else if (name == "--time-source") {
      o.time_source = arg.Value();
    } else if (name == "--transport-latency-us") {
      o.transport_latency_us = arg.DoubleValue();
    } else if (ParseDriverLcmFlag(arg, &o)) {
    } else if (name == "--stall-timeout-s") {
      o.stall_timeout_s = arg.DoubleValue();
    } else if (name == "--reconnect-max-backoff-s") {
      o.reconnect_max_backoff_s = arg.DoubleValue();
    } else if (name == "--command-timeout-ms") {
      o.command_timeout_ms = arg.IntValue();
    } else if (name == "--command-retries") {
      o.command_retries = arg.IntValue();
    } else if (name == "--list") {
      cl.list = arg.Flag();
    } else if (name == "--print-config") {
      cl.print_config = arg.Flag();
    } else {
      throw UsageError(name + ": unknown option");
    }
  }
  ThrowIfInvalid(o.Validate(), "options");
  return cl;
}

std::string UsbImuUsage() {
  const UsbImuOptions d;
  std::ostringstream out;
  out << R"(Usage: vilma-usb-imu [options]

Reads a MicroStrain MIP IMU (3DM-GX5 or 3DM-CV7 family) over a serial tty, libusb or a recorded
byte stream, configures its IMU stream (scaled accelerometer, scaled gyroscope, device
timestamp), maps the device timestamps onto the robot's clock (CLOCK_REALTIME, minimum-delay
clock sync) and publishes vilma.imu_t on IMU (accelerations in m/s^2, angular rates in rad/s,
in the IMU's own frame) and vilma.status_t on VILMA_STATUS_IMU. docs/drivers.md has the details.

Options (flags override --config; defaults in brackets):
  --config FILE             YAML options (config/usb_imu.yaml lists every key)
  --serial DEV              transport serial: tty path [)" << d.serial_device << R"(]
  --baud N                  serial line rate [)" << d.baud << R"(]
  --usb                     transport usb: libusb, the kernel's cdc_acm detached
  --vendor-id ID            USB vendor id [)" << Hex(d.usb_vendor_id) << R"(]
  --product-id ID[,ID..]    USB product ids to accept [0x3065,0x3d65]
  --usb-serial S            pick the device with this USB serial number
  --list                    list USB devices of the vendor id (0: all) and exit
  --replay-bytes FILE       transport replay: a recorded MIP byte stream (implies
                            --no-configure)
  --replay-rate R           replay speed by device timestamps; 0 = as fast as possible
                            (needs --time-source device) [1]
  --family gx5|cv7          MIP command dialect and timestamp field [)" << d.family << R"(]
  --no-configure            do not configure the device; take its stream as it comes
  --command-timeout-ms MS   wait for each command's ACK [)" << d.command_timeout_ms << R"(]
  --command-retries N       tries per command [)" << d.command_retries << R"(]
  --rate-hz R               sample rate: base rate / integer decimation (with
                            --no-configure: the rate the device streams) [)" << d.rate_hz << R"(]
  --lowpass auto|off|manual accel and gyro low-pass filter [)" << d.lowpass << R"(]
  --lowpass-cutoff-hz F     cutoff with --lowpass manual
  --time-source host_sync|device
                            device stamps through clock sync, or shifted by the first
                            sample's offset [)" << d.time_source << R"(]
  --transport-latency-us U  fixed delay from sampling to arrival, subtracted [0]
)" << DriverLcmUsage(d) << R"(  --stall-timeout-s S       no sample for this long: status DEGRADED [)" << d.stall_timeout_s << R"(]
  --reconnect-max-backoff-s S
                            reopen tries back off from 0.1 s to this [)" << d.reconnect_max_backoff_s << R"(]
  --print-config            print the effective options as YAML and exit
  --help                    this text
The clock filter's options (clock_sync: window_s, outlier and jump thresholds, ...) are set in
the --config file only.

Exit status: 0 after a clean stop (signal, --seconds, end of a replay), 1 when the device
cannot be opened or configured or LCM fails, 2 on bad options or config file.
)";
  return out.str();
}

}  // namespace vilma::usb_imu
