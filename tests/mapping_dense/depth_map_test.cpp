#include "vilma/mapping/dense/depth_map.h"

#include <catch2/catch.hpp>
#include <opencv2/imgcodecs.hpp>
#include <cmath>
#include <limits>
#include <random>
#include <stdexcept>

#include "mapping_dense/dense_test_util.h"
#include "vilma/core/error.h"

using namespace vilma;
using namespace vilma::mapping;
using vilma::mapping::testing::InputErrorOf;
using testing::Pinhole;
using testing::Plane;
using testing::RenderPlaneDepth;

namespace {

DepthMap SmallDepthMap() {
  DepthMap depth;
  depth.fx = 151.23456789012345;
  depth.fy = 149.87654321098765;
  depth.cx = 79.3000000000001;
  depth.cy = 60.123456789;
  depth.q_C_D = Eigen::Quaterniond(0.9, 0.1, -0.2, 0.3).normalized();
  depth.depth_m = cv::Mat(12, 17, CV_32FC1, cv::Scalar(1.5f));
  return depth;
}

// Replaces the first `from` in `bytes` by `to`.
std::string Patched(std::string bytes, const std::string& from, const std::string& to) {
  const std::size_t at = bytes.find(from);
  REQUIRE(at != std::string::npos);
  return bytes.replace(at, from.size(), to);
}

DepthMap PlaneView(const Pinhole& k, const Eigen::Matrix4d& T_G_D, const Plane& plane) {
  DepthMap d;
  d.fx = k.fx;
  d.fy = k.fy;
  d.cx = k.cx;
  d.cy = k.cy;
  d.depth_m = RenderPlaneDepth(k, T_G_D, plane);
  return d;
}

// Whether the point of pixel (u, v) of view A lands inside view B's image in front of it.
bool Sees(const DepthMap& a, const Eigen::Matrix4d& T_G_A, int u, int v, const DepthMap& b,
          const Eigen::Matrix4d& T_G_B) {
  const float z = a.depth_m.at<float>(v, u);
  const Eigen::Vector4d p_A(z * (u - a.cx) / a.fx, z * (v - a.cy) / a.fy, z, 1.0);
  const Eigen::Vector4d p_B = T_G_B.inverse() * T_G_A * p_A;
  if (p_B.z() <= 0.0) return false;
  const long ub = std::lround(b.fx * p_B.x() / p_B.z() + b.cx);
  const long vb = std::lround(b.fy * p_B.y() / p_B.z() + b.cy);
  return ub >= 0 && vb >= 0 && ub < b.width() && vb < b.height();
}

}  // namespace

