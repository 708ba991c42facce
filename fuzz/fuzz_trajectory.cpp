// Trajectory files of other systems as `vilma eval` reads them (TUM, EuRoC/ASL CSV, KITTI, with
// headers, separators, repeated stamps, ns or s).
#include <cstddef>
#include <cstdint>
#include <exception>
#include <sstream>
#include <string>

#include "vilma/eval/trajectory.h"
#include <vector>
#include "fuzz_util.h"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  vilma::fuzz::WriteSeedsIfAsked([] {
    vilma::Trajectory trajectory;
    for (int i = 0; i < 4; ++i) {
      trajectory.Add(1403715273262142976 + i * 50000000LL,
                     vilma::Transformation(Eigen::Quaterniond(1.0, 0.01 * i, 0.0, 0.0).normalized(),
                                           Eigen::Vector3d(0.1 * i, -0.2, 1.0)));
    }
    std::vector<std::string> seeds;
    std::ostringstream tum, euroc, kitti;
    vilma::WriteTumTrajectory(tum, trajectory);
    vilma::WriteEurocTrajectory(euroc, trajectory);
    vilma::WriteKittiTrajectory(kitti, trajectory);
    seeds = {tum.str(), euroc.str(), kitti.str(),
             "# timestamp tx ty tz qx qy qz qw\n1.0 0 0 0 0 0 0 1\n1.0 1 0 0 0 0 0 1\n"
             "1.1,0.5,0,0,0,0,0,1\n"};
    return seeds;
  });
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  std::istringstream in(std::string(reinterpret_cast<const char*>(data), size));
  try {
    vilma::TrajectoryReadReport report;
    vilma::ReadTrajectory(in, "fuzz-trajectory.txt", &report);
    vilma::TrajectoryReadSummary(report);
    vilma::TrajectoryReadWarnings(report);
  } catch (const std::exception&) {
  }
  return 0;
}
