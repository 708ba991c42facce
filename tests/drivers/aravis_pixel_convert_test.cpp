// GenICam pixel buffers -> image_t images (drivers/aravis/src/pixel_convert.cpp).
#include <catch2/catch.hpp>

#include "test_skip.h"

#ifdef VILMA_HAVE_DRIVER_ARAVIS

#include <cstring>
#include <opencv2/imgproc.hpp>
#include <vector>
#include <vilma/image_t.hpp>

#include "vilma/drivers/aravis/pixel_convert.h"
#include "vilma/drivers/lcm_convert.h"

namespace vilma::aravis {
namespace {

RawFrame Frame(const std::vector<uint8_t>& bytes, int width, int height, SourceFormat format,
               int row_padding = 0) {
  RawFrame f;
  f.data = bytes.data();
  f.size = bytes.size();
  f.width = width;
  f.height = height;
  f.row_padding = row_padding;
  f.format = format;
  return f;
}

TEST_CASE("PFNC codes and names of the supported formats", "[aravis]") {
  SourceFormat f{};
  REQUIRE(SourceFormatFromName("BayerRG8", &f));
  CHECK(f == SourceFormat::kBayerRG8);
  CHECK(PfncCode(f) == 0x01080009u);
  REQUIRE(SourceFormatFromPfnc(0x01100007u, &f));
  CHECK(f == SourceFormat::kMono16);
  CHECK(std::string(SourceFormatName(f)) == "Mono16");
  CHECK(SourceBytesPerPixel(SourceFormat::kMono12) == 2);
  CHECK(SourceBytesPerPixel(SourceFormat::kRGB8) == 3);
  CHECK_FALSE(SourceFormatFromPfnc(0x010c0006u, &f));  // Mono12Packed: not supported
  CHECK_FALSE(SourceFormatFromName("Mono12Packed", &f));
}

TEST_CASE("Mono8 is copied, row padding skipped", "[aravis]") {
  const int w = 5, h = 3, pad = 3;
  std::vector<uint8_t> bytes((w + pad) * h - pad);  // the last row's padding may be absent
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) bytes[y * (w + pad) + x] = static_cast<uint8_t>(10 * y + x);
  }
  cv::Mat image;
  REQUIRE(ConvertFrame(Frame(bytes, w, h, SourceFormat::kMono8, pad), {}, &image).empty());
  REQUIRE(image.type() == CV_8UC1);
  REQUIRE(image.cols == w);
  REQUIRE(image.rows == h);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) CHECK(image.at<uint8_t>(y, x) == 10 * y + x);
  }
  CHECK(OutputPixelFormat(SourceFormat::kMono8, {}) == image_t::GRAY8);
}

// Little-endian 16-bit pixels.
std::vector<uint8_t> Pixels16(const std::vector<uint16_t>& values) {
  std::vector<uint8_t> bytes(values.size() * 2);
  for (size_t i = 0; i < values.size(); ++i) {
    bytes[2 * i] = static_cast<uint8_t>(values[i] & 0xFF);
    bytes[2 * i + 1] = static_cast<uint8_t>(values[i] >> 8);
  }
  return bytes;
}

TEST_CASE("Mono10/12/16 to GRAY8 (top bits) and GRAY16 (full range)", "[aravis]") {
  struct Case {
    SourceFormat format;
    std::vector<uint16_t> in;
    std::vector<uint8_t> gray8;
    std::vector<uint16_t> gray16;
  };
  const std::vector<Case> cases = {
      {SourceFormat::kMono16, {0, 255, 256, 0x8000, 0xFFFF, 0x1234}, {0, 0, 1, 128, 255, 0x12},
       {0, 255, 256, 0x8000, 0xFFFF, 0x1234}},
      {SourceFormat::kMono12, {0, 15, 16, 0x800, 0xFFF, 0x123}, {0, 0, 1, 128, 255, 0x12},
       {0, 240, 256, 0x8000, 0xFFF0, 0x1230}},
      // A stray bit above the format's range saturates GRAY8 instead of wrapping.
      {SourceFormat::kMono10, {0, 3, 4, 0x200, 0x3FF, 0x7FF}, {0, 0, 1, 128, 255, 255},
       {0, 192, 256, 0x8000, 0xFFC0, 0xFFC0}},
  };
  for (const Case& c : cases) {
    INFO(SourceFormatName(c.format));
    const std::vector<uint8_t> bytes = Pixels16(c.in);
    cv::Mat image;
    ConvertOptions options;
    REQUIRE(ConvertFrame(Frame(bytes, 3, 2, c.format), options, &image).empty());
    REQUIRE(image.type() == CV_8UC1);
    CHECK(OutputPixelFormat(c.format, options) == image_t::GRAY8);
    for (int i = 0; i < 6; ++i) CHECK(int(image.at<uint8_t>(i / 3, i % 3)) == int(c.gray8[i]));
    options.keep_16bit = true;
    REQUIRE(ConvertFrame(Frame(bytes, 3, 2, c.format), options, &image).empty());
    REQUIRE(image.type() == CV_16UC1);
    CHECK(OutputPixelFormat(c.format, options) == image_t::GRAY16);
    for (int i = 0; i < 6; ++i) CHECK(int(image.at<uint16_t>(i / 3, i % 3)) == int(c.gray16[i]));
  }
}

