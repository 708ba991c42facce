// vilma-usb-imu's run loop: open the transport, configure the IMU, stream, map the device clock,
// publish imu_t and status_t, reopen and reconfigure after the device disappears.
#pragma once

#include <atomic>
#include <memory>

#include "vilma/drivers/usb_imu/transport.h"
#include "vilma/drivers/usb_imu/usb_imu_options.h"

namespace vilma::usb_imu {

// The transport that `options` name (not opened yet).
std::unique_ptr<ByteTransport> MakeTransport(const UsbImuOptions& options);

// The program: parses the command line, runs until *stop, --seconds or the end of a replay.
// Returns the exit status (0 ok, 1 runtime failure, 2 usage/config error).
int UsbImuMain(int argc, const char* const* argv, const std::atomic<bool>* stop);

}  // namespace vilma::usb_imu
