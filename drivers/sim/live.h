// Live mode of vilma-sim: publishes the simulation on LCM in real time like a sensor driver
// (images as GRAY8 vilma.image_t on CAM0/CAM1, IMU as vilma.imu_t on IMU). Executable-only:
// the vilma_sim library stays free of LCM (architecture.md section 4).
#pragma once

#include <iosfwd>
#include <string>

#include "vilma/sim/simulator.h"

namespace vilma {
namespace sim {

struct LiveOptions {
  std::string lcm_url;          // empty: $LCM_DEFAULT_URL or LCM's default (ttl=0)
  std::string channel_suffix;   // appended to CAM0, CAM1, IMU
  double rate = 1.0;            // playback speed factor (1 = real time)

  std::string Validate() const;
};

// Publishes the whole sequence; returns the process exit code (0 on success). Rendering runs
// on its own thread a few frames ahead so that the IMU stream keeps its 5 ms spacing.
int PublishLive(Simulator* sim, const LiveOptions& options, std::ostream& log);

}  // namespace sim
}  // namespace vilma
