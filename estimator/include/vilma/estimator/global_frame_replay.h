// Offline replay of LOC mode's T_G_M fusion (docs/daemon.md "T_G_M estimation", "Replaying the
// fusion"): vilma-estimatord's localization results and odometry of a recorded run, fused again
// with other GlobalFrameOptions, give the global poses the daemon would have published with
// them, in milliseconds instead of a daemon run per setting. The localizer is not re-run: the
// results (T_G_I, covariance, inliers) are those of the recording, which do not depend on the
// fusion (the queries' T_M_I come from the filter, which the fusion does not feed back into).
// No LCM here: vilma-loc-replay (daemon/tools) decodes the log.
#pragma once

#include <cstdint>
#include <vector>

#include "vilma/core/geometry.h"
#include "vilma/estimator/global_frame_estimator.h"

namespace vilma::estimator {

// One frame of the filter's output (VILMA_ODOM): `tracked` = a valid pose in the odometry frame
// M. A frame that is not tracked after a tracked one is the filter's reset: a new M frame.
struct OdometrySample {
  int64_t t_ns = 0;
  bool tracked = false;
  Transformation T_M_I;
};

// One localization attempt (VILMA_LOC) at an odometry frame's time.
struct LocalizationSample {
  int64_t t_ns = 0;
  bool ok = false;   // the localizer found a pose (status "ok"); the rest is valid only then
  int inliers = 0;   // RANSAC inliers
  Transformation T_G_I;
  // Covariance of the global (left) error of T_G_I, as VILMA_LOC publishes it: (R rho, R phi)
  // for T_G_I Exp([rho; phi]) [m^2, rad^2].
  Matrix6d covariance_G = Matrix6d::Identity();
};

struct GlobalFrameReplayOptions {
  GlobalFrameOptions global_frame;  // the daemon's localization.* fusion keys
  int min_inliers = 30;             // the daemon's localization.min_inliers
};

struct GlobalFramePose {
  int64_t t_ns = 0;
  Transformation T_G_I;  // T_G_M T_M_I, as VILMA_POSE
};

struct GlobalFrameReplayResult {
  std::vector<GlobalFramePose> poses;  // one per tracked frame once T_G_M is initialized
  // Decisions, as the daemon's VILMA_LOC "decision" and loc_* counters.
  int64_t attempts = 0;            // localization samples at a replayed frame
  int64_t failed = 0;              // not ok
  int64_t accepted = 0;            // fused (a re-initialization from a result included)
  int64_t rejected_inliers = 0;
  int64_t rejected_gravity = 0;
  int64_t rejected_jump = 0;
  int64_t reinitializations = 0;   // max_consecutive_gated jumps in a row
  int64_t m_frame_resets = 0;      // filter resets (a new M frame drops T_G_M)
  int64_t unmatched = 0;           // localization samples without an odometry frame at their time
};

// Replays the fusion as vilma-estimatord's filter thread applies it in --input-log mode: per
// odometry frame in time order, first the reset of T_G_M if the filter reset (the first frame
// not tracked after a tracked one), then the localization result of that frame (queried at it
// and applied before its pose is published), then the global pose. Both inputs in time order
// (as logged). Live runs apply a result a few frames after its query; their replay is then
// approximate (the tool reports the difference to the recorded VILMA_POSE).
GlobalFrameReplayResult ReplayGlobalFrame(const std::vector<OdometrySample>& odometry,
                                          const std::vector<LocalizationSample>& localizations,
                                          const GlobalFrameReplayOptions& options);

}  // namespace vilma::estimator
