#include "vilma/drivers/v4l2/pixel_convert.h"

#include <linux/videodev2.h>

#include <cstring>
#include <opencv2/imgcodecs.hpp>

#include "vilma/drivers/v4l2/v4l2_io.h"

namespace vilma::v4l2 {
namespace {

int MinBytesPerLine(uint32_t fourcc, int width) {
  switch (fourcc) {
    case V4L2_PIX_FMT_GREY:
      return width;
    case V4L2_PIX_FMT_Y16:
    case V4L2_PIX_FMT_YUYV:
      return 2 * width;
    default:
      return 0;
  }
}

std::string SizeText(int width, int height) {
  return std::to_string(width) + "x" + std::to_string(height);
}

}  // namespace

bool IsSupportedFourcc(uint32_t fourcc) {
  return fourcc == V4L2_PIX_FMT_GREY || fourcc == V4L2_PIX_FMT_Y16 || fourcc == V4L2_PIX_FMT_YUYV ||
         fourcc == V4L2_PIX_FMT_MJPEG;
}

bool IsSixteenBitFourcc(uint32_t fourcc) { return fourcc == V4L2_PIX_FMT_Y16; }

std::string ConvertToGray(const uint8_t* data, std::size_t bytes_used, const FrameLayout& layout,
                          bool keep_16_bit, cv::Mat* image) {
  if (!IsSupportedFourcc(layout.fourcc)) {
    return "pixel format " + FourccName(layout.fourcc) + " is not supported";
  }
  if (layout.width <= 0 || layout.height <= 0) return "empty frame layout";
  if (layout.fourcc == V4L2_PIX_FMT_MJPEG) {
    if (bytes_used == 0) return "empty MJPG frame";
    // cv::imdecode takes a Mat header over the buffer (no copy).
    const cv::Mat encoded(1, static_cast<int>(bytes_used), CV_8UC1, const_cast<uint8_t*>(data));
    cv::Mat decoded;
    try {
      decoded = cv::imdecode(encoded, cv::IMREAD_GRAYSCALE);
    } catch (const cv::Exception&) {
      decoded.release();
    }
    if (decoded.empty())
      return "MJPG frame of " + std::to_string(bytes_used) + " bytes does not decode";
    if (decoded.cols != layout.width || decoded.rows != layout.height) {
      return "MJPG frame decodes to " + SizeText(decoded.cols, decoded.rows) + ", expected " +
             SizeText(layout.width, layout.height);
    }
    *image = decoded;
    return "";
  }

  const int min_stride = MinBytesPerLine(layout.fourcc, layout.width);
  const int stride = layout.bytes_per_line > 0 ? layout.bytes_per_line : min_stride;
  if (stride < min_stride) {
    return "bytesperline " + std::to_string(stride) + " < " + std::to_string(min_stride) + " for " +
           FourccName(layout.fourcc) + " " + SizeText(layout.width, layout.height);
  }
  // The last row needs only its pixels, not its padding.
  const std::size_t needed =
      static_cast<std::size_t>(stride) * static_cast<std::size_t>(layout.height - 1) +
      static_cast<std::size_t>(min_stride);
  if (bytes_used < needed) {
    return "frame has " + std::to_string(bytes_used) + " bytes, " + FourccName(layout.fourcc) +
           " " + SizeText(layout.width, layout.height) + " needs " + std::to_string(needed);
  }

  const bool sixteen = layout.fourcc == V4L2_PIX_FMT_Y16 && keep_16_bit;
  image->create(layout.height, layout.width, sixteen ? CV_16UC1 : CV_8UC1);
  for (int y = 0; y < layout.height; ++y) {
    const uint8_t* in = data + static_cast<std::size_t>(y) * static_cast<std::size_t>(stride);
    switch (layout.fourcc) {
      case V4L2_PIX_FMT_GREY:
        std::memcpy(image->ptr<uint8_t>(y), in, static_cast<std::size_t>(layout.width));
        break;
      case V4L2_PIX_FMT_Y16:
        if (sixteen) {
          uint16_t* out = image->ptr<uint16_t>(y);
          for (int x = 0; x < layout.width; ++x) {
            out[x] = static_cast<uint16_t>(in[2 * x] | (in[2 * x + 1] << 8));
          }
        } else {
          uint8_t* out = image->ptr<uint8_t>(y);
          for (int x = 0; x < layout.width; ++x) out[x] = in[2 * x + 1];  // high byte
        }
        break;
      case V4L2_PIX_FMT_YUYV: {
        uint8_t* out = image->ptr<uint8_t>(y);
        for (int x = 0; x < layout.width; ++x) out[x] = in[2 * x];  // Y0 U Y1 V
        break;
      }
      default:
        break;
    }
  }
  return "";
}

}  // namespace vilma::v4l2
