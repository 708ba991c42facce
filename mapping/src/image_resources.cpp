#include "vilma/mapping/image_resources.h"

#include <opencv2/imgcodecs.hpp>
#include <stdexcept>
#include <vector>

namespace vilma::mapping {

mapstore::ResourceId ImageResourceId(const mapstore::VertexId& vertex_id, uint32_t camera) {
  // Two splitmix64 rounds: the first mixes the high half (with a tag, so that image ids are
  // unrelated to the vertex's own id stream), the second the low half and the camera.
  constexpr uint64_t kImageTag = 0xBB67AE8584CAA73BULL;  // sqrt(3) fraction bits
  mapstore::IdGenerator high(vertex_id.hi ^ kImageTag);
  const mapstore::Id mixed = high.Next();
  mapstore::IdGenerator low(mixed.lo ^ vertex_id.lo ^
                            (static_cast<uint64_t>(camera) + 1) * 0x9E3779B97F4A7C15ULL);
  return low.Next();
}

std::string EncodeImagePng(const cv::Mat& image) {
  if (image.empty()) throw std::invalid_argument("EncodeImagePng: empty image");
  const int depth = image.depth();
  const int channels = image.channels();
  if ((depth != CV_8U && depth != CV_16U) || (channels != 1 && channels != 3 && channels != 4)) {
    throw std::invalid_argument(
        "EncodeImagePng: PNG holds 8- or 16-bit images with 1, 3 or 4 "
        "channels, got type " +
        std::to_string(image.type()));
  }
  std::vector<uchar> png;
  if (!cv::imencode(".png", image, png)) {
    throw std::invalid_argument("EncodeImagePng: cv::imencode failed");
  }
  return std::string(png.begin(), png.end());
}

cv::Mat DecodeImageResource(const std::string& bytes) {
  const std::vector<uchar> data(bytes.begin(), bytes.end());
  cv::Mat image = cv::imdecode(data, cv::IMREAD_UNCHANGED);
  if (image.empty()) throw std::runtime_error("image resource: the bytes are not an image");
  return image;
}

}  // namespace vilma::mapping
