// vilma-v4l2: see `vilma-v4l2 --help` and docs/drivers.md. The logic is in the
// vilma_driver_v4l2 library (tested in tests/drivers/v4l2/).
#include <atomic>
#include <csignal>
#include <string>
#include <vector>

#include "vilma/drivers/v4l2/v4l2_driver.h"

namespace {
std::atomic<bool> g_stop{false};
void OnSignal(int) { g_stop = true; }
}  // namespace

int main(int argc, char** argv) {
  std::signal(SIGINT, OnSignal);
  std::signal(SIGTERM, OnSignal);
  const std::vector<std::string> args(argv + 1, argv + argc);
  return vilma::v4l2::V4l2Main(args, &g_stop);
}
