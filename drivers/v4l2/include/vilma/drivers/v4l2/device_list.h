// `vilma-v4l2 --list`: every V4L2 device node with its stable names, driver, card and bus, and
// for capture nodes the pixel formats (marked when vilma-v4l2 converts them), frame sizes,
// frame rates and controls with their ranges.
#pragma once

#include <string>

#include "vilma/drivers/v4l2/v4l2_io.h"

namespace vilma::v4l2 {

// The listing as text. `*capture_nodes` is set to the number of capture nodes found (0 when
// there is no /dev/video* at all: the text then says so).
std::string ListDevices(V4l2Io* io, int* capture_nodes);

}  // namespace vilma::v4l2
