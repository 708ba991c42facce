#include "vilma/mapping/dense/depth_map.h"

#include <cmath>
#include <iomanip>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <stdexcept>
#include <vector>

#include "vilma/core/error.h"
#include "vilma/mapstore/checksum.h"

namespace vilma::mapping {

int DepthMap::ValidPixels() const {
  int n = 0;
  for (int v = 0; v < depth_m.rows; ++v) {
    const float* row = depth_m.ptr<float>(v);
    for (int u = 0; u < depth_m.cols; ++u) n += (std::isfinite(row[u]) && row[u] > 0.0f);
  }
  return n;
}

Eigen::Vector3d DepthMap::PointInCamera(double u, double v, double z) const {
  const Eigen::Vector3d p_D(z * (u - cx) / fx, z * (v - cy) / fy, z);
  return q_C_D * p_D;
}

std::string EncodeDepthMap(const DepthMap& depth, double depth_unit_m) {
  if (depth.depth_m.empty() || depth.depth_m.type() != CV_32FC1) {
    throw std::invalid_argument("EncodeDepthMap: expected a non-empty CV_32FC1 depth image");
  }
  if (!(depth_unit_m > 0.0)) throw std::invalid_argument("EncodeDepthMap: depth_unit_m <= 0");
  cv::Mat quantized(depth.depth_m.size(), CV_16UC1);
  for (int v = 0; v < quantized.rows; ++v) {
    const float* in = depth.depth_m.ptr<float>(v);
    uint16_t* out = quantized.ptr<uint16_t>(v);
    for (int u = 0; u < quantized.cols; ++u) {
      const double units = std::isfinite(in[u]) && in[u] > 0.0f ? std::round(in[u] / depth_unit_m)
                                                                 : 0.0;
      out[u] = units >= 1.0 && units <= 65535.0 ? static_cast<uint16_t>(units) : 0;
    }
  }
  std::vector<uint8_t> png;
  if (!cv::imencode(".png", quantized, png)) throw std::runtime_error("PNG encoding failed");
  std::ostringstream header;
  header << std::setprecision(17) << "vilma-depth " << kDepthMapFormatVersion << "\n"
         << "size " << depth.width() << " " << depth.height() << "\n"
         << "pinhole " << depth.fx << " " << depth.fy << " " << depth.cx << " " << depth.cy << "\n"
         << "q_C_D " << depth.q_C_D.w() << " " << depth.q_C_D.x() << " " << depth.q_C_D.y() << " "
         << depth.q_C_D.z() << "\n"
         << "depth_unit_m " << depth_unit_m << "\n\n";
  std::string bytes = header.str();
  bytes.append(reinterpret_cast<const char*>(png.data()), png.size());
  return bytes;
}

namespace {

InputError Malformed(const std::string& where, const std::string& field,
                     const std::string& expected, const std::string& found) {
  return InputError(FormatInputError(where, field, "expected " + expected + ", found " + found));
}

// Reads header line `key` with `count` numbers; throws InputError naming the field.
std::vector<double> ReadHeaderLine(std::istringstream& in, const std::string& key, int count,
                                   const std::string& where) {
  std::string line;
  if (!std::getline(in, line)) {
    throw Malformed(where, key, "a header line '" + key + " ...'", "the end");
  }
  std::istringstream words(line);
  std::string name;
  words >> name;
  if (name != key) throw Malformed(where, key, "the line '" + key + " ...'", "'" + line + "'");
  std::vector<double> values(count);
  for (double& x : values) {
    if (!(words >> x) || !std::isfinite(x)) {
      throw Malformed(where, key, std::to_string(count) + " finite numbers",
                                        "'" + line + "'");
    }
  }
  return values;
}

}  // namespace

DepthMap DecodeDepthMap(const std::string& bytes, const std::string& where) {
  const std::size_t end = bytes.find("\n\n");
  if (bytes.rfind("vilma-depth ", 0) != 0 || end == std::string::npos) {
    throw Malformed(where, "header",
                                      "a vilma depth map ('vilma-depth 1' ... blank line)",
                                      "other bytes");
  }
  std::istringstream in(bytes.substr(0, end + 1));
  // Whole numbers are checked before any cast to int (a cast of 1e30 is undefined).
  const double version = ReadHeaderLine(in, "vilma-depth", 1, where)[0];
  if (!(version >= 1 && version <= kDepthMapFormatVersion && version == std::floor(version))) {
    std::ostringstream found;
    found << version;
    throw Malformed(where, "vilma-depth",
                                      "a format version from 1 to " +
                                          std::to_string(kDepthMapFormatVersion),
                                      found.str());
  }
  const std::vector<double> size = ReadHeaderLine(in, "size", 2, where);
  for (double n : size) {
    if (!(n >= 1 && n <= 65535 && n == std::floor(n))) {
      std::ostringstream found;
      found << size[0] << " " << size[1];
      throw Malformed(where, "size", "width and height, whole numbers from 1 to 65535", found.str());
    }
  }
  const std::vector<double> pinhole = ReadHeaderLine(in, "pinhole", 4, where);
  const std::vector<double> q = ReadHeaderLine(in, "q_C_D", 4, where);
  const double unit = ReadHeaderLine(in, "depth_unit_m", 1, where)[0];
  if (!(pinhole[0] > 0.0 && pinhole[1] > 0.0)) {
    throw Malformed(where, "pinhole", "positive focal lengths", "fx or fy <= 0");
  }
  if (!(unit > 0.0)) throw Malformed(where, "depth_unit_m", "> 0", std::to_string(unit));
  const Eigen::Quaterniond q_C_D(q[0], q[1], q[2], q[3]);
  if (std::abs(q_C_D.norm() - 1.0) > 1e-6) {
    throw Malformed(where, "q_C_D", "a unit quaternion (w, x, y, z)",
                                      "norm " + std::to_string(q_C_D.norm()));
  }
  const std::vector<uint8_t> png(bytes.begin() + static_cast<std::ptrdiff_t>(end + 2), bytes.end());
  // cv::imdecode asserts (cv::Exception) on an empty buffer instead of returning no image.
  const cv::Mat quantized = png.empty() ? cv::Mat() : cv::imdecode(png, cv::IMREAD_UNCHANGED);
  if (quantized.empty() || quantized.type() != CV_16UC1) {
    throw Malformed(where, "data", "a 16-bit one-channel PNG", "other data");
  }
  if (quantized.cols != static_cast<int>(size[0]) || quantized.rows != static_cast<int>(size[1])) {
    throw Malformed(
        where, "size", std::to_string(static_cast<int>(size[0])) + "x" + std::to_string(static_cast<int>(size[1])) + " as the header says",
        std::to_string(quantized.cols) + "x" + std::to_string(quantized.rows));
  }
  DepthMap depth;
  depth.fx = pinhole[0];
  depth.fy = pinhole[1];
  depth.cx = pinhole[2];
  depth.cy = pinhole[3];
  depth.q_C_D = q_C_D;
  quantized.convertTo(depth.depth_m, CV_32FC1, unit);
  return depth;
}

mapstore::ResourceId DerivedResourceId(const mapstore::VertexId& vertex, int camera,
                                       const std::string& kind, const std::string& bytes) {
  // splitmix64-style mixing of the vertex id, camera, kind and content checksum: ids of
  // different content differ unless CRC-32 and size collide, equal content repeats.
  uint64_t seed = vertex.hi ^ (vertex.lo * 0x9e3779b97f4a7c15ull);
  seed ^= (static_cast<uint64_t>(camera) + 1) * 0xbf58476d1ce4e5b9ull;
  seed ^= static_cast<uint64_t>(mapstore::Crc32(kind)) << 32;
  seed ^= static_cast<uint64_t>(mapstore::Crc32(bytes)) * 0x94d049bb133111ebull;
  seed ^= static_cast<uint64_t>(bytes.size());
  return mapstore::IdGenerator(seed).Next();
}

DepthMap LoadDepthMap(const mapstore::VIMap& map, const mapstore::VertexId& vertex, int camera) {
  const std::string where = "vertex " + vertex.Hex() + " camera " + std::to_string(camera);
  const mapstore::Vertex& v = map.vertex(vertex);
  if (camera < 0 || camera >= static_cast<int>(v.frames.size()) ||
      !v.frames[camera].depth_resource_id.IsValid()) {
    throw InputError(where + ": depth_resource_id: expected a depth map, found none");
  }
  const mapstore::ResourceId& id = v.frames[camera].depth_resource_id;
  return DecodeDepthMap(*map.resources().Load(mapstore::ResourceType::kDepthMap, id),
                        where + " depth resource " + id.Hex());
}

Eigen::Matrix4d DepthViewPose(const mapstore::VIMap& map, const mapstore::VertexId& vertex,
                              int camera, const DepthMap& depth) {
  const mapstore::Mission& mission = map.mission(map.vertex(vertex).mission_id);
  const Transformation T_G_C = map.T_G_I(vertex) * mission.rig.cameras.at(camera).T_I_C;
  Eigen::Matrix4d T_G_D = T_G_C.matrix();
  T_G_D.topLeftCorner<3, 3>() = T_G_C.rotationMatrix() * depth.q_C_D.toRotationMatrix();
  return T_G_D;
}

std::string DepthFilterOptions::Validate() const {
  if (neighbours < 0) return "neighbours: >= 0";
  if (min_consistent_views < 1) return "min_consistent_views: >= 1";
  if (!(relative_tolerance > 0.0)) return "relative_tolerance: > 0";
  return "";
}

int FilterDepthByNeighbours(DepthMap* view, const Eigen::Matrix4d& T_G_D,
                            const std::vector<PosedDepth>& others, const DepthFilterOptions& options) {
  std::vector<Eigen::Matrix4d> T_O_D;
  for (const PosedDepth& o : others) T_O_D.push_back(o.T_G_D.inverse() * T_G_D);
  int removed = 0;
  for (int v = 0; v < view->height(); ++v) {
    float* row = view->depth_m.ptr<float>(v);
    for (int u = 0; u < view->width(); ++u) {
      const float z = row[u];
      if (!(z > 0.0f)) continue;
      const Eigen::Vector4d p_D(z * (u - view->cx) / view->fx, z * (v - view->cy) / view->fy, z, 1.0);
      int confirmed = 0;
      for (std::size_t k = 0; k < others.size() && confirmed < options.min_consistent_views; ++k) {
        const DepthMap& o = *others[k].depth;
        const Eigen::Vector4d p_O = T_O_D[k] * p_D;
        if (p_O.z() <= 0.0) continue;
        const long uo = std::lround(o.fx * p_O.x() / p_O.z() + o.cx);
        const long vo = std::lround(o.fy * p_O.y() / p_O.z() + o.cy);
        if (uo < 0 || vo < 0 || uo >= o.width() || vo >= o.height()) continue;
        const float z_o = o.depth_m.at<float>(static_cast<int>(vo), static_cast<int>(uo));
        confirmed += z_o > 0.0f && std::abs(p_O.z() - z_o) <= options.relative_tolerance * p_O.z();
      }
      if (confirmed < options.min_consistent_views) {
        row[u] = 0.0f;
        ++removed;
      }
    }
  }
  return removed;
}

}  // namespace vilma::mapping
