// Conversion of a V4L2 capture buffer into the grayscale image vilma publishes (image_t GRAY8,
// or GRAY16 when asked to keep 16 bits).
//
//  - GREY: 8-bit gray, rows `bytesperline` apart (which may exceed the width: padding).
//  - Y16: 16-bit gray, little endian (videodev2.h: "the least significant byte is stored at
//    lower memory addresses"); to 8 bits by dropping the low byte (value >> 8).
//  - YUYV (4:2:2, Y0 U Y1 V): the Y samples are the gray image; chroma is ignored.
//  - MJPG: decoded with OpenCV (libjpeg-turbo) straight to grayscale. UVC cameras omit the
//    Huffman tables (DHT) of every frame; libjpeg-turbo falls back to the standard tables of
//    JPEG Annex K.3, which is what those cameras use (tested with such frames). A frame that
//    does not decode, or decodes to another size than negotiated, is an error (counted as
//    malformed, never published).
#pragma once

#include <cstddef>
#include <cstdint>
#include <opencv2/core.hpp>
#include <string>

namespace vilma::v4l2 {

struct FrameLayout {
  uint32_t fourcc = 0;     // V4L2_PIX_FMT_*
  int width = 0;           // [px]
  int height = 0;          // [px]
  int bytes_per_line = 0;  // [bytes]; 0 for compressed formats
};

// Whether the driver can convert `fourcc` (GREY, Y16, YUYV, MJPG).
bool IsSupportedFourcc(uint32_t fourcc);
// True for 16-bit formats (Y16), whose depth keep_16_bit preserves.
bool IsSixteenBitFourcc(uint32_t fourcc);

// Converts `bytes_used` bytes at `data` into `*image` (reusing its memory when the size and
// type match): CV_8UC1, or CV_16UC1 for Y16 when `keep_16_bit`. Returns "" or what is wrong
// (too few bytes for the layout, an undecodable JPEG, a size mismatch, an unknown format).
std::string ConvertToGray(const uint8_t* data, std::size_t bytes_used, const FrameLayout& layout,
                          bool keep_16_bit, cv::Mat* image);

}  // namespace vilma::v4l2
