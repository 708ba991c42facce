// Exposure, gain and other V4L2 controls (VIDIOC_QUERYCTRL / S_CTRL / G_CTRL).
//
// Exposure: auto, or a fixed time in microseconds. V4L2_CID_EXPOSURE_ABSOLUTE counts in
// 100 us units (videodev2 "exposure_time_absolute"), so 5000 us is the value 50; the value is
// rounded to the control's step and must lie in its range. Fixed exposure first switches
// V4L2_CID_EXPOSURE_AUTO to V4L2_EXPOSURE_MANUAL: UVC cameras refuse (EACCES) an absolute
// exposure while auto exposure is on. Auto exposure sets V4L2_EXPOSURE_AUTO, or
// APERTURE_PRIORITY where the camera's menu has no full auto (most UVC webcams).
// Gain: auto (V4L2_CID_AUTOGAIN on, where the camera has it), or a fixed value of
// V4L2_CID_GAIN in the camera's units.
// Other controls by their v4l2-ctl names ("brightness", "power_line_frequency"): lower case,
// runs of other characters as one '_'. A name the camera does not have is a warning (the same
// configuration serves several camera models); a value out of range is an error.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "vilma/drivers/v4l2/v4l2_io.h"

namespace vilma::v4l2 {

struct ControlOptions {
  double exposure_us = 0.0;                 // > 0: fixed exposure [us]; 0: auto
  int gain = -1;                            // >= 0: fixed gain [camera units]; -1: auto
  std::map<std::string, int64_t> controls;  // further controls by v4l2-ctl name

  // "" or "field: expectation".
  std::string Validate() const;
};

struct ControlReport {
  std::vector<std::string> warnings;  // unknown control names, controls the camera lacks
  std::vector<std::string> applied;   // "exposure_time_absolute=50 (5000 us)", ...
  int64_t exposure_us = 0;            // the fixed exposure as set (read back); 0 if auto
};

// "Exposure Time, Absolute" -> "exposure_time_absolute" (v4l2-ctl's names).
std::string ControlKey(const std::string& name);

// Applies `options` on the open descriptor. Returns "" or an error naming the control, the
// value and the range the camera allows.
std::string ApplyControls(V4l2Io* io, int fd, const ControlOptions& options, ControlReport* report);

// The exposure [us] V4L2_CID_EXPOSURE_ABSOLUTE reports; 0 if the camera has no such control.
// In auto mode many UVC cameras report the auto exposure's current time, some only the last
// manual value (then mid-exposure stamps are off by half the difference).
int64_t ReadExposureUs(V4l2Io* io, int fd);

// Every control the camera has, one line each: name, type, range, step, default, current
// value, menu items, inactive/read-only flags (for --list). "" when it has none.
std::string DescribeControls(V4l2Io* io, int fd);

}  // namespace vilma::v4l2
