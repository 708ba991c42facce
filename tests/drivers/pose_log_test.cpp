#include "vilma/drivers/pose_log.h"

#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>
#include <unistd.h>
#include <vilma/localization_t.hpp>
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

localization_t MakeAttempt(int64_t utime, const std::string& status, const std::string& decision,
                           double x) {
  localization_t m{};
  m.utime = utime;
  m.status = status;
  m.decision = decision;
  m.position[0] = x;
  m.orientation[0] = 1.0;
  return m;
}

TEST_CASE("ReadLocalizationLog: attempts with a pose, counts for recall, type by fingerprint",
          "[lcm]") {
  const std::string dir = std::filesystem::temp_directory_path().string() + "/vilma_loc_log_" +
                          std::to_string(::getpid());
  std::filesystem::create_directories(dir);
  const std::string path = dir + "/loc.lcmlog";
  {
    LcmLogWriter writer(path);
    writer.WriteMessage("VILMA_POSE", MakePose(1000000, 0.0, pose_t::LOCALIZED), 1000000);
    writer.WriteMessage("VILMA_LOC", MakeAttempt(1000000, "too_few_inliers", "failed", 0.0), 1000000);
    writer.WriteMessage("VILMA_LOC", MakeAttempt(1500000, "ok", "rejected_inliers", 1.0), 1500000);
    writer.WriteMessage("VILMA_LOC", MakeAttempt(2000000, "ok", "accepted", 2.0), 2000000);
    localization_t broken = MakeAttempt(2500000, "ok", "accepted", 3.0);
    broken.orientation[0] = NAN;
    writer.WriteMessage("VILMA_LOC", broken, 2500000);
    const uint8_t garbage[5] = {1, 2, 3, 4, 5};
    writer.Write("VILMA_LOC", garbage, 5, 2600000);
    writer.WriteMessage("VILMA_LOC", MakeAttempt(3000000, "ok", "accepted", 4.0), 3000000);
    writer.Write("OTHER", garbage, 5, 3000000);
    writer.Close();
  }
  CHECK(DetectPoseLogType(path, "VILMA_LOC") == PoseLogType::kLocalization);
  CHECK(DetectPoseLogType(path, "VILMA_POSE") == PoseLogType::kPose);
  CHECK(DetectPoseLogType(path, "OTHER") == PoseLogType::kOther);
  CHECK(DetectPoseLogType(path, "NONE") == PoseLogType::kEmpty);
  LocalizationLogStats stats;
  const Trajectory t = ReadLocalizationLog(path, "VILMA_LOC", &stats);
  REQUIRE(t.size() == 3);  // the "ok" attempts with a finite pose, accepted or not
  CHECK(t.t_ns[0] == 1500000000);
  CHECK(t.T_W_B[0].translation().x() == 1.0);
  CHECK(t.t_ns[2] == 3000000000);
  CHECK(stats.events_on_channel == 6);
  CHECK(stats.attempts == 5);
  CHECK(stats.with_pose == 3);
  CHECK(stats.accepted == 3);  // the broken one was accepted too: decisions count as sent
  CHECK(stats.malformed == 2);
  // pose_t readers do not take localization_t for poses (another fingerprint).
  PoseLogStats pose_stats;
  CHECK(ReadPoseLog(path, "VILMA_LOC", true, &pose_stats).empty());
  CHECK(pose_stats.malformed == 6);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace vilma
