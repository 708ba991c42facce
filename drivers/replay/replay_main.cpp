// vilma-replay: see `vilma-replay --help` and docs/lcm.md. The logic is in
// drivers/common/src/replay.cpp (tested in tests/drivers/replay_test.cpp).
#include <atomic>
#include <csignal>

#include "vilma/drivers/replay.h"

namespace {
std::atomic<bool> g_stop{false};
void OnSignal(int) { g_stop = true; }
}  // namespace

int main(int argc, char** argv) {
  std::signal(SIGINT, OnSignal);
  std::signal(SIGTERM, OnSignal);
  return vilma::ReplayMain(argc, argv, &g_stop);
}
