// Choosing a capture format with a V4L2 device (VIDIOC_ENUM_FMT, S_FMT, S_PARM).
//
// The pixel format is the first of the preference list that the device offers (and the
// driver converts: GREY, Y16, YUYV, MJPG). S_FMT asks for the size; the device answers with
// the nearest size it has, S_PARM likewise with the nearest frame interval. What it chose is
// reported when it differs from what was asked; when the size or rate is required
// (require_size / require_fps), a difference is an error that lists what the device offers.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "vilma/drivers/v4l2/v4l2_io.h"

namespace vilma::v4l2 {

struct FormatRequest {
  std::vector<uint32_t> fourccs;  // preference order (V4L2_PIX_FMT_*)
  int width = 0;                  // [px]; 0 = keep the device's current size
  int height = 0;                 // [px]
  double fps = 0.0;               // [Hz]; 0 = keep the device's current rate
  bool require_size = false;      // a different size is an error (else a note)
  bool require_fps = false;       // a rate off by more than 1 % is an error (else a note)
  // The device's buffer type: V4L2_BUF_TYPE_VIDEO_CAPTURE, or _CAPTURE_MPLANE for devices
  // with the multi-planar API only (many MIPI receivers); the formats used have one plane.
  uint32_t buffer_type = 1;  // V4L2_BUF_TYPE_VIDEO_CAPTURE
};

struct NegotiatedFormat {
  uint32_t fourcc = 0;
  int width = 0;
  int height = 0;
  int bytes_per_line = 0;          // 0 for MJPG
  uint32_t size_image = 0;         // buffer size the driver needs [bytes]
  double fps = 0.0;                // 0 when the device does not report a frame interval
  std::vector<std::string> notes;  // what differs from the request, for the log
};

// Negotiates on the open capture descriptor `fd`. Returns "" or an error that says what was
// asked and what the device offers (ioctl failures name the ioctl and errno).
std::string NegotiateFormat(V4l2Io* io, int fd, const FormatRequest& request,
                            NegotiatedFormat* result);

// The pixel formats the device lists (ENUM_FMT) for `buffer_type`, in its order.
std::vector<uint32_t> EnumerateFourccs(V4l2Io* io, int fd, uint32_t buffer_type = 1);
// "640x480, 320x240" (discrete), "16x16..1920x1080 step 8x8" (stepwise) of one format.
std::string DescribeFrameSizes(V4l2Io* io, int fd, uint32_t fourcc);
// "60, 30, 15 fps" (discrete) or "1..60 fps" (stepwise/continuous) at one size.
std::string DescribeFrameRates(V4l2Io* io, int fd, uint32_t fourcc, int width, int height);

}  // namespace vilma::v4l2
