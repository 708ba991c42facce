// AttachTrueDepth on a hand-built world (one tilted quad wall in front of the camera) and a
// one-vertex map (tests/mapping_dense/dense_test_util.h): each pixel's depth is the wall's
// analytic depth (ray-plane intersection, within half a depth unit), pixels that miss the wall
// or lie beyond max_depth_m have none, a camera the rig lacks is an InputError, and the
// resource ids are deterministic.
#include "vilma/mapping/evaluation/true_depth.h"

#include <catch2/catch.hpp>
#include <cmath>

#include "mapping_dense/dense_test_util.h"
#include "vilma/core/error.h"
#include "vilma/mapping/dense/depth_map.h"

namespace vilma::mapping {
namespace {

using testing::MakePlaneMap;
using testing::PlaneMap;
using testing::PlaneMapOptions;

// The wall: x in [-1.2, 0.6], y in [-0.5, 0.6] of G, rising from z = 1.9 to 2.35 with x; its
// normal edge_u x edge_v = (0.495, 0, -1.98) faces the camera (at z = 0, looking along +z).
// Narrower than the view: the pixels at the image borders miss it.
struct Wall {
  Eigen::Vector3d origin{-1.2, -0.5, 1.9};
  Eigen::Vector3d edge_u{0.0, 1.1, 0.0};
  Eigen::Vector3d edge_v{1.8, 0.0, 0.45};  // perpendicular to edge_u
};

sim::World WallWorld(const Wall& wall = {}) {
  sim::World world;
  world.name = "wall";
  world.AddQuad(wall.origin, wall.edge_u, wall.edge_v, 0.05, 7, 128.0);
  return world;
}

// One vertex, no depth yet; camera 0's view (q_C_D identity) has pose PlaneViewPose(0).
PlaneMap OneVertexMap() {
  PlaneMapOptions o;
  o.vertices = 1;
  o.depth = false;
  o.q_C_D = Eigen::Quaterniond::Identity();
  return MakePlaneMap(o);
}

// The wall's depth (along the view's z) at pixel (u, v) of a pinhole view with pose T_G_D, or
// 0 where the ray misses it; `near_edge` is set where the hit lies within 1e-4 of the wall's
// border (either answer is right there).
double AnalyticDepth(const DepthMap& k, const Eigen::Matrix4d& T_G_D, const Wall& wall, int u, int v,
                     bool* near_edge) {
  const Eigen::Vector3d ray_G =
      T_G_D.topLeftCorner<3, 3>() * Eigen::Vector3d((u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0);
  const Eigen::Vector3d o_G = T_G_D.topRightCorner<3, 1>();
  const Eigen::Vector3d n = wall.edge_u.cross(wall.edge_v);
  const double z = n.dot(wall.origin - o_G) / n.dot(ray_G);  // ray_G has unit z in D
  const Eigen::Vector3d r = o_G + z * ray_G - wall.origin;
  const double s = r.dot(wall.edge_u) / wall.edge_u.squaredNorm();
  const double t = r.dot(wall.edge_v) / wall.edge_v.squaredNorm();
  *near_edge = std::min({std::abs(s), std::abs(s - 1.0), std::abs(t), std::abs(t - 1.0)}) < 1e-4;
  return z > 0.0 && s >= 0.0 && s <= 1.0 && t >= 0.0 && t <= 1.0 ? z : 0.0;
}

struct Comparison {
  int hits = 0, misses = 0, beyond = 0;  // pixels checked of each kind
  double max_error_m = 0.0;              // over the hits
  int wrong = 0;                         // pixels with depth where none belongs, or none where some does
  double min_depth = 1e9, max_depth = 0.0;
};

Comparison Compare(const DepthMap& depth, const Eigen::Matrix4d& T_G_D, const Wall& wall,
                   double max_depth_m, double tolerance_m) {
  Comparison c;
  for (int v = 0; v < depth.height(); ++v) {
    for (int u = 0; u < depth.width(); ++u) {
      bool near_edge = false;
      const double expected = AnalyticDepth(depth, T_G_D, wall, u, v, &near_edge);
      if (near_edge || std::abs(expected - max_depth_m) < 1e-4) continue;
      const double got = depth.depth_m.at<float>(v, u);
      if (expected == 0.0) {
        ++c.misses;
        c.wrong += got != 0.0;
      } else if (expected > max_depth_m) {
        ++c.beyond;
        c.wrong += got != 0.0;
      } else {
        ++c.hits;
        c.min_depth = std::min(c.min_depth, expected);
        c.max_depth = std::max(c.max_depth, expected);
        if (got == 0.0) {
          ++c.wrong;
        } else {
          c.max_error_m = std::max(c.max_error_m, std::abs(got - expected));
          c.wrong += std::abs(got - expected) > tolerance_m;
        }
      }
    }
  }
  return c;
}

TEST_CASE("true depth: a wall's analytic depth, none where the rays miss it", "[true_depth]") {
  PlaneMap m = OneVertexMap();
  const Wall wall;
  const sim::World world = WallWorld(wall);
  TrueDepthOptions options;
  REQUIRE(options.Validate().empty());
  CHECK(AttachTrueDepth(&m.map, {}, world, options) == 1);

  const mapstore::ResourceId id = m.map.vertex(m.vertices[0]).frames[0].depth_resource_id;
  REQUIRE(id.IsValid());
  CHECK(m.map.resources().Has(mapstore::ResourceType::kDepthMap, id));
  const DepthMap depth = LoadDepthMap(m.map, m.vertices[0], 0);
  // The camera's own (distortion-free) pinhole, no rotation against the camera.
  const testing::Pinhole k;
  CHECK(depth.width() == k.width);
  CHECK(depth.height() == k.height);
  CHECK(depth.fx == Approx(k.fx));
  CHECK(depth.fy == Approx(k.fy));
  CHECK(depth.cx == Approx(k.cx));
  CHECK(depth.cy == Approx(k.cy));
  CHECK(depth.q_C_D.angularDistance(Eigen::Quaterniond::Identity()) < 1e-12);
  const Eigen::Matrix4d T_G_D = DepthViewPose(m.map, m.vertices[0], 0, depth);
  CHECK((T_G_D - m.T_G_D[0]).norm() < 1e-9);

  const Comparison c = Compare(depth, m.T_G_D[0], wall, options.max_depth_m,
                               options.depth_unit_m / 2.0 + 1e-6);
  INFO("hits " << c.hits << ", misses " << c.misses << ", max error " << c.max_error_m
               << " m, depth " << c.min_depth << " .. " << c.max_depth << " m");
  CHECK(c.wrong == 0);
  CHECK(c.max_error_m <= options.depth_unit_m / 2.0 + 1e-6);
  // Most of the image sees the wall, its borders do not.
  CHECK(c.hits > depth.width() * depth.height() / 2);
  CHECK(c.misses > 500);
  CHECK(c.min_depth < 2.0);
  CHECK(c.max_depth > 2.2);
  CHECK(depth.ValidPixels() >= c.hits);
  CHECK(depth.ValidPixels() <= depth.width() * depth.height() - c.misses);

  // A coarser depth unit: still within half of it.
  PlaneMap coarse = OneVertexMap();
  options.depth_unit_m = 0.01;
  CHECK(AttachTrueDepth(&coarse.map, {}, world, options) == 1);
  const Comparison cc = Compare(LoadDepthMap(coarse.map, coarse.vertices[0], 0), coarse.T_G_D[0],
                                wall, options.max_depth_m, 0.005 + 1e-6);
  CHECK(cc.wrong == 0);
  CHECK(cc.max_error_m > 0.001);  // coarser than the default unit indeed
}

TEST_CASE("true depth: max_depth_m drops the farther part of the wall", "[true_depth]") {
  PlaneMap m = OneVertexMap();
  const Wall wall;
  TrueDepthOptions options;
  options.max_depth_m = 2.1;
  CHECK(AttachTrueDepth(&m.map, {m.mission}, WallWorld(wall), options) == 1);
  const DepthMap depth = LoadDepthMap(m.map, m.vertices[0], 0);
  const Comparison c = Compare(depth, m.T_G_D[0], wall, options.max_depth_m,
                               options.depth_unit_m / 2.0 + 1e-6);
  INFO("hits " << c.hits << ", beyond " << c.beyond << ", misses " << c.misses);
  CHECK(c.wrong == 0);
  CHECK(c.hits > 1000);
  CHECK(c.beyond > 1000);
  double deepest = 0.0;
  for (int v = 0; v < depth.height(); ++v) {
    for (int u = 0; u < depth.width(); ++u) deepest = std::max(deepest, double(depth.depth_m.at<float>(v, u)));
  }
  CHECK(deepest <= 2.1 + 1e-6);
  CHECK(deepest > 2.09);

  // Nothing within reach: every pixel without depth (the map still gets a depth map).
  PlaneMap far = OneVertexMap();
  options.max_depth_m = 1.0;
  CHECK(AttachTrueDepth(&far.map, {}, WallWorld(wall), options) == 1);
  CHECK(LoadDepthMap(far.map, far.vertices[0], 0).ValidPixels() == 0);
}

TEST_CASE("true depth: invalid options and a camera beyond the rig", "[true_depth]") {
  PlaneMap m = OneVertexMap();
  const sim::World world = WallWorld();
  const std::size_t resources = m.map.resources().List().size();
  TrueDepthOptions options;
  options.cameras = {1};  // the rig has one camera
  CHECK_THROWS_AS(AttachTrueDepth(&m.map, {}, world, options), InputError);
  try {
    AttachTrueDepth(&m.map, {}, world, options);
  } catch (const InputError& e) {
    CHECK_THAT(e.what(), Catch::Contains("expected indices below 1, found 1"));
  }
  options.cameras = {0, 1};  // one bad index: nothing is attached
  CHECK_THROWS_AS(AttachTrueDepth(&m.map, {}, world, options), InputError);
  CHECK(!m.map.vertex(m.vertices[0]).frames[0].depth_resource_id.IsValid());
  CHECK(m.map.resources().List().size() == resources);

  options = TrueDepthOptions();
  options.cameras = {};
  CHECK_THAT(options.Validate(), Catch::StartsWith("cameras:"));
  CHECK_THROWS_AS(AttachTrueDepth(&m.map, {}, world, options), InputError);
  options.cameras = {-1};
  CHECK_THAT(options.Validate(), Catch::StartsWith("cameras:"));
  options = TrueDepthOptions();
  options.max_depth_m = 0.0;
  CHECK_THAT(options.Validate(), Catch::StartsWith("max_depth_m:"));
  options = TrueDepthOptions();
  options.max_depth_m = 100.0;  // 100000 mm do not fit 16 bits
  CHECK_THAT(options.Validate(), Catch::StartsWith("depth_unit_m:"));
  options.depth_unit_m = 0.002;
  CHECK(options.Validate().empty());
  CHECK(!m.map.vertex(m.vertices[0]).frames[0].depth_resource_id.IsValid());
}

TEST_CASE("true depth: deterministic resource ids", "[true_depth]") {
  const sim::World world = WallWorld();
  PlaneMap a = OneVertexMap(), b = OneVertexMap();
  const TrueDepthOptions options;
  AttachTrueDepth(&a.map, {}, world, options);
  AttachTrueDepth(&b.map, {}, world, options);
  const mapstore::ResourceId id_a = a.map.vertex(a.vertices[0]).frames[0].depth_resource_id;
  const mapstore::ResourceId id_b = b.map.vertex(b.vertices[0]).frames[0].depth_resource_id;
  REQUIRE(id_a.IsValid());
  CHECK(id_a == id_b);
  CHECK(*a.map.resources().Load(mapstore::ResourceType::kDepthMap, id_a) ==
        *b.map.resources().Load(mapstore::ResourceType::kDepthMap, id_b));
  // Again on the same map: the same resource, replaced in place.
  const std::size_t resources = a.map.resources().List().size();
  AttachTrueDepth(&a.map, {}, world, options);
  CHECK(a.map.vertex(a.vertices[0]).frames[0].depth_resource_id == id_a);
  CHECK(a.map.resources().List().size() == resources);
  // Other depth (another unit): another id.
  TrueDepthOptions coarse;
  coarse.depth_unit_m = 0.01;
  AttachTrueDepth(&b.map, {}, world, coarse);
  CHECK(b.map.vertex(b.vertices[0]).frames[0].depth_resource_id != id_a);
}

}  // namespace
}  // namespace vilma::mapping
