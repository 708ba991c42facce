// vilma-sim --live publishes the same sequence that vilma-sim --out writes: same stamps, same
// IMU samples, same pixels, in time order. LCM's file provider (file://...?mode=w) records
// what the process publishes without a network, so the comparison is exact.
#include <catch2/catch.hpp>
#include <filesystem>
#include <map>

#include "integration/process_util.h"
#include "vilma/core/asl_dataset.h"
#include "vilma/core/time.h"
#include "vilma/drivers/lcm_convert.h"
#include "vilma/drivers/lcm_log.h"
#include "test_skip.h"

namespace vilma {
namespace {

const std::string kSim = std::string(VILMA_BINARY_DIR) + "/bin/vilma-sim";

TEST_CASE("vilma-sim --live publishes what vilma-sim --out writes", "[integration][sim]") {
  if (!test::FileExists(kSim)) {
    VILMA_SKIP(kSim << " not built");
  }
  const std::string dir = test::ScratchDir() + "/sim_live";
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  const std::string log_path = dir + "/live.lcm";
  const std::vector<std::string> common = {"room", "--seconds", "2", "--seed", "5", "--stereo"};

  std::vector<std::string> live_args = {kSim};
  live_args.insert(live_args.end(), common.begin(), common.end());
  for (const char* a : {"--live", "--rate", "4", "--lcm-url"}) live_args.push_back(a);
  live_args.push_back("file://" + log_path + "?mode=w");
  test::ChildProcess live(live_args, dir + "/live.out");
  REQUIRE(live.Wait(60.0) == 0);

  std::vector<std::string> file_args = {kSim};
  file_args.insert(file_args.end(), common.begin(), common.end());
  file_args.push_back("--out");
  file_args.push_back(dir + "/dataset");
  test::ChildProcess written(file_args, dir + "/file.out");
  REQUIRE(written.Wait(60.0) == 0);
  const AslDataset dataset = AslDataset::Open(dir + "/dataset");
  REQUIRE(dataset.cameras().size() == 2);

  std::map<std::string, int> counts;
  int64_t last_utime = -1;
  LcmLogReader reader(log_path);
  LcmLogEvent event;
  while (reader.Next(&event)) {
    const int index = counts[event.channel]++;
    const int size = static_cast<int>(event.data.size());
    if (event.channel == "IMU") {
      imu_t msg;
      ImuSample sample;
      REQUIRE(DecodeImuMessage(event.data.data(), size, &msg, &sample).empty());
      CHECK(msg.seq == index);
      REQUIRE(index < static_cast<int>(dataset.imu().size()));
      const ImuSample& expected = dataset.imu()[static_cast<std::size_t>(index)];
      CHECK(msg.utime == NsToUtime(expected.t_ns));
      // The CSV keeps 10 significant digits.
      CHECK((sample.omega_I - expected.omega_I).norm() < 1e-8 * (1.0 + expected.omega_I.norm()));
      CHECK((sample.a_I - expected.a_I).norm() < 1e-8 * (1.0 + expected.a_I.norm()));
      CHECK(msg.utime >= last_utime);
      last_utime = msg.utime;
    } else {
      REQUIRE((event.channel == "CAM0" || event.channel == "CAM1"));
      const std::size_t camera = event.channel == "CAM0" ? 0 : 1;
      image_t msg;
      REQUIRE(DecodeImageMessage(event.data.data(), size, &msg).empty());
      CHECK(msg.seq == index);
      CHECK(msg.camera_id == static_cast<int>(camera));
      REQUIRE(index < static_cast<int>(dataset.cameras()[camera].frames.size()));
      const CameraFrame& frame = dataset.cameras()[camera].frames[static_cast<std::size_t>(index)];
      CHECK(msg.utime == NsToUtime(frame.t_ns));
      cv::Mat image;
      REQUIRE(MessageToGray8(msg, &image).empty());
      const cv::Mat expected = AslDataset::LoadImage(frame.image_path);
      CHECK(cv::norm(image, expected, cv::NORM_INF) == 0.0);
      CHECK(msg.utime >= last_utime);
      last_utime = msg.utime;
    }
  }
  // 2 s at 200 Hz and 20 Hz, both ends included.
  CHECK(counts["IMU"] == 401);
  CHECK(counts["CAM0"] == 41);
  CHECK(counts["CAM1"] == 41);
  CHECK(counts.size() == 3);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace vilma
