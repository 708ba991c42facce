// Time conventions (architecture.md section 2): inside the libraries time is int64_t
// nanoseconds (`t_ns`), as in the ASL datasets; LCM messages carry `utime` in microseconds.
// Both are on the robot's (sensor) clock unless a name says otherwise.
#pragma once

#include <chrono>
#include <cstdint>

namespace vilma {

constexpr int64_t kNanosecondsPerSecond = 1000000000;

inline double NsToSeconds(int64_t t_ns) { return static_cast<double>(t_ns) * 1e-9; }
// Rounds to the nearest nanosecond.
inline int64_t SecondsToNs(double t_s) {
  return static_cast<int64_t>(t_s * 1e9 + (t_s >= 0 ? 0.5 : -0.5));
}
// ns -> us rounds to the nearest microsecond (EuRoC stamps are not whole microseconds).
inline int64_t NsToUtime(int64_t t_ns) { return (t_ns + (t_ns >= 0 ? 500 : -500)) / 1000; }
inline int64_t UtimeToNs(int64_t utime) { return utime * 1000; }

// Wall-clock time now [us since the Unix epoch], for status reports and logs; estimation
// always uses the sensor stamps, never this.
inline int64_t WallClockUtime() {
  return std::chrono::duration_cast<std::chrono::microseconds>(
             std::chrono::system_clock::now().time_since_epoch())
      .count();
}

}  // namespace vilma
