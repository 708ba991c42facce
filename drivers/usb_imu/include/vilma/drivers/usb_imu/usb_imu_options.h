// Options of vilma-usb-imu: a plain struct with defaults, strict YAML (config/usb_imu.yaml:
// every key present, unknown keys an error) and command-line flags that override fields.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "vilma/core/clock_sync.h"
#include "vilma/core/yaml_io.h"
#include "vilma/drivers/driver_lcm_options.h"

namespace vilma::usb_imu {

// The LCM part (lcm_url, channel [IMU], channel_suffix, status_channel, status_period_s,
// seconds) is DriverLcmOptions, shared with the camera drivers.
struct UsbImuOptions : DriverLcmOptions {
  UsbImuOptions() { channel = "IMU"; }

  // Where the bytes come from: "serial" (a tty: /dev/ttyACM0 of cdc_acm, a UART adapter),
  // "usb" (libusb, by vendor/product id) or "replay" (a recorded byte stream, for tests/demos).
  std::string transport = "serial";
  std::string serial_device = "/dev/ttyACM0";  // serial: tty path (or a /dev/serial/by-id link)
  int baud = 115200;                           // serial: line rate (the GX5/CV7 default)
  int usb_vendor_id = 0x199b;                  // usb: MicroStrain
  std::vector<int> usb_product_ids = {0x3065, 0x3d65};  // usb: GX5/CV7/GQ7 family, older GX4
  std::string usb_serial;                      // usb: iSerialNumber to pick; "" = first found
  std::string replay_file;                     // replay: the recorded bytes
  // replay: speed factor of the pacing by device timestamps (1 = as recorded); 0 = as fast as
  // possible (then time_source must be "device").
  double replay_rate = 1.0;

  std::string family = "gx5";  // MIP command dialect: "gx5" (3DM-GX5-xx) or "cv7" (3DM-CV7-xx)
  bool configure = true;       // send the configuration (false: take the stream as it comes)
  // Wanted sample rate [Hz] (base rate / integer decimation); with configure false, the rate
  // the device already streams (for counting dropped samples).
  double rate_hz = 200.0;
  std::string lowpass = "auto";     // accel+gyro low-pass: "auto" (half the rate), "off", "manual"
  double lowpass_cutoff_hz = 0.0;   // lowpass "manual": -3 dB cutoff [Hz]
  int command_timeout_ms = 500;     // wait for each ACK
  int command_retries = 3;          // tries per command

  // "host_sync": device stamps mapped to CLOCK_REALTIME by ClockSync (default); "device":
  // device stamps shifted by the first sample's arrival offset (replays, PPS-disciplined devices).
  std::string time_source = "host_sync";
  // Fixed part of the delay from sampling to the read() that returns the packet [us]: subtracted
  // from arrival stamps (ClockSync sees only the variable part). A UART at B baud adds at least
  // 10 * packet bytes / B s; USB full speed about 1 ms polling.
  double transport_latency_us = 0.0;
  ClockSyncOptions clock_sync;

  double stall_timeout_s = 1.0;   // no sample for this long: status DEGRADED [s]
  double reconnect_max_backoff_s = 2.0;  // reopen tries back off from 0.1 s up to this [s]

  // "" when valid, else "field: expectation".
  std::string Validate() const;
};

// Reads every key of `node` (a map); InputError naming file, key and expectation otherwise.
UsbImuOptions ReadUsbImuOptions(const YamlNode& node);
UsbImuOptions LoadUsbImuOptions(const std::string& path);
// The options as YAML that ReadUsbImuOptions reads back (--print-config).
std::string UsbImuOptionsToYaml(const UsbImuOptions& options);

struct UsbImuCommandLine {
  UsbImuOptions options;
  bool help = false;
  bool list = false;          // list USB devices of usb_vendor_id and exit
  bool print_config = false;  // print the effective options as YAML and exit
};

// --config FILE is read first, then every other flag overrides its field. Throws UsageError
// (core/arg_cursor.h) for a bad command line and InputError for a bad config file or values.
UsbImuCommandLine ParseUsbImuCommandLine(int argc, const char* const* argv);
std::string UsbImuUsage();

}  // namespace vilma::usb_imu
