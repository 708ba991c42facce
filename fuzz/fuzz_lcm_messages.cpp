// The estimator daemon's decoding of untrusted LCM payloads: image_t (validated, converted to
// 8-bit gray as the tracker needs) and imu_t. The first byte picks the type.
#include <opencv2/core.hpp>

#include <cstddef>
#include <cstdint>
#include <exception>

#include "vilma/drivers/lcm_convert.h"
#include <string>
#include <vector>
#include "fuzz_util.h"

extern "C" int LLVMFuzzerInitialize(int*, char***) {
  vilma::fuzz::WriteSeedsIfAsked([] {
    std::vector<std::string> seeds;
    const auto encode = [](const auto& msg) {
      std::string bytes(static_cast<std::size_t>(msg.getEncodedSize()), '\0');
      msg.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
      return bytes;
    };
    cv::Mat gray(6, 8, CV_8UC1);
    for (int i = 0; i < gray.rows * gray.cols; ++i) gray.data[i] = static_cast<uint8_t>(i * 5);
    cv::Mat gray16(4, 5, CV_16UC1, cv::Scalar(1000));
    cv::Mat bgr(4, 4, CV_8UC3, cv::Scalar(10, 200, 30));
    vilma::image_t image;
    vilma::MakeImageMessage(gray, vilma::image_t::GRAY8, 1000, 1, 0, &image);
    seeds.push_back(vilma::fuzz::WithPrefix(0, encode(image)));
    vilma::MakeImageMessage(gray16, vilma::image_t::GRAY16, 2000, 2, 1, &image);
    seeds.push_back(vilma::fuzz::WithPrefix(0, encode(image)));
    vilma::MakeImageMessage(bgr, vilma::image_t::PNG, 3000, 3, 0, &image);
    seeds.push_back(vilma::fuzz::WithPrefix(0, encode(image)));
    vilma::MakeImageMessage(gray, vilma::image_t::BAYER_RGGB8, 4000, 4, 0, &image);
    seeds.push_back(vilma::fuzz::WithPrefix(0, encode(image)));
    vilma::ImuSample sample;
    sample.t_ns = 5000;
    sample.omega_I << 0.1, -0.2, 0.3;
    sample.a_I << 0.0, 0.0, 9.81;
    seeds.push_back(vilma::fuzz::WithPrefix(1, encode(vilma::ImuToMessage(sample, 7))));
    return seeds;
  });
  return 0;
}

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, std::size_t size) {
  if (size < 1) return 0;
  const uint8_t* payload = data + 1;
  const int payload_size = static_cast<int>(size - 1);
  try {
    if (data[0] % 2 == 0) {
      vilma::image_t msg;
      if (vilma::DecodeImageMessage(payload, payload_size, &msg).empty()) {
        cv::Mat gray;
        vilma::MessageToGray8(msg, &gray);
      }
    } else {
      vilma::imu_t msg;
      vilma::ImuSample sample;
      vilma::DecodeImuMessage(payload, payload_size, &msg, &sample);
    }
  } catch (const std::exception&) {
    // Rejected with an error: the expected outcome for bad input.
  }
  return 0;
}
