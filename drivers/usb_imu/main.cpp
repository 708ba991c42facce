// vilma-usb-imu: see `vilma-usb-imu --help` and docs/drivers.md. The logic is in
// drivers/usb_imu/src (tested in tests/drivers/usb_imu_*_test.cpp).
#include <atomic>
#include <csignal>

#include "vilma/drivers/usb_imu/usb_imu_driver.h"

namespace {
std::atomic<bool> g_stop{false};
void OnSignal(int) { g_stop = true; }
}  // namespace

int main(int argc, char** argv) {
  std::signal(SIGINT, OnSignal);
  std::signal(SIGTERM, OnSignal);
  // A USB/tty write to a vanished device must be an error we handle, not a kill.
  std::signal(SIGPIPE, SIG_IGN);
  return vilma::usb_imu::UsbImuMain(argc, argv, &g_stop);
}
