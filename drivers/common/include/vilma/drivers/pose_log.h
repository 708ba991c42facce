// Trajectories out of LCM logs: the vilma.pose_t messages of one channel (VILMA_ODOM,
// VILMA_POSE, ...) as a core Trajectory, so that a recorded run can be evaluated with
// `vilma eval` or any TUM tool.
#pragma once

#include <cstdint>
#include <string>

#include "vilma/eval/trajectory.h"

namespace vilma {

struct PoseLogStats {
  int64_t events_on_channel = 0;  // messages seen on the channel
  int64_t malformed = 0;          // did not decode as pose_t, or non-finite values: skipped
  int64_t not_valid = 0;          // status INVALID / INITIALIZING: skipped unless asked for

  // "N messages, M malformed, V not valid" (core/report.h's shape).
  std::string BriefReport() const;
  std::string FullReport() const { return BriefReport() + "\n"; }
};

// Reads every pose_t on `channel` of the log at `path`, in log order; stamps are the messages'
// utime (sensor clock). Throws InputError naming the file if it cannot be read.
Trajectory ReadPoseLog(const std::string& path, const std::string& channel,
                       bool include_not_valid, PoseLogStats* stats);

// What one channel of a log carries, by the LCM fingerprint of its first decodable message.
enum class PoseLogType { kEmpty, kPose, kLocalization, kOther };
PoseLogType DetectPoseLogType(const std::string& path, const std::string& channel);

struct LocalizationLogStats {
  int64_t events_on_channel = 0;
  int64_t malformed = 0;  // did not decode as localization_t, or non-finite pose: skipped
  int64_t attempts = 0;   // decodable localization_t messages (one per attempt)
  int64_t with_pose = 0;  // status "ok" (the library found a pose)
  int64_t accepted = 0;   // decision "accepted" (used for T_G_M by vilma-estimatord)

  // "attempts A, with pose P, accepted C" (what vilma-lcm-poses prints; core/report.h's shape).
  std::string BriefReport() const;
  // BriefReport() and the messages seen / malformed.
  std::string FullReport() const;
};

// The vilma.localization_t attempts on `channel` (VILMA_LOC) that have a pose (status "ok"),
// as T_G_I at the query frames' utime, in log order. Localization recall = attempts whose pose
// is within a tolerance of ground truth / stats->attempts. Throws InputError like ReadPoseLog.
Trajectory ReadLocalizationLog(const std::string& path, const std::string& channel,
                               LocalizationLogStats* stats);

}  // namespace vilma
