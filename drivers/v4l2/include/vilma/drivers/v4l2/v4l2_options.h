// Options of vilma-v4l2: a YAML file (--config, strict: unknown keys are errors, absent keys
// keep their defaults; config/v4l2.yaml lists them all) and command-line flags that override
// its fields. `vilma-v4l2 --help` lists the flags; --print-config prints the effective
// options as YAML that --config reads back.
#pragma once

#include <string>
#include <vector>

#include "vilma/core/yaml_io.h"
#include "vilma/drivers/driver_lcm_options.h"
#include "vilma/drivers/v4l2/v4l2_capture.h"

namespace vilma::v4l2 {

// The LCM part (lcm_url, channel [CAM0], channel_suffix, status_channel, status_period_s,
// seconds) is DriverLcmOptions, shared with the other drivers.
struct V4l2DriverOptions : DriverLcmOptions {
  V4l2DriverOptions() { channel = "CAM0"; }

  CaptureOptions capture;
  int camera_id = 0;  // image_t.camera_id: the camera's index in the rig
  // Command line only:
  bool fake = false;  // the in-process fake camera (fake_v4l2_io.h) instead of the kernel
  // With --fake: unplug the fake camera after this many frames for fake_unplug_s, to show the
  // recovery (0 = never).
  int fake_unplug_after = 0;
  double fake_unplug_s = 0.5;
  bool list = false;          // print devices, formats, controls and exit
  bool print_config = false;  // print the effective options and exit
  std::string config_file;    // where the YAML came from ("" = defaults)

  // "" or "field: expectation".
  std::string Validate() const;
};

// Reads the options of a YAML map (absent keys keep the defaults of `defaults`). Throws
// InputError naming the file and key for unknown keys, wrong types and invalid values.
V4l2DriverOptions ReadV4l2Options(const YamlNode& root, const V4l2DriverOptions& defaults = {});
V4l2DriverOptions LoadV4l2Options(const std::string& path);

// The options as YAML that ReadV4l2Options reads back (command-line-only fields left out).
std::string V4l2OptionsYaml(const V4l2DriverOptions& options);

// The command line: --config first, then every flag over it. Throws UsageError (arg_cursor.h)
// for a bad command line, InputError for a bad config file or values. Sets *help for --help.
V4l2DriverOptions ParseV4l2CommandLine(const std::vector<std::string>& args, bool* help);

std::string V4l2Usage();

// "auto" -> 0 (exposure) / -1 (gain), else the number; false if neither.
bool ParseExposure(const std::string& text, double* exposure_us);
bool ParseGain(const std::string& text, int* gain);

}  // namespace vilma::v4l2