TEST_CASE("depth map encoding: round trip within half a unit, header kept exactly", "[depth_map]") {
  DepthMap depth = SmallDepthMap();
  const double unit = GENERATE(0.001, 0.0005, 0.004);
  std::mt19937_64 rng(11);
  std::uniform_real_distribution<double> z(0.05, 60.0 * unit * 1000.0);
  for (int v = 0; v < depth.height(); ++v) {
    for (int u = 0; u < depth.width(); ++u) depth.depth_m.at<float>(v, u) = static_cast<float>(z(rng));
  }
  // Special pixels: none, not finite, negative, beyond 65535 units, the largest and smallest
  // representable depths, and depths that round to 0 units.
  const float kNaN = std::numeric_limits<float>::quiet_NaN();
  const float kInf = std::numeric_limits<float>::infinity();
  const float largest = static_cast<float>(65535.0 * unit);
  depth.depth_m.at<float>(0, 0) = 0.0f;
  depth.depth_m.at<float>(0, 1) = kNaN;
  depth.depth_m.at<float>(0, 2) = kInf;
  depth.depth_m.at<float>(0, 3) = -1.0f;
  depth.depth_m.at<float>(0, 4) = static_cast<float>(65536.0 * unit);
  depth.depth_m.at<float>(0, 5) = static_cast<float>(1e6);
  depth.depth_m.at<float>(0, 6) = largest;
  depth.depth_m.at<float>(0, 7) = static_cast<float>(unit);
  depth.depth_m.at<float>(0, 8) = static_cast<float>(0.4 * unit);
  depth.depth_m.at<float>(0, 9) = -kInf;

  const std::string bytes = EncodeDepthMap(depth, unit);
  CHECK(bytes.rfind("vilma-depth 1\nsize 17 12\n", 0) == 0);
  const DepthMap decoded = DecodeDepthMap(bytes, "test");
  REQUIRE(decoded.width() == 17);
  REQUIRE(decoded.height() == 12);
  REQUIRE(decoded.depth_m.type() == CV_32FC1);
  CHECK(decoded.fx == depth.fx);
  CHECK(decoded.fy == depth.fy);
  CHECK(decoded.cx == depth.cx);
  CHECK(decoded.cy == depth.cy);
  CHECK(decoded.q_C_D.coeffs() == depth.q_C_D.coeffs());

  int dropped = 0;
  double worst = 0.0;
  for (int v = 0; v < depth.height(); ++v) {
    for (int u = 0; u < depth.width(); ++u) {
      const float in = depth.depth_m.at<float>(v, u);
      const float out = decoded.depth_m.at<float>(v, u);
      const double units = std::isfinite(in) && in > 0.0f ? std::round(in / unit) : 0.0;
      if (units < 1.0 || units > 65535.0) {
        CHECK(out == 0.0f);
        ++dropped;
      } else {
        worst = std::max(worst, std::abs(static_cast<double>(out) - in));
      }
    }
  }
  INFO("unit " << unit << ", worst " << worst);
  CHECK(dropped == 8);  // 0, NaN, +-inf, -1, 65536 units, 1e6, 0.4 units
  CHECK(worst <= unit / 2 + 1e-5);
  CHECK(decoded.depth_m.at<float>(0, 6) == Approx(largest).margin(1e-5));
  CHECK(decoded.depth_m.at<float>(0, 7) == Approx(unit).margin(1e-9));
  CHECK(decoded.ValidPixels() == 17 * 12 - 8);

  // Encoding what was decoded gives the same bytes.
  CHECK(EncodeDepthMap(decoded, unit) == bytes);
}

TEST_CASE("depth map encoding refuses an empty map and a bad unit", "[depth_map]") {
  DepthMap depth = SmallDepthMap();
  CHECK_THROWS_AS(EncodeDepthMap(depth, 0.0), std::invalid_argument);
  CHECK_THROWS_AS(EncodeDepthMap(depth, -0.001), std::invalid_argument);
  CHECK_THROWS_AS(EncodeDepthMap(depth, std::nan("")), std::invalid_argument);
  depth.depth_m = cv::Mat();
  CHECK_THROWS_AS(EncodeDepthMap(depth), std::invalid_argument);
  depth.depth_m = cv::Mat(4, 4, CV_64FC1, cv::Scalar(1.0));
  CHECK_THROWS_AS(EncodeDepthMap(depth), std::invalid_argument);
}

