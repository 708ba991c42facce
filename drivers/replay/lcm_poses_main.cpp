// vilma-lcm-poses: writes the vilma.pose_t messages of one channel of an LCM log as a TUM
// trajectory (e.g. VILMA_POSE or VILMA_ODOM recorded by lcm-logger or written by
// vilma-estimatord --lcm-url file://...?mode=w), for `vilma eval`.
#include <iostream>
#include <string>

#include "vilma/core/error.h"
#include "vilma/drivers/pose_log.h"

namespace {

const char kUsage[] = R"(Usage: vilma-lcm-poses LOG --out TRAJ.txt [--channel NAME] [--all]

Writes the vilma.pose_t messages of one channel of an LCM log file as TUM text
(t [s] x y z qx qy qz qw), in log order, for `vilma eval` or other trajectory tools.

Options:
  --out FILE       output trajectory (TUM)
  --channel NAME   channel to read (default VILMA_POSE)
  --all            also keep poses whose status is INVALID or INITIALIZING
  --help           this text

Exit status: 0 on success, 1 on a bad or unreadable log (or no pose on the channel),
2 on bad options.
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
    vilma::PoseLogStats stats;
    const vilma::Trajectory trajectory = vilma::ReadPoseLog(log_path, channel, all, &stats);
    if (trajectory.empty()) {
      std::cerr << "vilma-lcm-poses: " << log_path << ": no usable pose_t on channel " << channel
                << " (" << stats.events_on_channel << " messages, " << stats.malformed
                << " malformed, " << stats.not_valid << " not valid)\n";
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
