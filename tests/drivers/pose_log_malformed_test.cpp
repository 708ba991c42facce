// A corrupted pose_t event in an LCM log (a string length of 0 or less, which makes lcm-gen's
// decoder throw std::length_error) is counted as malformed; the poses around it are read.
#include <unistd.h>

#include <catch2/catch.hpp>
#include <filesystem>
#include <vilma/pose_t.hpp>

#include "vilma/drivers/lcm_log.h"
#include "vilma/drivers/pose_log.h"

namespace vilma {
namespace {

pose_t Pose(int64_t utime) {
  pose_t p{};
  p.utime = utime;
  p.parent_frame = "G";
  p.child_frame = "I";
  p.orientation[0] = 1.0;
  p.status = pose_t::LOCALIZED;
  return p;
}

TEST_CASE("ReadPoseLog: an event with a bad string length is malformed, not the end", "[lcm]") {
  const std::string dir = std::filesystem::temp_directory_path().string() +
                          "/vilma_pose_log_malformed_" + std::to_string(::getpid());
  std::filesystem::create_directories(dir);
  const std::string path = dir + "/poses.lcmlog";
  for (const int32_t bad_length : {0, -5}) {
    CAPTURE(bad_length);
    {
      LcmLogWriter writer(path);
      writer.WriteMessage("VILMA_POSE", Pose(1000000), 1000000);
      const pose_t bad = Pose(1050000);
      std::vector<uint8_t> bytes(static_cast<std::size_t>(bad.getEncodedSize()));
      bad.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
      // parent_frame's length field follows the hash, utime and seq (24 bytes).
      for (int i = 0; i < 4; ++i) {
        bytes[24 + i] = static_cast<uint8_t>(static_cast<uint32_t>(bad_length) >> (24 - 8 * i));
      }
      writer.Write("VILMA_POSE", bytes.data(), static_cast<int>(bytes.size()), 1050000);
      writer.WriteMessage("VILMA_POSE", Pose(1100000), 1100000);
      writer.Close();
    }
    PoseLogStats stats;
    const Trajectory t = ReadPoseLog(path, "VILMA_POSE", false, &stats);
    CHECK(t.size() == 2);
    CHECK(stats.events_on_channel == 3);
    CHECK(stats.malformed == 1);
    CHECK(DetectPoseLogType(path, "VILMA_POSE") == PoseLogType::kPose);
  }
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace vilma