TEST_CASE("depth map decoding: malformed bytes name the field", "[depth_map]") {
  const std::string good = EncodeDepthMap(SmallDepthMap());
  REQUIRE_NOTHROW(DecodeDepthMap(good, "x"));
  const std::string where = "vertex 0123 camera 0";
  auto message = [&](const std::string& bytes) {
    return InputErrorOf([&] { DecodeDepthMap(bytes, where); });
  };
  using Catch::Contains;
  using Catch::StartsWith;
  // Not a depth map at all.
  CHECK_THAT(message("\x89PNG\r\n\x1a\n whatever"), StartsWith(where) && Contains("header") &&
                                                        Contains("expected a vilma depth map"));
  CHECK_THAT(message(""), StartsWith(where) && Contains("header"));
  CHECK_THAT(message("vilma-depth 1\nsize 17 12\n"), Contains("header"));  // no blank line
  // Version.
  CHECK_THAT(message(Patched(good, "vilma-depth 1", "vilma-depth 2")),
             StartsWith(where) && Contains("vilma-depth") && Contains("version") && Contains("found 2"));
  CHECK_THAT(message(Patched(good, "vilma-depth 1", "vilma-depth 0")), Contains("version"));
  CHECK_THAT(message(Patched(good, "vilma-depth 1", "vilma-depth 1.5")), Contains("version"));
  // Header lines.
  CHECK_THAT(message(Patched(good, "size 17 12", "size 17")), Contains(": size: expected 2 finite numbers"));
  CHECK_THAT(message(Patched(good, "size 17 12", "dims 17 12")), Contains(": size: expected the line"));
  CHECK_THAT(message(Patched(good, "pinhole 151", "pinhole nan")), Contains(": pinhole: "));
  CHECK_THAT(message(Patched(good, "pinhole 151", "pinhole -151")),
             Contains(": pinhole: expected positive focal lengths"));
  CHECK_THAT(message(Patched(good, "depth_unit_m 0.001", "depth_unit_m 0")), Contains(": depth_unit_m: "));
  CHECK_THAT(message(Patched(good, "depth_unit_m 0.001\n", "")), Contains(": depth_unit_m: "));
  // Non-unit quaternion.
  const std::size_t q_at = good.find("q_C_D ");
  const std::string q_line = good.substr(q_at, good.find('\n', q_at) - q_at);
  CHECK_THAT(message(Patched(good, q_line, "q_C_D 2 0 0 0")),
             StartsWith(where) && Contains(": q_C_D: expected a unit quaternion") && Contains("norm 2"));
  CHECK_THAT(message(Patched(good, q_line, "q_C_D 0 0 0 0")), Contains(": q_C_D: "));
  // The image: truncated, not 16 bit, another size than the header's.
  const std::size_t blank = good.find("\n\n");
  CHECK_THAT(message(good.substr(0, good.size() - 30)), StartsWith(where) && Contains(": data: expected a 16-bit"));
  CHECK_THAT(message(good.substr(0, blank + 2)), Contains(": data: "));
  CHECK_THAT(message(good.substr(0, blank + 2) + "garbage"), Contains(": data: "));
  {
    std::vector<uint8_t> png8;
    REQUIRE(cv::imencode(".png", cv::Mat(12, 17, CV_8UC1, cv::Scalar(9)), png8));
    CHECK_THAT(message(good.substr(0, blank + 2) + std::string(png8.begin(), png8.end())),
               Contains(": data: expected a 16-bit one-channel PNG"));
  }
  CHECK_THAT(message(Patched(good, "size 17 12", "size 18 12")),
             StartsWith(where) && Contains(": size: expected 18x12") && Contains("found 17x12"));
  CHECK_THAT(message(Patched(good, "size 17 12", "size 17 1e30")), Contains(": size: "));
  CHECK_THAT(message(Patched(good, "size 17 12", "size -17 12")), Contains(": size: "));
  CHECK_THAT(message(Patched(good, "size 17 12", "size 17.5 12")), Contains(": size: "));
}

TEST_CASE("derived resource ids: deterministic and content dependent", "[depth_map]") {
  mapstore::IdGenerator ids(5);
  const mapstore::VertexId a = ids.Next(), b = ids.Next();
  const std::string bytes = EncodeDepthMap(SmallDepthMap());
  const mapstore::ResourceId id = DerivedResourceId(a, 0, "depth", bytes);
  CHECK(id.IsValid());
  CHECK(DerivedResourceId(a, 0, "depth", bytes) == id);
  CHECK(DerivedResourceId(a, 0, "depth", std::string(bytes)) == id);
  // Another vertex, camera, kind or content: another id.
  CHECK(!(DerivedResourceId(b, 0, "depth", bytes) == id));
  CHECK(!(DerivedResourceId(a, 1, "depth", bytes) == id));
  CHECK(!(DerivedResourceId(a, 0, "image", bytes) == id));
  std::string other = bytes;
  other[other.size() / 2] = static_cast<char>(other[other.size() / 2] ^ 1);
  CHECK(!(DerivedResourceId(a, 0, "depth", other) == id));
  CHECK(!(DerivedResourceId(a, 0, "depth", bytes + " ") == id));
  // Many contents of one frame: all ids differ.
  std::vector<mapstore::ResourceId> many;
  for (int i = 0; i < 200; ++i) many.push_back(DerivedResourceId(a, 0, "depth", bytes + std::to_string(i)));
  for (std::size_t i = 0; i < many.size(); ++i) {
    for (std::size_t j = i + 1; j < many.size(); ++j) CHECK_FALSE(many[i] == many[j]);
  }
}

