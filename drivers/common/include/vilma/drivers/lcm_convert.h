// Conversions between core types (cv::Mat images, ImuSample, t_ns) and vilma LCM messages,
// and validation of incoming messages.
//
// Validation and decoding never throw: a daemon that receives a malformed message counts it
// and goes on (architecture.md section 9). Every function that can fail returns an error
// string, empty on success.
//
// Time: messages carry utime [us] on the robot's clock; t_ns -> utime rounds to the nearest
// microsecond (core/time.h), so t_ns survives a round trip only to the microsecond.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <string>

#include <vilma/image_t.hpp>
#include <vilma/imu_t.hpp>

#include "vilma/core/imu.h"

namespace vilma {

// Encoded size of an image_t without its data [bytes]: hash 8 + 2 x int64 + 7 x int32.
constexpr int kImageHeaderBytes = 8 + 2 * 8 + 7 * 4;
// Encoded size of an imu_t [bytes]: hash 8 + 2 x int64 + 6 x double.
constexpr int kImuMessageBytes = 8 + 2 * 8 + 6 * 8;

// "GRAY8", "BAYER_RGGB8", ...; "UNKNOWN(<n>)" for unknown values.
std::string PixelFormatName(int32_t pixel_format);
// Bytes per pixel of a raw format (1 for GRAY8 and Bayer, 2 for GRAY16, 3 for RGB8/BGR8); 0 for
// compressed (JPEG, PNG) and unknown formats.
int BytesPerPixel(int32_t pixel_format);

// Fills `msg` (everything but utime, seq, camera_id, exposure_us, which the caller sets) from
// `image`, copying the pixels row by row (row_stride = width * bytes per pixel):
//   GRAY8: CV_8UC1; GRAY16: CV_16UC1 (host byte order, i.e. little endian on x86 and ARM);
//   RGB8, BGR8: CV_8UC3 whose channel order is the format's (no swapping is done here);
//   BAYER_*: CV_8UC1 raw mosaic;
//   JPEG, PNG: CV_8UC1 or CV_8UC3 (BGR), encoded with cv::imencode (row_stride = 0).
std::string ImageToMessage(const cv::Mat& image, int32_t pixel_format, image_t* msg);

// Convenience: a complete message from a capture.
std::string MakeImageMessage(const cv::Mat& image, int32_t pixel_format, int64_t t_ns,
                             int64_t seq, int32_t camera_id, image_t* msg);

// "" when `utime` [us] converts to int64 nanoseconds without overflow (|utime| <= 2^63 / 1000),
// else "<type_name>: utime ... is out of range". Image and IMU checks include it.
std::string ValidateUtime(const char* type_name, int64_t utime);

// Checks an incoming image: utime in range, positive dimensions, known format, camera_id >= 0, and for raw
// formats row_stride >= width * bytes per pixel and size == height * row_stride; for JPEG/PNG
// size > 0 and row_stride == 0; data holds `size` bytes.
std::string ValidateImageMessage(const image_t& msg);

// Decodes the pixels of a validated or unvalidated message (it is validated first) into a new
// cv::Mat that owns its memory:
//   GRAY8 -> CV_8UC1, GRAY16 -> CV_16UC1, RGB8 -> CV_8UC3 (R,G,B), BGR8 -> CV_8UC3 (B,G,R),
//   BAYER_* -> CV_8UC3 BGR (demosaiced with cv::cvtColor, bilinear),
//   JPEG/PNG -> as stored in the file (cv::IMREAD_UNCHANGED); its size must match width/height.
std::string MessageToImage(const image_t& msg, cv::Mat* image);

// Like MessageToImage, then converted to 8-bit grayscale (what the visual front-end uses):
// GRAY16 is scaled by 1/256, colour is converted with cv::cvtColor (ITU-R BT.601 weights).
std::string MessageToGray8(const image_t& msg, cv::Mat* gray);

// imu_t <-> ImuSample. MessageToImu checks that all values are finite.
imu_t ImuToMessage(const ImuSample& sample, int64_t seq);
std::string MessageToImu(const imu_t& msg, ImuSample* sample);

// Decodes raw LCM bytes into a message without ever throwing or allocating more than the
// buffer announces: wrong length, wrong type hash, or an image `size` field that disagrees
// with the buffer length is an error. Images are validated as well (ValidateImageMessage).
std::string DecodeImageMessage(const void* data, int size, image_t* msg);
std::string DecodeImuMessage(const void* data, int size, imu_t* msg, ImuSample* sample);

// Reads the (utime, seq) pair that image_t and imu_t share at the start of their encoding
// (after the 8-byte type hash); false if the buffer is shorter than 24 bytes. Used by tools
// that only count messages and gaps (vilma-lcm-rates).
bool PeekUtimeAndSeq(const void* data, int size, int64_t* utime, int64_t* seq);

}  // namespace vilma
