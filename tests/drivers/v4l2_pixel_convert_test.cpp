// vilma-v4l2's conversions of capture buffers to gray (drivers/v4l2/src/pixel_convert.cpp).
#include <catch2/catch.hpp>

#include "test_skip.h"

#ifdef VILMA_HAVE_DRIVER_V4L2
#include <linux/videodev2.h>

#include <opencv2/imgcodecs.hpp>
#include <vector>

#include "vilma/drivers/v4l2/fake_v4l2_io.h"
#include "vilma/drivers/v4l2/pixel_convert.h"
#include "vilma/drivers/v4l2/v4l2_io.h"

namespace vilma::v4l2 {
namespace {

// A w x h picture with distinct values, and the buffer of `fourcc` holding it with
// `stride` bytes per row (padding filled with 0xEE, which must never show up).
std::vector<uint8_t> MakeBuffer(uint32_t fourcc, const cv::Mat& gray16, int stride) {
  std::vector<uint8_t> buffer(static_cast<std::size_t>(stride * gray16.rows), 0xEE);
  for (int y = 0; y < gray16.rows; ++y) {
    uint8_t* line = buffer.data() + static_cast<std::size_t>(y * stride);
    for (int x = 0; x < gray16.cols; ++x) {
      const uint16_t v = gray16.at<uint16_t>(y, x);
      if (fourcc == V4L2_PIX_FMT_GREY) {
        line[x] = static_cast<uint8_t>(v >> 8);
      } else if (fourcc == V4L2_PIX_FMT_Y16) {
        line[2 * x] = static_cast<uint8_t>(v & 0xff);  // little endian
        line[2 * x + 1] = static_cast<uint8_t>(v >> 8);
      } else if (fourcc == V4L2_PIX_FMT_YUYV) {
        line[2 * x] = static_cast<uint8_t>(v >> 8);
        line[2 * x + 1] = static_cast<uint8_t>(x % 2 == 0 ? 0x11 : 0xF0);  // U, V
      }
    }
  }
  return buffer;
}

cv::Mat Picture16(int width, int height) {
  cv::Mat m(height, width, CV_16UC1);
  for (int y = 0; y < height; ++y) {
    for (int x = 0; x < width; ++x)
      m.at<uint16_t>(y, x) = static_cast<uint16_t>(x * 997 + y * 3001);
  }
  return m;
}

cv::Mat HighByte(const cv::Mat& gray16) {
  cv::Mat out(gray16.size(), CV_8UC1);
  for (int y = 0; y < gray16.rows; ++y) {
    for (int x = 0; x < gray16.cols; ++x) {
      out.at<uint8_t>(y, x) = static_cast<uint8_t>(gray16.at<uint16_t>(y, x) >> 8);
    }
  }
  return out;
}

TEST_CASE("v4l2 GREY, Y16 and YUYV buffers with row padding convert exactly", "[v4l2]") {
  const cv::Mat picture = Picture16(37, 11);  // odd width: YUYV's last pair half used
  const cv::Mat expected8 = HighByte(picture);
  struct Case {
    uint32_t fourcc;
    int stride;
  };
  for (const Case& c :
       {Case{V4L2_PIX_FMT_GREY, 37}, Case{V4L2_PIX_FMT_GREY, 64}, Case{V4L2_PIX_FMT_Y16, 74},
        Case{V4L2_PIX_FMT_Y16, 96}, Case{V4L2_PIX_FMT_YUYV, 74}, Case{V4L2_PIX_FMT_YUYV, 80}}) {
    CAPTURE(FourccName(c.fourcc), c.stride);
    const std::vector<uint8_t> buffer = MakeBuffer(c.fourcc, picture, c.stride);
    const FrameLayout layout{c.fourcc, 37, 11, c.stride};
    cv::Mat gray;
    REQUIRE(ConvertToGray(buffer.data(), buffer.size(), layout, false, &gray).empty());
    REQUIRE(gray.type() == CV_8UC1);
    CHECK(cv::norm(gray, expected8, cv::NORM_INF) == 0.0);
  }
}

TEST_CASE("v4l2 Y16 keeps all 16 bits when asked", "[v4l2]") {
  const cv::Mat picture = Picture16(20, 7);
  const std::vector<uint8_t> buffer = MakeBuffer(V4L2_PIX_FMT_Y16, picture, 48);
  cv::Mat gray;
  REQUIRE(ConvertToGray(buffer.data(), buffer.size(), {V4L2_PIX_FMT_Y16, 20, 7, 48}, true, &gray)
              .empty());
  REQUIRE(gray.type() == CV_16UC1);
  CHECK(cv::norm(gray, picture, cv::NORM_INF) == 0.0);
  // keep_16_bit does not change 8-bit formats.
  const std::vector<uint8_t> grey = MakeBuffer(V4L2_PIX_FMT_GREY, picture, 20);
  REQUIRE(
      ConvertToGray(grey.data(), grey.size(), {V4L2_PIX_FMT_GREY, 20, 7, 20}, true, &gray).empty());
  CHECK(gray.type() == CV_8UC1);
}

TEST_CASE("v4l2 the last row needs no padding, but a short buffer is an error", "[v4l2]") {
  const cv::Mat picture = Picture16(16, 4);
  std::vector<uint8_t> buffer = MakeBuffer(V4L2_PIX_FMT_YUYV, picture, 40);
  cv::Mat gray;
  const FrameLayout layout{V4L2_PIX_FMT_YUYV, 16, 4, 40};
  const std::size_t needed = 40 * 3 + 32;
  CHECK(ConvertToGray(buffer.data(), needed, layout, false, &gray).empty());
  const std::string error = ConvertToGray(buffer.data(), needed - 1, layout, false, &gray);
  CHECK(error.find("needs " + std::to_string(needed)) != std::string::npos);
  // A stride below the row's bytes is refused, not read out of bounds.
  CHECK(ConvertToGray(buffer.data(), buffer.size(), {V4L2_PIX_FMT_YUYV, 16, 4, 31}, false, &gray)
            .find("bytesperline") != std::string::npos);
  CHECK(ConvertToGray(buffer.data(), buffer.size(), {V4L2_PIX_FMT_RGB24, 16, 4, 48}, false, &gray)
            .find("not supported") != std::string::npos);
}

TEST_CASE("v4l2 MJPG frames decode to gray, also without Huffman tables as UVC cameras send them",
          "[v4l2]") {
  const cv::Mat pattern = FakeFramePattern(7, 64, 48);
  std::vector<uint8_t> jpeg;
  REQUIRE(cv::imencode(".jpg", pattern, jpeg, {cv::IMWRITE_JPEG_QUALITY, 95}));
  cv::Mat gray;
  const FrameLayout layout{V4L2_PIX_FMT_MJPEG, 64, 48, 0};
  REQUIRE(ConvertToGray(jpeg.data(), jpeg.size(), layout, false, &gray).empty());
  CHECK(gray.type() == CV_8UC1);
  CHECK(cv::norm(gray, pattern, cv::NORM_INF) <= 8.0);

  // The same frame as the fake camera (and UVC cameras) send it: no DHT segment.
  std::vector<uint8_t> stripped;
  for (std::size_t i = 2; i + 4 <= jpeg.size();) {
    const int marker = jpeg[i + 1];
    const std::size_t length = (std::size_t{jpeg[i + 2]} << 8) | jpeg[i + 3];
    if (marker == 0xDA) {
      stripped.insert(stripped.end(), jpeg.begin() + static_cast<long>(i), jpeg.end());
      break;
    }
    if (marker != 0xC4) {
      stripped.insert(stripped.end(), jpeg.begin() + static_cast<long>(i),
                      jpeg.begin() + static_cast<long>(i + 2 + length));
    }
    i += 2 + length;
  }
  stripped.insert(stripped.begin(), {0xFF, 0xD8});
  REQUIRE(stripped.size() < jpeg.size());
  cv::Mat from_stripped;
  REQUIRE(ConvertToGray(stripped.data(), stripped.size(), layout, false, &from_stripped).empty());
  CHECK(cv::norm(from_stripped, gray, cv::NORM_INF) == 0.0);

  // Corrupt and mis-sized frames are errors.
  std::vector<uint8_t> truncated(jpeg.begin(), jpeg.begin() + 20);
  CHECK(ConvertToGray(truncated.data(), truncated.size(), layout, false, &gray)
            .find("does not decode") != std::string::npos);
  std::vector<uint8_t> garbage(500, 0x5A);
  CHECK_FALSE(ConvertToGray(garbage.data(), garbage.size(), layout, false, &gray).empty());
  CHECK(ConvertToGray(jpeg.data(), jpeg.size(), {V4L2_PIX_FMT_MJPEG, 640, 480, 0}, false, &gray)
            .find("decodes to 64x48, expected 640x480") != std::string::npos);
  CHECK(ConvertToGray(jpeg.data(), 0, layout, false, &gray).find("empty") != std::string::npos);
}

TEST_CASE("v4l2 fourcc names", "[v4l2]") {
  CHECK(FourccFromName("GREY") == V4L2_PIX_FMT_GREY);
  CHECK(FourccFromName("Y16") == V4L2_PIX_FMT_Y16);
  CHECK(FourccFromName("MJPG") == V4L2_PIX_FMT_MJPEG);
  CHECK(FourccName(V4L2_PIX_FMT_Y16) == "Y16");
  CHECK(FourccName(V4L2_PIX_FMT_YUYV) == "YUYV");
  CHECK(FourccFromName("grey") == 0);
  CHECK(FourccFromName("TOOLONG") == 0);
  CHECK(IsSupportedFourcc(V4L2_PIX_FMT_MJPEG));
  CHECK_FALSE(IsSupportedFourcc(V4L2_PIX_FMT_RGB24));
  // Name fields of V4L2 structs: up to the NUL, or the whole field when it is full.
  const uint8_t full[4] = {'u', 'v', 'c', 'x'};
  const uint8_t padded[8] = {'u', 'v', 'c', 0, 'j', 'u', 'n', 'k'};
  CHECK(FieldText(full) == "uvcx");
  CHECK(FieldText(padded) == "uvc");
}

}  // namespace
}  // namespace vilma::v4l2

#else
TEST_CASE("vilma-v4l2 pixel conversions", "[v4l2]") {
  VILMA_SKIP("vilma-v4l2 is not built here (<linux/videodev2.h> missing)");
}
#endif
