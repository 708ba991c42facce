// Camera images kept in a VI-map as image resources (docs/vi-map.md "Resources"): lossless PNG
// bytes (8-bit grey stays grey, colour stays colour) under an id derived from the vertex and
// the camera, so that every tool that stores the image of one vertex camera (the map builder's
// `keep_images`, the console's `attach_images`) gives it the same id, run after run.
#pragma once

#include <cstdint>
#include <opencv2/core.hpp>
#include <string>

#include "vilma/mapstore/id.h"

namespace vilma::mapping {

// The image resource id of camera `camera` at vertex `vertex_id`: the first id of an
// IdGenerator seeded from both halves of the vertex id and the camera index (never invalid).
mapstore::ResourceId ImageResourceId(const mapstore::VertexId& vertex_id, uint32_t camera);

// PNG bytes of an 8- or 16-bit, 1-, 3- or 4-channel image (cv::imencode, default compression).
// Throws std::invalid_argument for an empty image or one PNG cannot hold.
std::string EncodeImagePng(const cv::Mat& image);

// The image of encoded resource bytes as stored (cv::IMREAD_UNCHANGED: grey stays grey).
// Throws std::runtime_error when the bytes are not an image.
cv::Mat DecodeImageResource(const std::string& bytes);

}  // namespace vilma::mapping
