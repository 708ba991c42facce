// Trajectories out of LCM logs: the vilma.pose_t messages of one channel (VILMA_ODOM,
// VILMA_POSE, ...) as a core Trajectory, so that a recorded run can be evaluated with
// `vilma eval` or any TUM tool.
#pragma once

#include <cstdint>
#include <string>

#include "vilma/core/trajectory.h"

namespace vilma {

struct PoseLogStats {
  int64_t events_on_channel = 0;  // messages seen on the channel
  int64_t malformed = 0;          // did not decode as pose_t, or non-finite values: skipped
  int64_t not_valid = 0;          // status INVALID / INITIALIZING: skipped unless asked for
};

// Reads every pose_t on `channel` of the log at `path`, in log order; stamps are the messages'
// utime (sensor clock). Throws InputError naming the file if it cannot be read.
Trajectory ReadPoseLog(const std::string& path, const std::string& channel,
                       bool include_not_valid, PoseLogStats* stats);

}  // namespace vilma
