#include "vilma/drivers/pose_log.h"

#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>
#include <unistd.h>
#include <vilma/pose_t.hpp>

#include "vilma/core/error.h"
#include "vilma/drivers/lcm_log.h"

namespace vilma {
namespace {

pose_t MakePose(int64_t utime, double x, int32_t status) {
  pose_t p{};
  p.utime = utime;
  p.parent_frame = "G";
  p.child_frame = "I";
  p.position[0] = x;
  p.position[1] = 2.0;
  p.position[2] = -1.0;
  const Eigen::Quaterniond q(Eigen::AngleAxisd(0.1 * x, Eigen::Vector3d::UnitZ()));
  p.orientation[0] = q.w();
  p.orientation[1] = q.x();
  p.orientation[2] = q.y();
  p.orientation[3] = q.z();
  p.status = status;
  return p;
}

TEST_CASE("ReadPoseLog extracts one pose_t channel in order and skips bad poses", "[lcm]") {
  const std::string dir = std::filesystem::temp_directory_path().string() + "/vilma_pose_log_" +
                          std::to_string(::getpid());
  std::filesystem::create_directories(dir);
  const std::string path = dir + "/poses.lcmlog";
  {
    LcmLogWriter writer(path);
    writer.WriteMessage("VILMA_ODOM", MakePose(1000000, 9.0, pose_t::TRACKING), 1000000);
    writer.WriteMessage("VILMA_POSE", MakePose(1000000, 0.0, pose_t::INITIALIZING), 1000000);
    writer.WriteMessage("VILMA_POSE", MakePose(1050000, 1.0, pose_t::LOCALIZED), 1050000);
    pose_t broken = MakePose(1100000, 2.0, pose_t::LOCALIZED);
    broken.orientation[0] = NAN;
    writer.WriteMessage("VILMA_POSE", broken, 1100000);
    const uint8_t garbage[5] = {1, 2, 3, 4, 5};
    writer.Write("VILMA_POSE", garbage, 5, 1120000);
    writer.WriteMessage("VILMA_POSE", MakePose(1150000, 3.0, pose_t::LOCALIZED), 1150000);
    writer.Close();
  }
  PoseLogStats stats;
  const Trajectory t = ReadPoseLog(path, "VILMA_POSE", false, &stats);
  REQUIRE(t.size() == 2);
  CHECK(t.t_ns[0] == 1050000000);
  CHECK(t.t_ns[1] == 1150000000);
  CHECK(t.T_W_B[1].translation().x() == 3.0);
  CHECK(AngleBetween(t.T_W_B[1].rotation(),
                     Eigen::Quaterniond(Eigen::AngleAxisd(0.3, Eigen::Vector3d::UnitZ()))) < 1e-12);
  CHECK(stats.events_on_channel == 5);
  CHECK(stats.malformed == 2);
  CHECK(stats.not_valid == 1);
  CHECK(ReadPoseLog(path, "VILMA_POSE", true, nullptr).size() == 3);
  CHECK(ReadPoseLog(path, "VILMA_ODOM", false, nullptr).size() == 1);
  CHECK_THROWS_AS(ReadPoseLog(dir + "/missing.lcmlog", "VILMA_POSE", false, nullptr), InputError);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace vilma
