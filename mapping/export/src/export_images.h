// Private helpers of the exports that write a map's camera frames (COLMAP, PMVS): decoding an
// image resource, undistorting images and keypoints to a pinhole camera, reading a pixel's
// colour, reporting an observation of a keypoint the frame does not have.
#pragma once

#include <array>
#include <cstdint>
#include <memory>
#include <string>

#include "vilma/core/camera.h"
#include "vilma/mapstore/vi_map.h"

namespace vilma::mapping::export_images {

// An image resource as stored (bytes, extension) and decoded (cv::IMREAD_UNCHANGED: grey, BGR
// or BGRA, 8 or 16 bit).
struct DecodedImage {
  std::shared_ptr<const std::string> bytes;
  std::string extension;  // without the dot, as stored
  std::string where;      // "image resource resources/image/<id>.<ext>", for error messages
  cv::Mat picture;
};

// Loads and decodes the image resource `id`. InputError naming the resource when the bytes
// cannot be decoded or the picture is not width x height (the rig camera's size).
DecodedImage DecodeImageResource(const mapstore::VIMap& map, const mapstore::ResourceId& id,
                                 int width, int height);

// True when frame `frame` of a vertex has an image the map holds.
bool HasImage(const mapstore::VIMap& map, const mapstore::VisualFrame& frame);

// Undistortion from a calibrated camera (`source`) to a distortion-free pinhole (`target`) with
// the same optical centre and orientation: a target pixel shows what the source sees along that
// pixel's ray.
class ImageUndistorter {
 public:
  ImageUndistorter() = default;
  ImageUndistorter(const Camera& source, const Camera& target);

  const Camera& source() const { return source_; }
  const Camera& target() const { return target_; }

  // The keypoint `uv` of the source as a target keypoint: the target's projection of the
  // keypoint's ray. False when the ray cannot be found (no convergence) or does not point
  // forward.
  bool Keypoint(const Eigen::Vector2d& uv, Eigen::Vector2d* target_uv) const;

  // The picture (source size) resampled into the target (bilinear; pixels whose ray the source
  // does not see are black). The remap tables are made on first use.
  cv::Mat Image(const cv::Mat& picture);

 private:
  Camera source_, target_;
  cv::Mat map_x_, map_y_;
};

// Throws InputError naming the landmark and the observation, whose keypoint its frame does not
// have (a broken map; check_map_consistency finds it).
[[noreturn]] void ThrowMissingKeypoint(const mapstore::LandmarkId& landmark_id,
                                       const mapstore::LandmarkObservation& o);

// RGB of pixel (u, v) of an 8- or 16-bit grey, BGR or BGRA picture (16 bit: the high byte).
std::array<uint8_t, 3> PixelRgb(const cv::Mat& picture, int u, int v);

}  // namespace vilma::mapping::export_images
