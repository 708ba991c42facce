#include "pipeline.h"

#include <cstdarg>
#include <cstdio>

namespace vilma::daemon {
namespace {

// Counters that are drops (summed into "drops").
constexpr std::array<Counter, 11> kDropCounters = {
    kImagesDroppedPool,     kImagesDroppedInputQueue, kImuDroppedInputQueue,
    kImuDroppedFilterQueue, kFramesDroppedBusy,       kFramesDroppedFilterQueue,
    kPosesDroppedOutput,    kSyncFramesDroppedOverflow, kMapFramesDropped,
    kMapImuDropped,         kLocMessagesDropped};

}  // namespace

int64_t Counters::Drops() const {
  int64_t drops = 0;
  for (Counter c : kDropCounters) drops += Get(c);
  return drops;
}

void LimitedLog::operator()(int topic, const char* format, ...) {
  const int64_t now = SteadyNs();
  std::atomic<int64_t>& last = last_ns_[static_cast<std::size_t>(topic) % last_ns_.size()];
  const int64_t previous = last.load(std::memory_order_relaxed);
  if (previous != 0 && now - previous < 1000 * kMs) return;
  last.store(now, std::memory_order_relaxed);
  char line[512];
  va_list args;
  va_start(args, format);
  std::vsnprintf(line, sizeof(line), format, args);
  va_end(args);
  std::fprintf(stderr, "vilma-estimatord: %s\n", line);
}

}  // namespace vilma::daemon
