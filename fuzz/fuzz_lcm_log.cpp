// LCM log files (drivers/common/lcm_log.h) as `vilma-estimatord --input-log` and vilma-replay
// read them.
#include <cstddef>
#include <cstdint>
#include <exception>
#include <filesystem>

#include "fuzz_util.h"
#include "vilma/drivers/lcm_log.h"
#include <string>
#include <vector>
#include "vilma/drivers/lcm_convert.h"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  vilma::fuzz::WriteSeedsIfAsked([] {
    const std::filesystem::path path = vilma::fuzz::ScratchDir("lcm_log") / "seed.lcmlog";
    {
      vilma::LcmLogWriter writer(path.string());
      vilma::ImuSample sample;
      sample.a_I << 0.0, 0.0, 9.81;
      for (int i = 0; i < 3; ++i) {
        sample.t_ns = 1000000LL * i;
        writer.WriteMessage("IMU", vilma::ImuToMessage(sample, i), i * 1000);
      }
      cv::Mat gray(4, 6, CV_8UC1, cv::Scalar(77));
      vilma::image_t image;
      vilma::MakeImageMessage(gray, vilma::image_t::GRAY8, 1500000, 0, 0, &image);
      writer.WriteMessage("CAM0", image, 1500);
      writer.Close();
    }
    return std::vector<std::string>{vilma::fuzz::ReadText(path)};
  });
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  const std::filesystem::path path = vilma::fuzz::ScratchDir("lcm_log") / "input.lcmlog";
  vilma::fuzz::WriteBytes(path, data, size);
  try {
    vilma::ReadLcmLog(path.string());
  } catch (const std::exception&) {
  }
  return 0;
}
