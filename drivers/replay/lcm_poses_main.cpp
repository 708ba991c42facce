// vilma-lcm-poses: writes the vilma.pose_t messages of one channel of an LCM log as a TUM
// trajectory (e.g. VILMA_POSE or VILMA_ODOM recorded by lcm-logger or written by
// vilma-estimatord --lcm-url file://...?mode=w), for `vilma eval`. A channel of
// vilma.localization_t (VILMA_LOC, told apart by the LCM fingerprint) gives the localization
// attempts that found a pose, and a summary line for recall.
#include <iostream>
#include <string>

#include "vilma/core/error.h"
#include "vilma/drivers/pose_log.h"

namespace {

const char kUsage[] = R"(Usage: vilma-lcm-poses LOG --out TRAJ.txt [--channel NAME] [--all]

Writes the vilma.pose_t messages of one channel of an LCM log file as TUM text
(t [s] x y z qx qy qz qw), in log order, for `vilma eval` or other trajectory tools.

If the channel carries vilma.localization_t instead (vilma-estimatord's VILMA_LOC, one
message per localization attempt; the type is recognized by its LCM fingerprint), the
attempts with a pose (status "ok": T_G_I at the query frame) are written, whether the
daemon accepted them or not, and stdout gets one summary line:
  attempts 30, with pose 28, accepted 15
so that recall = (poses within a tolerance of ground truth) / attempts. No pose at all
is then a valid outcome (an empty file, exit 0).

Options:
  --out FILE       output trajectory (TUM)
  --channel NAME   channel to read (default VILMA_POSE; VILMA_LOC for the attempts)
  --all            pose_t: also keep poses whose status is INVALID or INITIALIZING
                   (no effect on localization_t)
  --help           this text

Exit status: 0 on success, 1 on a bad or unreadable log (or no pose_t pose / no
localization_t message on the channel, or another type), 2 on bad options.
)";

}  // namespace

int main(int argc, char** argv) {
  std::string log_path, out_path, channel = "VILMA_POSE";
  bool all = false;
  for (int i = 1; i < argc; ++i) {
    const std::string a = argv[i];
    if (a == "--help" || a == "-h") {
      std::cout << kUsage;
      return 0;
    } else if ((a == "--out" || a == "--channel") && i + 1 < argc) {
      (a == "--out" ? out_path : channel) = argv[++i];
    } else if (a == "--all") {
      all = true;
    } else if (!a.empty() && a[0] != '-' && log_path.empty()) {
      log_path = a;
    } else {
      std::cerr << "vilma-lcm-poses: unexpected argument '" << a << "'\n(see --help)\n";
      return 2;
    }
  }
  if (log_path.empty() || out_path.empty()) {
    std::cerr << "vilma-lcm-poses: LOG and --out are required\n(see --help)\n";
    return 2;
  }
  try {
    const vilma::PoseLogType type = vilma::DetectPoseLogType(log_path, channel);
    if (type == vilma::PoseLogType::kOther) {
      std::cerr << "vilma-lcm-poses: " << log_path << ": channel " << channel
                << " carries neither vilma.pose_t nor vilma.localization_t\n";
      return 1;
    }
    if (type == vilma::PoseLogType::kLocalization) {
      vilma::LocalizationLogStats stats;
      const vilma::Trajectory trajectory = vilma::ReadLocalizationLog(log_path, channel, &stats);
      vilma::WriteTrajectoryFile(out_path, trajectory, vilma::TrajectoryFormat::kTum);
      std::cout << stats.BriefReport() << "\n";
      std::cerr << "vilma-lcm-poses: " << trajectory.size() << " localization poses from " << channel
                << " (" << stats.malformed << " malformed skipped) -> " << out_path << "\n";
      return 0;
    }
    vilma::PoseLogStats stats;
    const vilma::Trajectory trajectory = vilma::ReadPoseLog(log_path, channel, all, &stats);
    if (trajectory.empty()) {
      std::cerr << "vilma-lcm-poses: " << log_path << ": no usable pose_t on channel " << channel
                << " (" << stats.BriefReport() << ")\n";
      return 1;
    }
    vilma::WriteTrajectoryFile(out_path, trajectory, vilma::TrajectoryFormat::kTum);
    std::cout << "vilma-lcm-poses: " << trajectory.size() << " poses from " << channel << " ("
              << stats.malformed << " malformed, " << stats.not_valid
              << " not valid skipped) -> " << out_path << "\n";
    return 0;
  } catch (const std::exception& e) {
    std::cerr << "vilma-lcm-poses: error: " << e.what() << "\n";
    return 1;
  }
}
