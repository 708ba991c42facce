#include "vilma/drivers/aravis/pixel_convert.h"

#include <opencv2/imgproc.hpp>
#include <vilma/image_t.hpp>

namespace vilma::aravis {
namespace {

struct FormatInfo {
  SourceFormat format;
  uint32_t pfnc;
  const char* name;
  int bytes_per_pixel;
};

constexpr FormatInfo kFormats[] = {
    {SourceFormat::kMono8, kPfncMono8, "Mono8", 1},
    {SourceFormat::kMono10, kPfncMono10, "Mono10", 2},
    {SourceFormat::kMono12, kPfncMono12, "Mono12", 2},
    {SourceFormat::kMono16, kPfncMono16, "Mono16", 2},
    {SourceFormat::kBayerRG8, kPfncBayerRG8, "BayerRG8", 1},
    {SourceFormat::kBayerGB8, kPfncBayerGB8, "BayerGB8", 1},
    {SourceFormat::kBayerGR8, kPfncBayerGR8, "BayerGR8", 1},
    {SourceFormat::kBayerBG8, kPfncBayerBG8, "BayerBG8", 1},
    {SourceFormat::kRGB8, kPfncRGB8, "RGB8", 3},
};

const FormatInfo& Info(SourceFormat format) {
  for (const FormatInfo& info : kFormats) {
    if (info.format == format) return info;
  }
  return kFormats[0];  // unreachable: every enumerator is in the table
}

bool IsBayer(SourceFormat f) {
  return f == SourceFormat::kBayerRG8 || f == SourceFormat::kBayerGB8 ||
         f == SourceFormat::kBayerGR8 || f == SourceFormat::kBayerBG8;
}

// Bits that a 16-bit container's significant bits must move by to fill 16 bits.
int HeadroomBits(SourceFormat f) {
  switch (f) {
    case SourceFormat::kMono10: return 6;
    case SourceFormat::kMono12: return 4;
    default: return 0;
  }
}

// OpenCV names a Bayer pattern after the 2x2 block that starts at the second row and second
// column, GenICam after the one at the top-left pixel: PFNC RG (R at (0,0)) is OpenCV's BG.
int BayerToGrayCode(SourceFormat f) {
  switch (f) {
    case SourceFormat::kBayerRG8: return cv::COLOR_BayerBG2GRAY;
    case SourceFormat::kBayerGB8: return cv::COLOR_BayerGR2GRAY;
    case SourceFormat::kBayerGR8: return cv::COLOR_BayerGB2GRAY;
    default: return cv::COLOR_BayerRG2GRAY;  // kBayerBG8
  }
}

}  // namespace

bool SourceFormatFromPfnc(uint32_t pfnc, SourceFormat* format) {
  for (const FormatInfo& info : kFormats) {
    if (info.pfnc == pfnc) {
      *format = info.format;
      return true;
    }
  }
  return false;
}

bool SourceFormatFromName(const std::string& name, SourceFormat* format) {
  for (const FormatInfo& info : kFormats) {
    if (name == info.name) {
      *format = info.format;
      return true;
    }
  }
  return false;
}

uint32_t PfncCode(SourceFormat format) { return Info(format).pfnc; }
const char* SourceFormatName(SourceFormat format) { return Info(format).name; }
int SourceBytesPerPixel(SourceFormat format) { return Info(format).bytes_per_pixel; }

int32_t OutputPixelFormat(SourceFormat format, const ConvertOptions& options) {
  switch (format) {
    case SourceFormat::kMono10:
    case SourceFormat::kMono12:
    case SourceFormat::kMono16:
      return options.keep_16bit ? int32_t{image_t::GRAY16} : int32_t{image_t::GRAY8};
    case SourceFormat::kBayerRG8: return options.keep_bayer ? int32_t{image_t::BAYER_RGGB8} : int32_t{image_t::GRAY8};
    case SourceFormat::kBayerGB8: return options.keep_bayer ? int32_t{image_t::BAYER_GBRG8} : int32_t{image_t::GRAY8};
    case SourceFormat::kBayerGR8: return options.keep_bayer ? int32_t{image_t::BAYER_GRBG8} : int32_t{image_t::GRAY8};
    case SourceFormat::kBayerBG8: return options.keep_bayer ? int32_t{image_t::BAYER_BGGR8} : int32_t{image_t::GRAY8};
    default: return image_t::GRAY8;
  }
}

std::string ConvertFrame(const RawFrame& frame, const ConvertOptions& options, cv::Mat* image) {
  if (frame.width <= 0 || frame.height <= 0) return "frame has no pixels (width or height <= 0)";
  if (frame.row_padding < 0) return "frame row padding is negative";
  const int bpp = SourceBytesPerPixel(frame.format);
  const std::size_t row_bytes = static_cast<std::size_t>(frame.width) * bpp;
  const std::size_t stride = row_bytes + static_cast<std::size_t>(frame.row_padding);
  // The last row's padding may be absent.
  const std::size_t needed = stride * static_cast<std::size_t>(frame.height - 1) + row_bytes;
  if (frame.data == nullptr || frame.size < needed) {
    return "frame of " + std::to_string(frame.size) + " bytes is smaller than " +
           std::to_string(frame.width) + "x" + std::to_string(frame.height) + " " +
           SourceFormatName(frame.format) + " needs (" + std::to_string(needed) + " bytes)";
  }
  if (IsBayer(frame.format) && (frame.width < 2 || frame.height < 2)) {
    return "Bayer frame smaller than 2x2";
  }
  auto* data = const_cast<uint8_t*>(frame.data);  // wrapped read-only below
  switch (frame.format) {
    case SourceFormat::kMono8: {
      const cv::Mat src(frame.height, frame.width, CV_8UC1, data, stride);
      src.copyTo(*image);
      return "";
    }
    case SourceFormat::kMono10:
    case SourceFormat::kMono12:
    case SourceFormat::kMono16: {
      const cv::Mat src(frame.height, frame.width, CV_16UC1, data, stride);
      const int headroom = HeadroomBits(frame.format);
      if (options.keep_16bit) {
        // Exact integer shift (convertTo would round a scale of 2^k the same, but say it).
        image->create(frame.height, frame.width, CV_16UC1);
        for (int y = 0; y < frame.height; ++y) {
          const uint16_t* in = src.ptr<uint16_t>(y);
          uint16_t* out = image->ptr<uint16_t>(y);
          for (int x = 0; x < frame.width; ++x) {
            out[x] = static_cast<uint16_t>(in[x] << headroom);
          }
        }
      } else {
        const int shift = 8 - headroom;  // the top 8 of the significant bits
        image->create(frame.height, frame.width, CV_8UC1);
        for (int y = 0; y < frame.height; ++y) {
          const uint16_t* in = src.ptr<uint16_t>(y);
          uint8_t* out = image->ptr<uint8_t>(y);
          for (int x = 0; x < frame.width; ++x) {
            // Values above the format's range (stray high bits) saturate instead of wrapping.
            const unsigned v = static_cast<unsigned>(in[x]) >> shift;
            out[x] = static_cast<uint8_t>(v > 255u ? 255u : v);
          }
        }
      }
      return "";
    }
    case SourceFormat::kBayerRG8:
    case SourceFormat::kBayerGB8:
    case SourceFormat::kBayerGR8:
    case SourceFormat::kBayerBG8: {
      const cv::Mat src(frame.height, frame.width, CV_8UC1, data, stride);
      if (options.keep_bayer) {
        src.copyTo(*image);
      } else {
        cv::cvtColor(src, *image, BayerToGrayCode(frame.format));
      }
      return "";
    }
    case SourceFormat::kRGB8: {
      const cv::Mat src(frame.height, frame.width, CV_8UC3, data, stride);
      cv::cvtColor(src, *image, cv::COLOR_RGB2GRAY);
      return "";
    }
  }
  return "unknown source format";
}

}  // namespace vilma::aravis