// A mosaic of one colour (r, g, b) in the GenICam pattern `format` (named after the 2x2 block
// at the top-left pixel: BayerRG8 = R G / G B).
std::vector<uint8_t> Mosaic(SourceFormat format, int w, int h, uint8_t r, uint8_t g, uint8_t b) {
  // Colour at (even row, even col), (even, odd), (odd, even), (odd, odd).
  uint8_t c[4];
  switch (format) {
    case SourceFormat::kBayerRG8: c[0] = r, c[1] = g, c[2] = g, c[3] = b; break;
    case SourceFormat::kBayerGB8: c[0] = g, c[1] = b, c[2] = r, c[3] = g; break;
    case SourceFormat::kBayerGR8: c[0] = g, c[1] = r, c[2] = b, c[3] = g; break;
    default: c[0] = b, c[1] = g, c[2] = g, c[3] = r; break;  // BayerBG8
  }
  std::vector<uint8_t> bytes(static_cast<size_t>(w) * h);
  for (int y = 0; y < h; ++y) {
    for (int x = 0; x < w; ++x) bytes[y * w + x] = c[(y % 2) * 2 + (x % 2)];
  }
  return bytes;
}

TEST_CASE("Bayer patterns demosaic to the gray of their colour", "[aravis]") {
  const SourceFormat format = GENERATE(SourceFormat::kBayerRG8, SourceFormat::kBayerGB8,
                                       SourceFormat::kBayerGR8, SourceFormat::kBayerBG8);
  INFO(SourceFormatName(format));
  const int w = 16, h = 12;
  // Distinct R, G, B: a pattern read with the wrong phase gives another gray (swapped R and
  // B: 91 instead of 122; G taken for R or B: far off too).
  const uint8_t r = 200, g = 100, b = 30;
  const std::vector<uint8_t> bytes = Mosaic(format, w, h, r, g, b);
  cv::Mat gray;
  REQUIRE(ConvertFrame(Frame(bytes, w, h, format), {}, &gray).empty());
  REQUIRE(gray.type() == CV_8UC1);
  CHECK(OutputPixelFormat(format, {}) == image_t::GRAY8);
  const double expected = 0.299 * r + 0.587 * g + 0.114 * b;  // ITU-R BT.601
  // Interior pixels (the border of a bilinear demosaic extrapolates).
  for (int y = 2; y < h - 2; ++y) {
    for (int x = 2; x < w - 2; ++x) {
      INFO("pixel " << x << "," << y);
      CHECK(std::abs(gray.at<uint8_t>(y, x) - expected) <= 1.0);
    }
  }

  // keep_bayer: the raw mosaic as the matching image_t BAYER_* format, which the estimator's
  // decoder (lcm_convert MessageToGray8) turns into the same gray.
  ConvertOptions keep;
  keep.keep_bayer = true;
  cv::Mat raw;
  REQUIRE(ConvertFrame(Frame(bytes, w, h, format), keep, &raw).empty());
  REQUIRE(raw.type() == CV_8UC1);
  CHECK(std::memcmp(raw.data, bytes.data(), bytes.size()) == 0);
  image_t msg;
  REQUIRE(MakeImageMessage(raw, OutputPixelFormat(format, keep), 0, 0, 0, &msg).empty());
  cv::Mat decoded;
  REQUIRE(MessageToGray8(msg, &decoded).empty());
  CHECK(std::abs(decoded.at<uint8_t>(h / 2, w / 2) - expected) <= 1.0);
}

TEST_CASE("RGB8 to gray", "[aravis]") {
  std::vector<uint8_t> bytes = {200, 100, 30, 0, 0, 0, 255, 255, 255, 0, 255, 0};
  cv::Mat gray;
  REQUIRE(ConvertFrame(Frame(bytes, 2, 2, SourceFormat::kRGB8), {}, &gray).empty());
  CHECK(std::abs(gray.at<uint8_t>(0, 0) - 121.9) <= 1.0);
  CHECK(gray.at<uint8_t>(0, 1) == 0);
  CHECK(gray.at<uint8_t>(1, 0) == 255);
  CHECK(std::abs(gray.at<uint8_t>(1, 1) - 149.7) <= 1.0);
}

TEST_CASE("Bad frames are refused with a reason", "[aravis]") {
  std::vector<uint8_t> bytes(99);
  cv::Mat image;
  std::string error = ConvertFrame(Frame(bytes, 10, 10, SourceFormat::kMono8), {}, &image);
  CHECK(error.find("smaller than 10x10 Mono8") != std::string::npos);
  error = ConvertFrame(Frame(bytes, 0, 10, SourceFormat::kMono8), {}, &image);
  CHECK_FALSE(error.empty());
  error = ConvertFrame(Frame(bytes, 5, 10, SourceFormat::kMono16), {}, &image);
  CHECK(error.find("needs (100 bytes)") != std::string::npos);
  error = ConvertFrame(Frame(bytes, 1, 1, SourceFormat::kBayerRG8), {}, &image);
  CHECK(error == "Bayer frame smaller than 2x2");
  RawFrame null_frame;
  null_frame.width = null_frame.height = 1;
  CHECK_FALSE(ConvertFrame(null_frame, {}, &image).empty());
}

}  // namespace
}  // namespace vilma::aravis

#else

TEST_CASE("Aravis pixel conversions", "[aravis]") {
  VILMA_SKIP("vilma-aravis is not built here (pkg-config finds no aravis-0.8: libaravis-dev)");
}

#endif
