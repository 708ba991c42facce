#include "vilma/drivers/lcm_convert.h"

#include <cmath>
#include <cstring>
#include <exception>
#include <limits>
#include <string>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <vector>

#include "vilma/core/time.h"

namespace vilma {

namespace {

// LCM encodes integers big endian.
int64_t ReadBigEndian(const uint8_t* p, int bytes) {
  uint64_t v = 0;
  for (int i = 0; i < bytes; ++i) v = (v << 8) | p[i];
  if (bytes == 4) return static_cast<int32_t>(static_cast<uint32_t>(v));
  return static_cast<int64_t>(v);
}

int CvTypeOf(int32_t pixel_format) {
  switch (pixel_format) {
    case image_t::GRAY8:
    case image_t::BAYER_RGGB8:
    case image_t::BAYER_BGGR8:
    case image_t::BAYER_GBRG8:
    case image_t::BAYER_GRBG8:
      return CV_8UC1;
    case image_t::GRAY16:
      return CV_16UC1;
    case image_t::RGB8:
    case image_t::BGR8:
      return CV_8UC3;
    default:
      return -1;
  }
}

bool IsCompressed(int32_t pixel_format) {
  return pixel_format == image_t::JPEG || pixel_format == image_t::PNG;
}

// OpenCV names Bayer patterns after the 2x2 block that starts at the second row and second
// column, while image_t (like ROS and the sensor data sheets) names the block at the top-left
// pixel; hence RGGB <-> BayerBG etc. The test demosaics synthetic mosaics of each pattern.
int DemosaicCode(int32_t pixel_format) {
  switch (pixel_format) {
    case image_t::BAYER_RGGB8: return cv::COLOR_BayerBG2BGR;
    case image_t::BAYER_BGGR8: return cv::COLOR_BayerRG2BGR;
    case image_t::BAYER_GBRG8: return cv::COLOR_BayerGR2BGR;
    case image_t::BAYER_GRBG8: return cv::COLOR_BayerGB2BGR;
    default: return -1;
  }
}

}  // namespace

std::string PixelFormatName(int32_t pixel_format) {
  switch (pixel_format) {
    case image_t::GRAY8: return "GRAY8";
    case image_t::GRAY16: return "GRAY16";
    case image_t::RGB8: return "RGB8";
    case image_t::BGR8: return "BGR8";
    case image_t::BAYER_RGGB8: return "BAYER_RGGB8";
    case image_t::BAYER_BGGR8: return "BAYER_BGGR8";
    case image_t::BAYER_GBRG8: return "BAYER_GBRG8";
    case image_t::BAYER_GRBG8: return "BAYER_GRBG8";
    case image_t::JPEG: return "JPEG";
    case image_t::PNG: return "PNG";
    default: return "UNKNOWN(" + std::to_string(pixel_format) + ")";
  }
}

int BytesPerPixel(int32_t pixel_format) {
  const int type = CvTypeOf(pixel_format);
  if (type < 0) return 0;
  return static_cast<int>(CV_ELEM_SIZE(type));
}

std::string ImageToMessage(const cv::Mat& image, int32_t pixel_format, image_t* msg) {
  if (image.empty()) return "image is empty";
  if (image.dims != 2) return "image must be two-dimensional";
  msg->width = image.cols;
  msg->height = image.rows;
  msg->pixel_format = pixel_format;
  if (IsCompressed(pixel_format)) {
    if (image.type() != CV_8UC1 && image.type() != CV_8UC3 && image.type() != CV_16UC1) {
      return "JPEG/PNG encoding needs a CV_8UC1, CV_8UC3 or CV_16UC1 image";
    }
    std::vector<uint8_t> encoded;
    try {
      if (!cv::imencode(pixel_format == image_t::JPEG ? ".jpg" : ".png", image, encoded)) {
        return "cv::imencode failed for " + PixelFormatName(pixel_format);
      }
    } catch (const std::exception& e) {
      return std::string("cv::imencode failed: ") + e.what();
    }
    msg->row_stride = 0;
    msg->data = std::move(encoded);
    msg->size = static_cast<int32_t>(msg->data.size());
    return "";
  }
  const int type = CvTypeOf(pixel_format);
  if (type < 0) return "unknown pixel format " + PixelFormatName(pixel_format);
  if (image.type() != type) {
    return "pixel format " + PixelFormatName(pixel_format) + " needs a cv::Mat of type " +
           cv::typeToString(type) + ", got " + cv::typeToString(image.type());
  }
  const size_t row_bytes = static_cast<size_t>(image.cols) * image.elemSize();
  msg->row_stride = static_cast<int32_t>(row_bytes);
  msg->data.resize(row_bytes * image.rows);
  if (image.isContinuous()) {
    std::memcpy(msg->data.data(), image.data, msg->data.size());
  } else {
    for (int r = 0; r < image.rows; ++r) {
      std::memcpy(msg->data.data() + r * row_bytes, image.ptr(r), row_bytes);
    }
  }
  msg->size = static_cast<int32_t>(msg->data.size());
  return "";
}

std::string MakeImageMessage(const cv::Mat& image, int32_t pixel_format, int64_t t_ns,
                             int64_t seq, int32_t camera_id, image_t* msg) {
  msg->utime = NsToUtime(t_ns);
  msg->seq = seq;
  msg->camera_id = camera_id;
  msg->exposure_us = 0;
  return ImageToMessage(image, pixel_format, msg);
}

std::string ValidateUtime(const char* type_name, int64_t utime) {
  // Stamps are converted to int64 nanoseconds (UtimeToNs): beyond +-2^63 ns (year 2262) the
  // product overflows. A message that far from now is corrupt; found by fuzz_lcm_messages.
  constexpr int64_t kMaxUtime = std::numeric_limits<int64_t>::max() / 1000;
  if (utime > kMaxUtime || utime < -kMaxUtime) {
    return std::string(type_name) + ": utime " + std::to_string(utime) +
           " us is out of range (|utime| <= " + std::to_string(kMaxUtime) + ")";
  }
  return "";
}

std::string ValidateImageMessage(const image_t& msg) {
  if (std::string error = ValidateUtime("image_t", msg.utime); !error.empty()) return error;
  if (msg.width <= 0 || msg.height <= 0) {
    return "image_t: width " + std::to_string(msg.width) + " x height " +
           std::to_string(msg.height) + ": expected positive dimensions";
  }
  if (msg.camera_id < 0) return "image_t: camera_id " + std::to_string(msg.camera_id) + " < 0";
  if (msg.size < 0 || static_cast<size_t>(msg.size) != msg.data.size()) {
    return "image_t: size " + std::to_string(msg.size) + " but data holds " +
           std::to_string(msg.data.size()) + " bytes";
  }
  if (IsCompressed(msg.pixel_format)) {
    if (msg.size == 0) return "image_t: " + PixelFormatName(msg.pixel_format) + " with no data";
    if (msg.row_stride != 0) return "image_t: row_stride must be 0 for compressed formats";
    return "";
  }
  const int bpp = BytesPerPixel(msg.pixel_format);
  if (bpp == 0) return "image_t: unknown pixel_format " + std::to_string(msg.pixel_format);
  const int64_t min_stride = static_cast<int64_t>(msg.width) * bpp;
  if (msg.row_stride < min_stride) {
    return "image_t: row_stride " + std::to_string(msg.row_stride) + " < width * " +
           std::to_string(bpp) + " = " + std::to_string(min_stride);
  }
  const int64_t expected = static_cast<int64_t>(msg.height) * msg.row_stride;
  if (msg.size != expected) {
    return "image_t: size " + std::to_string(msg.size) + " != height * row_stride = " +
           std::to_string(expected);
  }
  return "";
}

namespace {

// Largest compressed image decoded [pixels]: a PNG or JPEG of a few bytes can claim any size
// (a decompression bomb); 64 Mpx covers every camera vilma drives.
constexpr int64_t kMaxCompressedPixels = int64_t{1} << 26;

uint32_t BigEndian16(const uint8_t* p) { return (uint32_t{p[0]} << 8) | p[1]; }
uint32_t BigEndian32(const uint8_t* p) { return (BigEndian16(p) << 16) | BigEndian16(p + 2); }

// The dimensions a PNG (IHDR) or JPEG (first SOF segment) file declares, read before anything
// is decoded: cv::imdecode would otherwise hand bytes without the format's signature to
// whichever of OpenCV's decoders accepts them (GDAL among them in Debian's build; found by
// fuzz_lcm_messages: 90 bytes of a "PNG" without its signature took 250 ms and large
// allocations) and allocate what the file claims. "" or what is wrong.
std::string CompressedDimensions(const image_t& msg, uint32_t* width, uint32_t* height) {
  const uint8_t* d = msg.data.data();
  const std::size_t n = msg.data.size();
  if (msg.pixel_format == image_t::PNG) {
    static const uint8_t kSignature[8] = {0x89, 'P', 'N', 'G', '\r', '\n', 0x1a, '\n'};
    if (n < 24 || std::memcmp(d, kSignature, 8) != 0 || std::memcmp(d + 12, "IHDR", 4) != 0) {
      return "image_t: PNG data does not start with the PNG signature and IHDR";
    }
    *width = BigEndian32(d + 16);
    *height = BigEndian32(d + 20);
    return "";
  }
  // JPEG: SOI, then segments (0xFF marker, 2-byte length) up to a start-of-frame marker.
  if (n < 4 || d[0] != 0xFF || d[1] != 0xD8 || d[2] != 0xFF) {
    return "image_t: JPEG data does not start with the SOI marker";
  }
  for (std::size_t at = 2; at + 4 <= n;) {
    if (d[at] != 0xFF) return "image_t: JPEG segment without a marker";
    const uint8_t marker = d[at + 1];
    if (marker == 0xFF) {  // fill byte
      ++at;
      continue;
    }
    const uint32_t length = BigEndian16(d + at + 2);
    const bool start_of_frame = marker >= 0xC0 && marker <= 0xCF && marker != 0xC4 &&
                                marker != 0xC8 && marker != 0xCC;
    if (start_of_frame) {
      if (at + 9 > n) break;
      *height = BigEndian16(d + at + 5);
      *width = BigEndian16(d + at + 7);
      return "";
    }
    if (length < 2) return "image_t: JPEG segment length below 2";
    at += 2 + length;
  }
  return "image_t: JPEG data without a start-of-frame segment";
}

}  // namespace

std::string MessageToImage(const image_t& msg, cv::Mat* image) {
  std::string error = ValidateImageMessage(msg);
  if (!error.empty()) return error;
  try {
    if (IsCompressed(msg.pixel_format)) {
      if (int64_t{msg.width} * msg.height > kMaxCompressedPixels) {
        return "image_t: " + PixelFormatName(msg.pixel_format) + " of " +
               std::to_string(msg.width) + "x" + std::to_string(msg.height) +
               " px, above the limit of " + std::to_string(kMaxCompressedPixels) + " px";
      }
      uint32_t file_width = 0, file_height = 0;
      error = CompressedDimensions(msg, &file_width, &file_height);
      if (!error.empty()) return error;
      if (file_width != static_cast<uint32_t>(msg.width) ||
          file_height != static_cast<uint32_t>(msg.height)) {
        return "image_t: " + PixelFormatName(msg.pixel_format) + " file is " +
               std::to_string(file_width) + "x" + std::to_string(file_height) +
               ", header says " + std::to_string(msg.width) + "x" + std::to_string(msg.height);
      }
      const cv::Mat buffer(1, msg.size, CV_8UC1, const_cast<uint8_t*>(msg.data.data()));
      cv::Mat decoded = cv::imdecode(buffer, cv::IMREAD_UNCHANGED);
      if (decoded.empty()) return "image_t: " + PixelFormatName(msg.pixel_format) + " does not decode";
      if (decoded.cols != msg.width || decoded.rows != msg.height) {
        return "image_t: decoded " + PixelFormatName(msg.pixel_format) + " is " +
               std::to_string(decoded.cols) + "x" + std::to_string(decoded.rows) +
               ", header says " + std::to_string(msg.width) + "x" + std::to_string(msg.height);
      }
      *image = decoded;
      return "";
    }
    // A view on the message's bytes honouring row_stride, then copied (or demosaiced) into
    // memory owned by the result.
    const cv::Mat view(msg.height, msg.width, CvTypeOf(msg.pixel_format),
                       const_cast<uint8_t*>(msg.data.data()), static_cast<size_t>(msg.row_stride));
    const int demosaic = DemosaicCode(msg.pixel_format);
    if (demosaic >= 0) {
      if (msg.width < 2 || msg.height < 2) return "image_t: Bayer image smaller than 2x2";
      cv::cvtColor(view, *image, demosaic);
    } else {
      *image = view.clone();
    }
  } catch (const std::exception& e) {
    return std::string("image_t: conversion failed: ") + e.what();
  }
  return "";
}

std::string MessageToGray8(const image_t& msg, cv::Mat* gray) {
  cv::Mat image;
  std::string error = MessageToImage(msg, &image);
  if (!error.empty()) return error;
  try {
    if (image.depth() == CV_16U) image.convertTo(image, CV_8U, 1.0 / 256.0);
    if (image.channels() == 1) {
      *gray = image;
    } else if (image.channels() == 3) {
      cv::cvtColor(image, *gray,
                   msg.pixel_format == image_t::RGB8 ? cv::COLOR_RGB2GRAY : cv::COLOR_BGR2GRAY);
    } else if (image.channels() == 4) {
      cv::cvtColor(image, *gray, cv::COLOR_BGRA2GRAY);
    } else {
      return "image_t: cannot convert " + std::to_string(image.channels()) + " channels to gray";
    }
  } catch (const std::exception& e) {
    return std::string("image_t: conversion to gray failed: ") + e.what();
  }
  return "";
}

imu_t ImuToMessage(const ImuSample& sample, int64_t seq) {
  imu_t msg;
  msg.utime = NsToUtime(sample.t_ns);
  msg.seq = seq;
  for (int i = 0; i < 3; ++i) {
    msg.angular_velocity[i] = sample.omega_I[i];
    msg.linear_acceleration[i] = sample.a_I[i];
  }
  return msg;
}

std::string MessageToImu(const imu_t& msg, ImuSample* sample) {
  if (std::string error = ValidateUtime("imu_t", msg.utime); !error.empty()) return error;
  for (int i = 0; i < 3; ++i) {
    if (!std::isfinite(msg.angular_velocity[i]) || !std::isfinite(msg.linear_acceleration[i])) {
      return "imu_t: non-finite angular_velocity or linear_acceleration";
    }
  }
  sample->t_ns = UtimeToNs(msg.utime);
  sample->omega_I = Eigen::Vector3d(msg.angular_velocity[0], msg.angular_velocity[1],
                                    msg.angular_velocity[2]);
  sample->a_I = Eigen::Vector3d(msg.linear_acceleration[0], msg.linear_acceleration[1],
                                msg.linear_acceleration[2]);
  return "";
}

std::string DecodeImageMessage(const void* data, int size, image_t* msg) {
  if (data == nullptr || size < kImageHeaderBytes) {
    return "image_t: " + std::to_string(size) + " bytes, shorter than the " +
           std::to_string(kImageHeaderBytes) + "-byte header";
  }
  // Check the data size field against the buffer before decoding: the generated decoder would
  // otherwise allocate whatever `size` claims (up to 2 GB) or throw on a negative value.
  const int64_t data_size = ReadBigEndian(static_cast<const uint8_t*>(data) + kImageHeaderBytes - 4, 4);
  if (data_size < 0 || data_size != size - kImageHeaderBytes) {
    return "image_t: size field " + std::to_string(data_size) + " but the message carries " +
           std::to_string(size - kImageHeaderBytes) + " data bytes";
  }
  try {
    if (msg->decode(data, 0, size) != size) return "image_t: does not decode (wrong type hash?)";
  } catch (const std::exception& e) {
    return std::string("image_t: decode failed: ") + e.what();
  }
  return ValidateImageMessage(*msg);
}

std::string DecodeImuMessage(const void* data, int size, imu_t* msg, ImuSample* sample) {
  if (data == nullptr || size != kImuMessageBytes) {
    return "imu_t: " + std::to_string(size) + " bytes, expected " +
           std::to_string(kImuMessageBytes);
  }
  if (msg->decode(data, 0, size) != size) return "imu_t: does not decode (wrong type hash?)";
  if (sample == nullptr) {
    ImuSample unused;
    return MessageToImu(*msg, &unused);
  }
  return MessageToImu(*msg, sample);
}

bool PeekUtimeAndSeq(const void* data, int size, int64_t* utime, int64_t* seq) {
  if (data == nullptr || size < 24) return false;
  const auto* p = static_cast<const uint8_t*>(data);
  *utime = ReadBigEndian(p + 8, 8);
  *seq = ReadBigEndian(p + 16, 8);
  return true;
}

}  // namespace vilma