TEST_CASE("depth view pose and loading a frame's depth map", "[depth_map]") {
  const testing::PlaneMap m = testing::MakePlaneMap();
  for (std::size_t i = 0; i < m.vertices.size(); ++i) {
    const DepthMap depth = LoadDepthMap(m.map, m.vertices[i], 0);
    CHECK(depth.width() == 160);
    CHECK(depth.q_C_D.coeffs().isApprox(testing::PlaneMapOptions().q_C_D.coeffs(), 1e-15));
    // T_G_D = T_G_M T_M_I T_I_C [R_C_D, 0], as the map was built.
    const Eigen::Matrix4d T_G_D = DepthViewPose(m.map, m.vertices[i], 0, depth);
    CHECK((T_G_D - m.T_G_D[i]).cwiseAbs().maxCoeff() < 1e-12);
    // ... and by hand from the map's parts.
    const mapstore::Mission& mission = m.map.mission(m.mission);
    const Eigen::Matrix4d by_hand =
        (mission.T_G_M * m.map.vertex(m.vertices[i]).T_M_I * mission.rig.cameras[0].T_I_C *
         Transformation(depth.q_C_D, Eigen::Vector3d::Zero()))
            .matrix();
    CHECK((T_G_D - by_hand).cwiseAbs().maxCoeff() < 1e-12);
    // PointInCamera rotates D's ray into C.
    const Eigen::Vector3d p_C = depth.PointInCamera(10.0, 20.0, 2.0);
    const Eigen::Vector3d p_D(2.0 * (10.0 - depth.cx) / depth.fx, 2.0 * (20.0 - depth.cy) / depth.fy, 2.0);
    CHECK((p_C - depth.q_C_D * p_D).norm() < 1e-12);
  }
  // A frame without a depth map, a camera the vertex does not have.
  testing::PlaneMapOptions none;
  none.depth = false;
  none.vertices = 1;
  const testing::PlaneMap empty = testing::MakePlaneMap(none);
  using Catch::Contains;
  const std::string vertex_hex = empty.vertices[0].Hex();
  CHECK_THAT(InputErrorOf([&] { LoadDepthMap(empty.map, empty.vertices[0], 0); }),
             Contains("vertex " + vertex_hex + " camera 0") && Contains("depth_resource_id"));
  CHECK_THAT(InputErrorOf([&] { LoadDepthMap(m.map, m.vertices[0], 3); }), Contains("camera 3"));
}

