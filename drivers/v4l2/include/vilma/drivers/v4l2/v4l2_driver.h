// The program behind `vilma-v4l2` (thin main in drivers/v4l2/main.cpp): options, the device
// (kernel or --fake), the capture loop, image_t on LCM, status_t at 1 Hz, systemd READY.
#pragma once

#include <atomic>
#include <cstdint>
#include <string>
#include <vector>
#include <vilma/image_t.hpp>

#include "vilma/drivers/v4l2/v4l2_capture.h"

namespace vilma::v4l2 {

constexpr int kExitOk = 0;
// Exit status, as the other drivers (docs/drivers.md): 2 is not worth a systemd restart.
constexpr int kExitRuntime = 1;  // camera absent or unable to do what is asked, LCM unusable
constexpr int kExitUsage = 2;    // bad command line or options file

// Keeps image_t.seq continuous for receivers: seq = the kernel's buffer sequence plus an
// offset that is re-chosen when the kernel's counter restarts (a new stream after a
// reconnect), so that a gap in `seq` on the bus is exactly the frames lost inside one stream
// (dropped by the kernel or camera, or malformed and not published).
class PublishedSequence {
 public:
  int64_t Next(int64_t kernel_sequence);

 private:
  int64_t last_kernel_ = -1;
  int64_t offset_ = 0;
  int64_t last_published_ = -1;
};

// Fills `msg` from a captured frame (GRAY8 or GRAY16, utime = robot_ns rounded to us).
// Returns "" or the conversion error.
std::string FrameToMessage(const CapturedFrame& frame, int64_t seq, int32_t camera_id,
                           image_t* msg);

// The whole program; returns the exit status. `stop` is set by SIGINT/SIGTERM.
int V4l2Main(const std::vector<std::string>& args, const std::atomic<bool>* stop);

}  // namespace vilma::v4l2
