// vilma-loc-replay: LOC mode's T_G_M fusion replayed on a recorded vilma-estimatord run with
// other options (estimator/global_frame_replay.h; docs/daemon.md "Replaying the fusion").
#include <cmath>
#include <iomanip>
#include <iostream>
#include <map>
#include <string>
#include <vector>

#include <vilma/localization_t.hpp>
#include <vilma/pose_t.hpp>

#include "vilma/core/error.h"
#include "vilma/daemon/daemon_options.h"
#include "vilma/drivers/lcm_log.h"
#include "vilma/estimator/global_frame_replay.h"
#include "vilma/eval/trajectory.h"

namespace {

const char kUsage[] = R"(Usage: vilma-loc-replay LOG --out TRAJ.txt [--config DAEMON.yaml]

Replays LOC mode's T_G_M fusion offline. LOG is an LCM log of a vilma-estimatord run in LOC
mode (lcm-logger, or --lcm-url file://LOG?mode=w) with its odometry (VILMA_ODOM) and its
localization attempts (VILMA_LOC). The recorded results are fused again with the
localization.* options of DAEMON.yaml (a partial file is enough: absent keys keep the
defaults; without --config, the defaults) and the global poses T_G_I = T_G_M T_M_I are
written as TUM text, the poses VILMA_POSE would have carried, for `vilma eval`. The localizer
is not re-run: min_inliers and the fusion keys (max_jump_*, forgetting_factor, drift_*,
min_sigma_*, noise_scale_*, ...) can be tuned this way in milliseconds per setting.

stdout: the decisions (as VILMA_LOC's) and, against the log's own VILMA_POSE, the largest
difference on common frames. With the options of the recorded run it is ~1e-12 m for a run
from --input-log (results applied at their query frame); live runs apply a result a few
frames later, so their replay is approximate.

Options:
  --out FILE        output trajectory (TUM: t [s] x y z qx qy qz qw)
  --config FILE     daemon options (their localization and channels sections are used)
  --help            this text

Exit status: 0 on success, 1 on a bad or unreadable log or config (or no odometry in the
log), 2 on bad options.
)";

struct Recorded {
  std::vector<vilma::estimator::OdometrySample> odometry;
  std::vector<vilma::estimator::LocalizationSample> localizations;
  std::map<int64_t, vilma::Transformation> poses;  // the log's VILMA_POSE by t_ns
  int64_t malformed = 0;
};

template <typename Msg>
vilma::Transformation PoseOf(const Msg& m) {
  return vilma::Transformation(
      Eigen::Quaterniond(m.orientation[0], m.orientation[1], m.orientation[2], m.orientation[3]),
      Eigen::Vector3d(m.position[0], m.position[1], m.position[2]));
}

template <typename Msg>
bool Decode(const std::vector<uint8_t>& data, Msg* m) {
  return m->decode(data.data(), 0, static_cast<int>(data.size())) > 0;
}

Recorded ReadRecordedRun(const std::string& path, const vilma::daemon::ChannelOptions& channels) {
  Recorded r;
  for (const vilma::LcmLogEvent& e : vilma::ReadLcmLog(path)) {
    if (e.channel == channels.odometry || e.channel == channels.pose) {
      vilma::pose_t m;
      if (!Decode(e.data, &m)) {
        ++r.malformed;
        continue;
      }
      const int64_t t_ns = m.utime * 1000;
      if (e.channel == channels.pose) {
        r.poses[t_ns] = PoseOf(m);
        continue;
      }
      vilma::estimator::OdometrySample s;
      s.t_ns = t_ns;
      s.tracked = m.status == vilma::pose_t::TRACKING;
      if (s.tracked) s.T_M_I = PoseOf(m);
      r.odometry.push_back(s);
    } else if (e.channel == channels.localization) {
      vilma::localization_t m;
      if (!Decode(e.data, &m)) {
        ++r.malformed;
        continue;
      }
      vilma::estimator::LocalizationSample s;
      s.t_ns = m.utime * 1000;
      s.ok = m.status == "ok";
      s.inliers = m.num_inliers;
      if (s.ok) {
        s.T_G_I = PoseOf(m);
        for (int i = 0; i < 36; ++i) s.covariance_G(i / 6, i % 6) = m.covariance[i];
      }
      r.localizations.push_back(s);
    }
  }
  return r;
}

}  // namespace

int main(int argc, char** argv) {
  std::string log_path, out_path, config_path;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      std::cout << kUsage;
      return 0;
    } else if ((a == "--out" || a == "--config") && i + 1 < argc) {
      (a == "--out" ? out_path : config_path) = argv[++i];
    } else if (!a.empty() && a[0] != '-' && log_path.empty()) {
      log_path = a;
    } else {
      std::cerr << "vilma-loc-replay: unexpected argument '" << a << "'\n(see --help)\n";
      return 2;
    }
  }
  if (log_path.empty() || out_path.empty()) {
    std::cerr << "vilma-loc-replay: LOG and --out are required\n(see --help)\n";
    return 2;
  }
  try {
    const vilma::daemon::DaemonOptions daemon_options =
        config_path.empty() ? vilma::daemon::DaemonOptions() : vilma::daemon::LoadDaemonOptions(config_path);
    const Recorded recorded = ReadRecordedRun(log_path, daemon_options.channels);
    if (recorded.odometry.empty()) {
      std::cerr << "vilma-loc-replay: " << log_path << ": no vilma.pose_t on "
                << daemon_options.channels.odometry << " (a vilma-estimatord output log?)\n";
      return 1;
    }
    vilma::estimator::GlobalFrameReplayOptions options;
    options.global_frame = daemon_options.localization.global_frame;
    options.min_inliers = daemon_options.localization.min_inliers;
    const vilma::estimator::GlobalFrameReplayResult result = vilma::estimator::ReplayGlobalFrame(
        recorded.odometry, recorded.localizations, options);
    vilma::Trajectory trajectory;
    for (const vilma::estimator::GlobalFramePose& p : result.poses) {
      trajectory.t_ns.push_back(p.t_ns);
      trajectory.T_W_B.push_back(p.T_G_I);
    }
    vilma::WriteTrajectoryFile(out_path, trajectory, vilma::TrajectoryFormat::kTum);
    // Against the recorded VILMA_POSE: the replay's fidelity with the run's own options.
    double max_dp = 0.0, max_dq_deg = 0.0;
    int64_t common = 0;
    for (const vilma::estimator::GlobalFramePose& p : result.poses) {
      const auto it = recorded.poses.find(p.t_ns);
      if (it == recorded.poses.end()) continue;
      ++common;
      max_dp = std::max(max_dp, (p.T_G_I.translation() - it->second.translation()).norm());
      max_dq_deg = std::max(max_dq_deg, p.T_G_I.rotation().angularDistance(it->second.rotation()) *
                                            180.0 / M_PI);
    }
    std::cout << "vilma-loc-replay: " << recorded.odometry.size() << " odometry frames, "
              << result.attempts << " localization attempts (" << recorded.malformed
              << " malformed messages skipped, " << result.unmatched
              << " attempts without an odometry frame)\n"
              << "  decisions        " << result.accepted << " accepted ("
              << result.reinitializations << " re-initializations), " << result.failed
              << " failed, " << result.rejected_inliers << " rejected inliers, "
              << result.rejected_gravity << " rejected gravity, " << result.rejected_jump
              << " rejected jump; " << result.m_frame_resets << " filter resets\n"
              << "  global poses     " << result.poses.size() << " -> " << out_path << "\n"
              << "  recorded poses   " << recorded.poses.size() << " on "
              << daemon_options.channels.pose << "; " << common
              << " at common frames, largest difference " << std::setprecision(3)
              << std::scientific << max_dp << " m, " << max_dq_deg << " deg\n";
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "vilma-loc-replay: error: " << e.what() << "\n";
    return 1;
  }
}
