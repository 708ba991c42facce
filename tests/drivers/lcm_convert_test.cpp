#include "vilma/drivers/lcm_convert.h"

#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <opencv2/imgproc.hpp>
#include <random>
#include <vector>

#include "vilma/core/time.h"

namespace vilma {
namespace {

cv::Mat RandomImage(int rows, int cols, int type, unsigned seed) {
  cv::Mat image(rows, cols, type);
  cv::RNG rng(seed);
  rng.fill(image, cv::RNG::UNIFORM, 0, CV_MAT_DEPTH(type) == CV_16U ? 65536 : 256);
  return image;
}

bool Equal(const cv::Mat& a, const cv::Mat& b) {
  return a.size() == b.size() && a.type() == b.type() && cv::norm(a, b, cv::NORM_INF) == 0;
}

std::vector<uint8_t> Encode(const image_t& msg) {
  std::vector<uint8_t> bytes(static_cast<size_t>(msg.getEncodedSize()));
  msg.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  return bytes;
}

TEST_CASE("Raw images round-trip through image_t and its encoding", "[lcm]") {
  struct Case {
    int32_t format;
    int type;
  };
  const Case c = GENERATE(Case{image_t::GRAY8, CV_8UC1}, Case{image_t::GRAY16, CV_16UC1},
                          Case{image_t::RGB8, CV_8UC3}, Case{image_t::BGR8, CV_8UC3});
  CAPTURE(PixelFormatName(c.format));
  const cv::Mat image = RandomImage(37, 53, c.type, 7);  // odd sizes: no accidental alignment
  image_t msg{};
  REQUIRE(MakeImageMessage(image, c.format, 1403715273262142976, 5, 1, &msg).empty());
  CHECK(msg.utime == 1403715273262143);  // rounded to the nearest microsecond
  CHECK(msg.seq == 5);
  CHECK(msg.camera_id == 1);
  CHECK(msg.width == 53);
  CHECK(msg.height == 37);
  CHECK(msg.row_stride == 53 * BytesPerPixel(c.format));
  CHECK(msg.size == 37 * msg.row_stride);
  CHECK(ValidateImageMessage(msg).empty());

  const std::vector<uint8_t> bytes = Encode(msg);
  image_t decoded{};
  REQUIRE(DecodeImageMessage(bytes.data(), static_cast<int>(bytes.size()), &decoded).empty());
  cv::Mat back;
  REQUIRE(MessageToImage(decoded, &back).empty());
  CHECK(Equal(back, image));
}

TEST_CASE("Non-contiguous images and padded row strides", "[lcm]") {
  const cv::Mat big = RandomImage(40, 60, CV_8UC1, 3);
  const cv::Mat roi = big(cv::Rect(5, 7, 20, 10));  // not continuous
  image_t msg{};
  REQUIRE(ImageToMessage(roi, image_t::GRAY8, &msg).empty());
  cv::Mat back;
  REQUIRE(MessageToImage(msg, &back).empty());
  CHECK(Equal(back, roi));

  // A camera that pads rows to 32 bytes: row_stride > width.
  image_t padded;
  padded.width = 20;
  padded.height = 10;
  padded.row_stride = 32;
  padded.pixel_format = image_t::GRAY8;
  padded.camera_id = 0;
  padded.data.assign(32 * 10, 0xEE);
  for (int r = 0; r < 10; ++r) {
    for (int c = 0; c < 20; ++c) padded.data[r * 32 + c] = roi.at<uint8_t>(r, c);
  }
  padded.size = static_cast<int32_t>(padded.data.size());
  REQUIRE(MessageToImage(padded, &back).empty());
  CHECK(Equal(back, roi));
}

TEST_CASE("PNG and JPEG messages decode", "[lcm]") {
  const cv::Mat gray = RandomImage(24, 32, CV_8UC1, 11);
  image_t msg{};
  REQUIRE(ImageToMessage(gray, image_t::PNG, &msg).empty());
  CHECK(msg.row_stride == 0);
  CHECK(ValidateImageMessage(msg).empty());
  cv::Mat back;
  REQUIRE(MessageToImage(msg, &back).empty());
  CHECK(Equal(back, gray));  // PNG is lossless

  // JPEG is lossy: a smooth image comes back close.
  cv::Mat smooth(48, 64, CV_8UC3);
  for (int r = 0; r < smooth.rows; ++r) {
    for (int c = 0; c < smooth.cols; ++c) smooth.at<cv::Vec3b>(r, c) = cv::Vec3b(2 * c, 3 * r, 100);
  }
  REQUIRE(ImageToMessage(smooth, image_t::JPEG, &msg).empty());
  REQUIRE(MessageToImage(msg, &back).empty());
  REQUIRE(back.type() == CV_8UC3);
  CHECK(cv::norm(back, smooth, cv::NORM_L1) / smooth.total() / 3 < 3.0);

  // A header that disagrees with the encoded file is refused.
  msg.width = 65;
  CHECK_FALSE(MessageToImage(msg, &back).empty());
  // Garbage bytes do not decode.
  msg.width = 64;
  msg.data.assign(100, 0x42);
  msg.size = 100;
  CHECK(MessageToImage(msg, &back) == "image_t: JPEG data does not start with the SOI marker");
}

TEST_CASE("Compressed images are checked before OpenCV decodes them", "[lcm]") {
  // Found by fuzz_lcm_messages: bytes without the format's signature reached whichever OpenCV
  // decoder accepted them, and a file can claim any size.
  const cv::Mat gray = RandomImage(24, 32, CV_8UC1, 12);
  image_t png{};
  REQUIRE(ImageToMessage(gray, image_t::PNG, &png).empty());
  cv::Mat back;
  image_t msg = png;
  msg.data[0] = '/';  // the signature's first byte
  CHECK(MessageToImage(msg, &back) ==
        "image_t: PNG data does not start with the PNG signature and IHDR");
  // The IHDR says 32x24; a header of 32x25 is refused before decoding.
  msg = png;
  msg.height = 25;
  CHECK(MessageToImage(msg, &back) == "image_t: PNG file is 32x24, header says 32x25");
  // A PNG claiming 20000 x 20000 px (a decompression bomb) is refused by its header alone.
  msg = png;
  msg.width = msg.height = 20000;
  CHECK(MessageToImage(msg, &back) ==
        "image_t: PNG of 20000x20000 px, above the limit of 67108864 px");
  image_t jpeg{};
  REQUIRE(ImageToMessage(gray, image_t::JPEG, &jpeg).empty());
  REQUIRE(MessageToImage(jpeg, &back).empty());
  msg = jpeg;
  msg.width = 31;
  CHECK(MessageToImage(msg, &back) == "image_t: JPEG file is 32x24, header says 31x24");
  msg = jpeg;
  msg.data.resize(40);  // cut before the start-of-frame segment ends
  msg.size = 40;
  CHECK_FALSE(MessageToImage(msg, &back).empty());
}

TEST_CASE("Bayer mosaics demosaic to the right colours", "[lcm]") {
  // A flat colour (B, G, R) = (30, 120, 220), sampled by each pattern; the top-left 2x2 block
  // names the pattern (RGGB: R at (0,0), G at (0,1) and (1,0), B at (1,1)).
  const int b = 30, g = 120, r = 220;
  struct Case {
    int32_t format;
    int tl, tr, bl, br;
  };
  const Case c = GENERATE(Case{image_t::BAYER_RGGB8, r, g, g, b}, Case{image_t::BAYER_BGGR8, b, g, g, r},
                          Case{image_t::BAYER_GBRG8, g, b, r, g}, Case{image_t::BAYER_GRBG8, g, r, b, g});
  CAPTURE(PixelFormatName(c.format));
  cv::Mat mosaic(16, 16, CV_8UC1);
  for (int y = 0; y < 16; ++y) {
    for (int x = 0; x < 16; ++x) {
      mosaic.at<uint8_t>(y, x) = static_cast<uint8_t>(
          (y % 2 == 0) ? (x % 2 == 0 ? c.tl : c.tr) : (x % 2 == 0 ? c.bl : c.br));
    }
  }
  image_t msg{};
  REQUIRE(ImageToMessage(mosaic, c.format, &msg).empty());
  cv::Mat bgr;
  REQUIRE(MessageToImage(msg, &bgr).empty());
  REQUIRE(bgr.type() == CV_8UC3);
  const cv::Vec3b center = bgr.at<cv::Vec3b>(8, 8);
  CHECK(center[0] == b);
  CHECK(center[1] == g);
  CHECK(center[2] == r);

  cv::Mat gray;
  REQUIRE(MessageToGray8(msg, &gray).empty());
  CHECK(gray.type() == CV_8UC1);
  CHECK(std::abs(gray.at<uint8_t>(8, 8) - (0.299 * r + 0.587 * g + 0.114 * b)) <= 1.0);
}

TEST_CASE("MessageToGray8 converts every raw format", "[lcm]") {
  cv::Mat gray16(4, 4, CV_16UC1, cv::Scalar(256 * 200));
  image_t msg{};
  REQUIRE(ImageToMessage(gray16, image_t::GRAY16, &msg).empty());
  cv::Mat gray;
  REQUIRE(MessageToGray8(msg, &gray).empty());
  CHECK(gray.type() == CV_8UC1);
  CHECK(gray.at<uint8_t>(2, 2) == 200);

  // RGB8 and BGR8 of the same colour give the same gray.
  cv::Mat rgb(4, 4, CV_8UC3, cv::Scalar(200, 50, 10));  // R=200, G=50, B=10
  cv::Mat bgr(4, 4, CV_8UC3, cv::Scalar(10, 50, 200));
  cv::Mat g1, g2;
  REQUIRE(ImageToMessage(rgb, image_t::RGB8, &msg).empty());
  REQUIRE(MessageToGray8(msg, &g1).empty());
  REQUIRE(ImageToMessage(bgr, image_t::BGR8, &msg).empty());
  REQUIRE(MessageToGray8(msg, &g2).empty());
  CHECK(g1.at<uint8_t>(0, 0) == g2.at<uint8_t>(0, 0));
  CHECK(std::abs(g1.at<uint8_t>(0, 0) - (0.299 * 200 + 0.587 * 50 + 0.114 * 10)) <= 1.0);
}

TEST_CASE("ImageToMessage refuses mismatched cv::Mat types", "[lcm]") {
  image_t msg{};
  CHECK_FALSE(ImageToMessage(cv::Mat(), image_t::GRAY8, &msg).empty());
  CHECK_FALSE(ImageToMessage(cv::Mat(4, 4, CV_8UC3), image_t::GRAY8, &msg).empty());
  CHECK_FALSE(ImageToMessage(cv::Mat(4, 4, CV_8UC1), image_t::GRAY16, &msg).empty());
  CHECK_FALSE(ImageToMessage(cv::Mat(4, 4, CV_8UC1), 42, &msg).empty());
}

image_t ValidGray(int width = 8, int height = 4) {
  image_t msg{};
  msg.utime = 1;
  msg.seq = 0;
  msg.camera_id = 0;
  msg.width = width;
  msg.height = height;
  msg.row_stride = width;
  msg.pixel_format = image_t::GRAY8;
  msg.exposure_us = 0;
  msg.data.assign(static_cast<size_t>(width * height), 0);
  msg.size = width * height;
  return msg;
}

TEST_CASE("Malformed image messages are reported, never thrown", "[lcm]") {
  CHECK(ValidateImageMessage(ValidGray()).empty());
  cv::Mat out;
  auto expect_error = [&](const image_t& msg, const std::string& fragment) {
    const std::string error = ValidateImageMessage(msg);
    CAPTURE(error);
    CHECK(error.find(fragment) != std::string::npos);
    CHECK_FALSE(MessageToImage(msg, &out).empty());
    CHECK_FALSE(MessageToGray8(msg, &out).empty());
  };
  image_t m = ValidGray();
  m.width = 0;
  expect_error(m, "positive dimensions");
  m = ValidGray();
  m.height = -3;
  expect_error(m, "positive dimensions");
  m = ValidGray();
  m.pixel_format = 99;
  expect_error(m, "unknown pixel_format");
  m = ValidGray();
  m.row_stride = 7;  // < width
  expect_error(m, "row_stride");
  m = ValidGray();
  m.data.pop_back();
  m.size -= 1;  // consistent with data, but not height * row_stride
  expect_error(m, "height * row_stride");
  m = ValidGray();
  m.size += 1;  // disagrees with data
  expect_error(m, "data holds");
  m = ValidGray();
  m.pixel_format = image_t::GRAY16;  // 2 bytes per pixel: stride too small
  expect_error(m, "row_stride");
  m = ValidGray();
  m.camera_id = -1;
  expect_error(m, "camera_id");
  m = ValidGray();
  m.pixel_format = image_t::PNG;  // compressed with a row stride
  expect_error(m, "row_stride");
  m = ValidGray();
  m.width = 1 << 30;  // overflow of height * row_stride must not fool the check
  m.row_stride = 1 << 30;
  m.height = 1 << 30;
  expect_error(m, "height * row_stride");
}

TEST_CASE("DecodeImageMessage rejects corrupt buffers without allocating", "[lcm]") {
  const image_t msg = ValidGray(16, 8);
  std::vector<uint8_t> bytes = Encode(msg);
  image_t decoded{};
  REQUIRE(DecodeImageMessage(bytes.data(), static_cast<int>(bytes.size()), &decoded).empty());
  CHECK(DecodeImageMessage(nullptr, 0, &decoded).find("shorter") != std::string::npos);
  CHECK_FALSE(DecodeImageMessage(bytes.data(), 20, &decoded).empty());
  // Truncated payload.
  CHECK_FALSE(DecodeImageMessage(bytes.data(), static_cast<int>(bytes.size()) - 1, &decoded).empty());
  // A size field claiming 2 GB or a negative size.
  for (uint8_t first : {uint8_t{0x7F}, uint8_t{0xFF}}) {
    std::vector<uint8_t> bad = bytes;
    bad[kImageHeaderBytes - 4] = first;
    CHECK_FALSE(DecodeImageMessage(bad.data(), static_cast<int>(bad.size()), &decoded).empty());
  }
  // Wrong type hash.
  std::vector<uint8_t> bad = bytes;
  bad[0] ^= 0x01;
  CHECK(DecodeImageMessage(bad.data(), static_cast<int>(bad.size()), &decoded).find("hash") !=
        std::string::npos);
  // An imu_t is not an image_t.
  const imu_t imu = ImuToMessage(ImuSample{}, 0);
  std::vector<uint8_t> imu_bytes(static_cast<size_t>(imu.getEncodedSize()));
  imu.encode(imu_bytes.data(), 0, static_cast<int>(imu_bytes.size()));
  CHECK_FALSE(DecodeImageMessage(imu_bytes.data(), static_cast<int>(imu_bytes.size()), &decoded).empty());
  // A well-formed encoding of an invalid header (width 0) decodes but fails validation.
  image_t zero = ValidGray(16, 8);
  zero.width = 0;
  const std::vector<uint8_t> zero_bytes = Encode(zero);
  CHECK(DecodeImageMessage(zero_bytes.data(), static_cast<int>(zero_bytes.size()), &decoded)
            .find("positive") != std::string::npos);
}

TEST_CASE("IMU samples round-trip through imu_t", "[lcm]") {
  ImuSample sample;
  sample.t_ns = 1403715273267142912;
  sample.omega_I = Eigen::Vector3d(-0.0013962634015954637, 0.019547687622336492, 0.078);
  sample.a_I = Eigen::Vector3d(9.0793234583333327, 0.122583125, -3.6938381666666662);
  const imu_t msg = ImuToMessage(sample, 42);
  CHECK(msg.utime == NsToUtime(sample.t_ns));
  CHECK(msg.seq == 42);
  std::vector<uint8_t> bytes(static_cast<size_t>(msg.getEncodedSize()));
  REQUIRE(bytes.size() == static_cast<size_t>(kImuMessageBytes));
  msg.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  imu_t decoded;
  ImuSample back;
  REQUIRE(DecodeImuMessage(bytes.data(), static_cast<int>(bytes.size()), &decoded, &back).empty());
  CHECK(back.t_ns == UtimeToNs(NsToUtime(sample.t_ns)));  // microsecond resolution on the wire
  CHECK(std::abs(back.t_ns - sample.t_ns) <= 500);
  CHECK(back.omega_I == sample.omega_I);  // doubles are sent bit-exact
  CHECK(back.a_I == sample.a_I);

  int64_t utime = 0, seq = 0;
  REQUIRE(PeekUtimeAndSeq(bytes.data(), static_cast<int>(bytes.size()), &utime, &seq));
  CHECK(utime == msg.utime);
  CHECK(seq == 42);
  CHECK_FALSE(PeekUtimeAndSeq(bytes.data(), 23, &utime, &seq));

  // Malformed: wrong length, non-finite values.
  CHECK_FALSE(DecodeImuMessage(bytes.data(), 71, &decoded, &back).empty());
  imu_t nan_msg = msg;
  nan_msg.linear_acceleration[1] = std::numeric_limits<double>::quiet_NaN();
  CHECK_FALSE(MessageToImu(nan_msg, &back).empty());
  nan_msg = msg;
  nan_msg.angular_velocity[2] = std::numeric_limits<double>::infinity();
  nan_msg.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  CHECK_FALSE(DecodeImuMessage(bytes.data(), static_cast<int>(bytes.size()), &decoded, nullptr).empty());
}

}  // namespace
}  // namespace vilma
