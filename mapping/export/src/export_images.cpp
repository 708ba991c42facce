#include "export_images.h"

#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "vilma/core/error.h"

namespace vilma::mapping::export_images {

DecodedImage DecodeImageResource(const mapstore::VIMap& map, const mapstore::ResourceId& id,
                                 int width, int height) {
  const mapstore::ResourceInfo& info = map.resources().Info(mapstore::ResourceType::kImage, id);
  DecodedImage image;
  image.bytes = map.resources().Load(mapstore::ResourceType::kImage, id);
  image.extension = info.extension;
  image.where = "image resource " + info.RelativePath();
  const cv::Mat raw(1, static_cast<int>(image.bytes->size()), CV_8UC1,
                    const_cast<char*>(image.bytes->data()));
  image.picture = cv::imdecode(raw, cv::IMREAD_UNCHANGED);
  if (image.picture.empty()) {
    throw InputError(FormatInputError(image.where, "", "expected an image OpenCV can decode"));
  }
  if (image.picture.cols != width || image.picture.rows != height) {
    throw InputError(FormatInputError(image.where, "size",
                                      "expected " + std::to_string(width) + "x" +
                                          std::to_string(height) + " as the rig's camera, found " +
                                          std::to_string(image.picture.cols) + "x" +
                                          std::to_string(image.picture.rows)));
  }
  return image;
}

bool HasImage(const mapstore::VIMap& map, const mapstore::VisualFrame& frame) {
  return frame.image_resource_id.IsValid() &&
         map.resources().Has(mapstore::ResourceType::kImage, frame.image_resource_id);
}

ImageUndistorter::ImageUndistorter(const Camera& source, const Camera& target)
    : source_(source), target_(target) {}

bool ImageUndistorter::Keypoint(const Eigen::Vector2d& uv, Eigen::Vector2d* target_uv) const {
  Eigen::Vector3d bearing;
  return source_.Unproject(uv, &bearing) && bearing.z() > 1e-6 &&
         target_.Project(bearing, target_uv) != Camera::ProjectionResult::kNotFinite;
}

cv::Mat ImageUndistorter::Image(const cv::Mat& picture) {
  if (map_x_.empty()) source_.ComputeUndistortionMaps(target_, &map_x_, &map_y_);
  cv::Mat undistorted;
  cv::remap(picture, undistorted, map_x_, map_y_, cv::INTER_LINEAR, cv::BORDER_CONSTANT,
            cv::Scalar::all(0));
  return undistorted;
}

void ThrowMissingKeypoint(const mapstore::LandmarkId& landmark_id,
                          const mapstore::LandmarkObservation& o) {
  throw InputError(FormatInputError("landmark " + landmark_id.Hex(), "observations",
                                    "expected an existing keypoint, found vertex " +
                                        o.vertex_id.Hex() + " camera " + std::to_string(o.camera) +
                                        " keypoint " + std::to_string(o.keypoint) +
                                        " (run check_map_consistency)"));
}

std::array<uint8_t, 3> PixelRgb(const cv::Mat& picture, int u, int v) {
  const int channels = picture.channels();
  const bool wide = picture.depth() == CV_16U;
  auto value = [&](int c) -> uint8_t {
    return wide ? static_cast<uint8_t>(picture.ptr<uint16_t>(v)[u * channels + c] >> 8)
                : picture.ptr<uint8_t>(v)[u * channels + c];
  };
  if (channels >= 3) return {value(2), value(1), value(0)};  // BGR(A) -> RGB
  return {value(0), value(0), value(0)};
}

}  // namespace vilma::mapping::export_images
