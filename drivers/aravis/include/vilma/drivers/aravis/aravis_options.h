// Options of vilma-aravis (docs/drivers.md, "vilma-aravis"): one plain struct, read from strict
// YAML (config/aravis.yaml; unknown keys are errors, absent keys keep their defaults) and from
// command-line flags that mirror the YAML keys (`frame_rate_hz` <-> `--frame-rate-hz`).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "vilma/core/clock_sync.h"
#include "vilma/drivers/driver_lcm_options.h"

namespace vilma::aravis {

// The LCM part (lcm_url, channel [CAM0], channel_suffix, status_channel, status_period_s,
// seconds) is DriverLcmOptions, shared with the other drivers.
struct AravisOptions : DriverLcmOptions {
  AravisOptions() { channel = "CAM0"; }

  // --- device
  // Camera to open: Aravis device id ("Basler-21234567", "Fake_1"), serial number, physical
  // id (MAC address / USB path) or IP address; "" opens the first camera found.
  std::string device;
  // Use Aravis's in-process fake camera ("Fake" interface, device Fake_1): no hardware needed.
  bool fake = false;

  // --- image
  // GenICam PFNC pixel format: Mono8, Mono10, Mono12, Mono16, BayerRG8, BayerGB8, BayerGR8,
  // BayerBG8, RGB8 (the camera must offer it; `vilma-aravis --list` shows which).
  std::string pixel_format = "Mono8";
  // Region of interest [px]; 0 = the camera's current width/height. Offsets from the sensor's
  // top-left corner [px].
  int width = 0;
  int height = 0;
  int offset_x = 0;
  int offset_y = 0;
  // Mono10/12/16: publish GRAY16 (true) or scale to GRAY8 (false; the top 8 bits).
  bool keep_16bit = false;
  // Bayer formats: publish the raw mosaic as BAYER_* (true) or demosaic to GRAY8 (false).
  bool keep_bayer = false;

  // --- acquisition
  // Frame rate [Hz]; 0 = leave the camera's setting. Ignored by the camera in trigger mode
  // (except with trigger_source Software, where the driver fires at this rate).
  double frame_rate_hz = 20.0;
  // Exposure: "off" (fixed exposure_us), "once" or "continuous" (camera's auto exposure).
  std::string exposure_auto = "off";
  // Fixed exposure time [us]; 0 = leave the camera's setting.
  double exposure_us = 0.0;
  // Gain: "off" (fixed gain), "once", "continuous".
  std::string gain_auto = "off";
  // Fixed gain in the camera's unit (GenICam Gain: dB on most cameras); < 0 = leave it.
  double gain = -1.0;
  // Hardware trigger: TriggerSelector FrameStart, TriggerMode On, this TriggerSource and
  // TriggerActivation. Software = the driver triggers at frame_rate_hz.
  bool trigger = false;
  std::string trigger_source = "Line0";
  std::string trigger_activation = "RisingEdge";

  // --- stream
  // Buffers queued to the stream: frames that may be in flight before the camera has to drop.
  int buffers = 8;
  // GigE Vision: ask the camera to resend lost packets.
  bool packet_resend = true;
  // GigE Vision packet size [bytes]; 0 = negotiate the largest that passes (auto).
  int packet_size = 0;
  // No frame for this long means the camera is lost (not in trigger mode) [s].
  double frame_timeout_s = 2.0;
  // Pause between attempts to reopen a lost camera [s].
  double reconnect_interval_s = 1.0;

  // --- time
  // "device": the camera's timestamps mapped onto the robot clock (ClockSync, with the host
  // arrival time of each buffer); "host": the host arrival time only.
  std::string timestamp_source = "device";
  // What the camera's timestamp marks: "exposure_start" (GenICam SFNC cameras: the frame
  // trigger / start of exposure) or "exposure_end". utime is mid-exposure either way.
  std::string timestamp_event = "exposure_start";
  // Constant added to every utime [us] (a latch latency known from the camera's manual).
  double time_offset_us = 0.0;
  // Least time from the end of exposure to the buffer's host arrival stamp (readout and the
  // first packet's transfer) [us]. One-way arrival times cannot reveal this constant; it is
  // subtracted before the clock filter (device mode) or from the arrival (host mode).
  double transport_latency_us = 0.0;
  ClockSyncOptions clock_sync;

  // --- LCM (besides DriverLcmOptions)
  int camera_id = 0;  // image_t.camera_id: the camera's index in the sensor rig

  // --- run (besides DriverLcmOptions::seconds)
  int64_t frames = 0;    // stop after this many published frames; 0 = no limit
  // Test only: pretend the camera was lost after this many frames (reconnect path); 0 = off.
  int64_t fault_lose_camera_after = 0;

  std::string Validate() const;
};

// Reads options from a YAML map over `base` (absent keys keep base's values). Throws InputError
// naming `source`, the key and the expectation.
AravisOptions ReadAravisOptions(const std::string& yaml_text, const std::string& source,
                                const AravisOptions& base = {});
AravisOptions LoadAravisOptionsFile(const std::string& path, const AravisOptions& base = {});
// The effective options as YAML (readable back by ReadAravisOptions).
std::string AravisOptionsToYaml(const AravisOptions& options);

// What the command line asked for.
struct AravisCommandLine {
  AravisOptions options;
  bool help = false;
  bool list = false;          // --list: print cameras and the chosen camera's features
  bool print_config = false;  // --print-config: print the effective options and exit
};

// Parses argv: --config FILE first (anywhere on the line), then every other flag overrides the
// file's value. Throws UsageError (core/arg_cursor.h) for a bad command line and InputError for
// a bad config file or option value.
AravisCommandLine ParseAravisCommandLine(const std::vector<std::string>& args);

std::string AravisUsage();

}  // namespace vilma::aravis
