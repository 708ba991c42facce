// GenICam pixel buffers -> images for vilma.image_t (docs/drivers.md, "vilma-aravis").
//
// Independent of Aravis (the GenICam PFNC codes are a public standard), so that the
// conversions are unit-tested everywhere. Formats:
//   Mono8            -> GRAY8 (copied)
//   Mono10, Mono12   -> GRAY8: the top 8 significant bits (>> 2, >> 4); or GRAY16 scaled up to
//                       the full 16-bit range (<< 6, << 4) so that every GRAY16 reader sees the
//                       same brightness (MessageToGray8 takes the top 8 bits)
//   Mono16           -> GRAY8 (>> 8) or GRAY16 (copied)
//   Bayer{RG,GB,GR,BG}8 -> GRAY8 demosaiced (OpenCV bilinear, cv::COLOR_Bayer*2GRAY: BT.601
//                       weights of the interpolated colour), or the raw mosaic as BAYER_*
//   RGB8             -> GRAY8 (cv::COLOR_RGB2GRAY, BT.601)
// Multi-byte pixels are little endian (GenICam's default for unpacked formats, as on x86/ARM).
#pragma once

#include <cstddef>
#include <cstdint>
#include <opencv2/core.hpp>
#include <string>

namespace vilma::aravis {

enum class SourceFormat { kMono8, kMono10, kMono12, kMono16, kBayerRG8, kBayerGB8, kBayerGR8,
                          kBayerBG8, kRGB8 };

// GenICam PFNC codes (what Aravis's ArvPixelFormat holds).
constexpr uint32_t kPfncMono8 = 0x01080001u;
constexpr uint32_t kPfncMono10 = 0x01100003u;
constexpr uint32_t kPfncMono12 = 0x01100005u;
constexpr uint32_t kPfncMono16 = 0x01100007u;
constexpr uint32_t kPfncBayerGR8 = 0x01080008u;
constexpr uint32_t kPfncBayerRG8 = 0x01080009u;
constexpr uint32_t kPfncBayerGB8 = 0x0108000Au;
constexpr uint32_t kPfncBayerBG8 = 0x0108000Bu;
constexpr uint32_t kPfncRGB8 = 0x02180014u;

// false for codes this driver does not convert (packed, colour other than RGB8, ...).
bool SourceFormatFromPfnc(uint32_t pfnc, SourceFormat* format);
// PFNC name ("Mono8", "BayerRG8", ...) -> format; false if unknown.
bool SourceFormatFromName(const std::string& name, SourceFormat* format);
uint32_t PfncCode(SourceFormat format);
const char* SourceFormatName(SourceFormat format);
int SourceBytesPerPixel(SourceFormat format);

struct ConvertOptions {
  bool keep_16bit = false;  // Mono10/12/16 -> GRAY16 instead of GRAY8
  bool keep_bayer = false;  // Bayer -> BAYER_* instead of GRAY8
};

// A frame as the camera delivered it: `height` rows of width * bytes-per-pixel bytes, each
// followed by `row_padding` bytes.
struct RawFrame {
  const uint8_t* data = nullptr;
  std::size_t size = 0;  // bytes in data
  int width = 0;
  int height = 0;
  int row_padding = 0;
  SourceFormat format = SourceFormat::kMono8;
};

// The image_t pixel format (image_t::GRAY8, ...) that ConvertFrame produces.
int32_t OutputPixelFormat(SourceFormat format, const ConvertOptions& options);

// Converts `frame` into `image` (CV_8UC1 or CV_16UC1, owning or reusing its memory) whose
// image_t format is OutputPixelFormat(). Returns "" or what is wrong (size too small,
// dimensions not positive, Bayer smaller than 2x2).
std::string ConvertFrame(const RawFrame& frame, const ConvertOptions& options, cv::Mat* image);

}  // namespace vilma::aravis
