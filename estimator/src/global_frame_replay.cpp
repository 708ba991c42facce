#include "vilma/estimator/global_frame_replay.h"

#include <cstddef>

namespace vilma::estimator {

GlobalFrameReplayResult ReplayGlobalFrame(const std::vector<OdometrySample>& odometry,
                                          const std::vector<LocalizationSample>& localizations,
                                          const GlobalFrameReplayOptions& options) {
  GlobalFrameReplayResult result;
  GlobalFrameEstimator estimator(options.global_frame);
  std::size_t next_loc = 0;
  bool was_tracked = false;
  for (const OdometrySample& frame : odometry) {
    // Results stamped before this frame have no frame of their own (not in a daemon log).
    while (next_loc < localizations.size() && localizations[next_loc].t_ns < frame.t_ns) {
      ++result.unmatched;
      ++next_loc;
    }
    if (!frame.tracked) {
      if (was_tracked) {
        // The filter reset: a new odometry frame M, T_G_M starts again (LocClient::NewMFrame).
        estimator.Reset();
        ++result.m_frame_resets;
      }
      was_tracked = false;
      continue;
    }
    was_tracked = true;
    while (next_loc < localizations.size() && localizations[next_loc].t_ns == frame.t_ns) {
      // LocClient::Decide: the localizer's status, the inlier count, then the fusion's gates.
      const LocalizationSample& loc = localizations[next_loc++];
      ++result.attempts;
      if (!loc.ok) {
        ++result.failed;
        continue;
      }
      if (loc.inliers < options.min_inliers) {
        ++result.rejected_inliers;
        continue;
      }
      // VILMA_LOC's covariance is of the global error (R rho, R phi); the estimator takes the
      // body one: C_I = A^T C_G A with A = diag(R_G_I, R_G_I).
      Matrix6d A = Matrix6d::Zero();
      A.block<3, 3>(0, 0) = loc.T_G_I.rotation().toRotationMatrix();
      A.block<3, 3>(3, 3) = A.block<3, 3>(0, 0);
      const Matrix6d covariance_I = A.transpose() * loc.covariance_G * A;
      switch (estimator.Update(loc.T_G_I, covariance_I, frame.T_M_I, frame.t_ns)) {
        case GlobalFrameUpdate::kAccepted: ++result.accepted; break;
        case GlobalFrameUpdate::kRejectedGravity: ++result.rejected_gravity; break;
        case GlobalFrameUpdate::kRejectedJump: ++result.rejected_jump; break;
        case GlobalFrameUpdate::kReinitialized:
          ++result.reinitializations;
          ++result.accepted;
          break;
      }
    }
    if (estimator.initialized()) {
      result.poses.push_back({frame.t_ns, estimator.T_G_M() * frame.T_M_I});
    }
  }
  result.unmatched += static_cast<int64_t>(localizations.size() - next_loc);
  return result;
}

}  // namespace vilma::estimator
