// Conversion between the VI-map model (vi_map.h) and its protobuf messages (vi_map.proto), for
// the map files (map_io.cpp) and the mission stream's deltas. Private to mapstore. Every reader
// names the file and the field path of what it rejects (InputError).
#pragma once

#include <Eigen/Core>
#include <string>
#include <utility>

#include "vi_map.pb.h"
#include "vilma/core/error.h"
#include "vilma/mapstore/vi_map.h"

namespace vilma::mapstore::proto {

class Reader {
 public:
  explicit Reader(std::string file) : file_(std::move(file)) {}
  [[noreturn]] void Fail(const std::string& field, const std::string& expectation) const {
    throw InputError(FormatInputError(file_, field, expectation));
  }
  const std::string& file() const { return file_; }

  Id ReadId(const pb::Id& id) const {
    Id out;
    out.hi = id.hi();
    out.lo = id.lo();
    return out;
  }

  Transformation ReadPose(const pb::Pose& p, const std::string& field) const {
    const Eigen::Quaterniond q(p.qw(), p.qx(), p.qy(), p.qz());
    const Eigen::Vector3d t(p.px(), p.py(), p.pz());
    if (!q.coeffs().allFinite() || !t.allFinite()) Fail(field, "expected finite values");
    if (std::abs(q.squaredNorm() - 1.0) > 1e-9) {
      Fail(field,
           "expected a unit quaternion (w, x, y, z), found norm " + std::to_string(q.norm()));
    }
    // Stored quaternions were normalized when created: keep their bits (bit-exact round trip).
    return Transformation::FromUnitQuaternion(q, t);
  }

  template <int R, int C>
  Eigen::Matrix<double, R, C> ReadMatrix(const google::protobuf::RepeatedField<double>& values,
                                         const std::string& field) const {
    if (values.size() != R * C) {
      Fail(field,
           "expected " + std::to_string(R * C) + " values, found " + std::to_string(values.size()));
    }
    Eigen::Matrix<double, R, C> m;
    for (int r = 0; r < R; ++r) {
      for (int c = 0; c < C; ++c) m(r, c) = values.Get(r * C + c);
    }
    return m;
  }

 private:
  std::string file_;
};

void ToProto(const Id& id, pb::Id* out);
void ToProto(const Transformation& T, pb::Pose* out);
void ToProto(const Mission& m, pb::Mission* out);
void ToProto(const VisualFrame& f, pb::VisualFrame* out);
void ToProto(const Vertex& v, pb::Vertex* out);
pb::EdgeType ToProto(EdgeType type);
void ToProto(const Edge& e, pb::Edge* out);
void ToProto(const Landmark& l, pb::Landmark* out);
Mission FromProto(const pb::Mission& p, const Reader& in, const std::string& field);
VisualFrame FromProto(const pb::VisualFrame& p, const Reader& in, const std::string& field);
Vertex FromProto(const pb::Vertex& p, const Reader& in, const std::string& field);
Edge FromProto(const pb::Edge& p, const Reader& in, const std::string& field);
Landmark FromProto(const pb::Landmark& p, const Reader& in, const std::string& field);

}  // namespace vilma::mapstore::proto