TEST_CASE("depth filter: neighbouring views confirm a plane, remove a corrupted pixel", "[depth_map]") {
  const Pinhole k;
  const Plane plane = testing::TiltedPlane();
  const Eigen::Matrix4d T_G_A = testing::LookingForward(Eigen::Vector3d(0.0, 0.0, 0.0), 0.0, 0.0);
  const Eigen::Matrix4d T_G_B = testing::LookingForward(Eigen::Vector3d(0.25, 0.05, 0.0), -0.08, 0.02);
  const Eigen::Matrix4d T_G_B2 = testing::LookingForward(Eigen::Vector3d(-0.2, -0.1, 0.1), 0.06, 0.0);
  // C looks sideways: it sees the plane, but not where A looks.
  const Eigen::Matrix4d T_G_C = testing::LookingForward(Eigen::Vector3d(0.0, 0.0, 0.0), 1.2, 0.0);
  const DepthMap b = PlaneView(k, T_G_B, plane);
  const DepthMap b2 = PlaneView(k, T_G_B2, plane);
  const DepthMap c = PlaneView(k, T_G_C, plane);
  const DepthMap a0 = PlaneView(k, T_G_A, plane);
  REQUIRE(a0.ValidPixels() == k.width * k.height);
  REQUIRE(c.ValidPixels() > 0);
  const int u0 = 80, v0 = 60;  // a pixel every view but C sees
  REQUIRE(Sees(a0, T_G_A, u0, v0, b, T_G_B));
  REQUIRE(Sees(a0, T_G_A, u0, v0, b2, T_G_B2));
  REQUIRE(!Sees(a0, T_G_A, u0, v0, c, T_G_C));

  DepthFilterOptions options;
  options.relative_tolerance = 0.02;  // the 1 % and 3 % errors below straddle it
  REQUIRE(options.Validate().empty());

  SECTION("a consistent neighbour confirms what it sees; the rest is not confirmed") {
    DepthMap a = a0;
    a.depth_m = a0.depth_m.clone();
    const int removed = FilterDepthByNeighbours(&a, T_G_A, {{&b, T_G_B}}, options);
    int expected_removed = 0;
    for (int v = 0; v < k.height; ++v) {
      for (int u = 0; u < k.width; ++u) {
        const bool seen = Sees(a0, T_G_A, u, v, b, T_G_B);
        expected_removed += !seen;
        // Pixels B sees are all kept (the plane is consistent), the others removed.
        if (seen != (a.depth_m.at<float>(v, u) > 0.0f)) FAIL("pixel " << u << ", " << v);
      }
    }
    CHECK(removed == expected_removed);
    CHECK(removed > 0);
    CHECK(removed < k.width * k.height / 2);
    CHECK(a.ValidPixels() == k.width * k.height - removed);
    // Kept depths are unchanged.
    CHECK(a.depth_m.at<float>(v0, u0) == a0.depth_m.at<float>(v0, u0));
  }

  SECTION("a corrupted pixel is removed, a small error within the tolerance kept") {
    DepthMap a = a0;
    a.depth_m = a0.depth_m.clone();
    a.depth_m.at<float>(v0, u0) *= 1.10f;
    a.depth_m.at<float>(v0, u0 + 5) *= 1.01f;
    a.depth_m.at<float>(v0, u0 + 10) *= 0.97f;
    FilterDepthByNeighbours(&a, T_G_A, {{&b, T_G_B}, {&b2, T_G_B2}}, options);
    CHECK(a.depth_m.at<float>(v0, u0) == 0.0f);
    CHECK(a.depth_m.at<float>(v0, u0 + 5) > 0.0f);
    CHECK(a.depth_m.at<float>(v0, u0 + 10) == 0.0f);
    CHECK(a.depth_m.at<float>(v0, u0 + 1) == a0.depth_m.at<float>(v0, u0 + 1));
    // A looser tolerance keeps the 3 % error.
    DepthMap loose = a0;
    loose.depth_m = a0.depth_m.clone();
    loose.depth_m.at<float>(v0, u0 + 10) *= 0.97f;
    DepthFilterOptions loose_options = options;
    loose_options.relative_tolerance = 0.05;
    FilterDepthByNeighbours(&loose, T_G_A, {{&b, T_G_B}}, loose_options);
    CHECK(loose.depth_m.at<float>(v0, u0 + 10) > 0.0f);
  }

  SECTION("a view that does not see the point neither confirms nor refutes it") {
    DepthMap a = a0;
    a.depth_m = a0.depth_m.clone();
    // B confirms, C does not see the pixel: kept.
    FilterDepthByNeighbours(&a, T_G_A, {{&c, T_G_C}, {&b, T_G_B}}, options);
    CHECK(a.depth_m.at<float>(v0, u0) > 0.0f);
    // C alone cannot confirm it.
    DepthMap only_c = a0;
    only_c.depth_m = a0.depth_m.clone();
    FilterDepthByNeighbours(&only_c, T_G_A, {{&c, T_G_C}}, options);
    CHECK(only_c.depth_m.at<float>(v0, u0) == 0.0f);
    // Two confirmations needed: B and B2 give them, B and C do not.
    DepthFilterOptions two = options;
    two.min_consistent_views = 2;
    DepthMap with_b2 = a0;
    with_b2.depth_m = a0.depth_m.clone();
    FilterDepthByNeighbours(&with_b2, T_G_A, {{&b, T_G_B}, {&b2, T_G_B2}}, two);
    CHECK(with_b2.depth_m.at<float>(v0, u0) > 0.0f);
    DepthMap with_c = a0;
    with_c.depth_m = a0.depth_m.clone();
    FilterDepthByNeighbours(&with_c, T_G_A, {{&b, T_G_B}, {&c, T_G_C}}, two);
    CHECK(with_c.depth_m.at<float>(v0, u0) == 0.0f);
    // A view that sees the point but has no depth there does not confirm it either.
    DepthMap holes = b;
    holes.depth_m = cv::Mat(b.depth_m.size(), CV_32FC1, cv::Scalar(0.0f));
    DepthMap with_holes = a0;
    with_holes.depth_m = a0.depth_m.clone();
    CHECK(FilterDepthByNeighbours(&with_holes, T_G_A, {{&holes, T_G_B}}, options) ==
          k.width * k.height);
  }

  SECTION("options") {
    DepthFilterOptions o;
    o.neighbours = -1;
    CHECK_THAT(o.Validate(), Catch::StartsWith("neighbours:"));
    o = DepthFilterOptions();
    o.min_consistent_views = 0;
    CHECK_THAT(o.Validate(), Catch::StartsWith("min_consistent_views:"));
    o = DepthFilterOptions();
    o.relative_tolerance = 0.0;
    CHECK_THAT(o.Validate(), Catch::StartsWith("relative_tolerance:"));
  }
}
