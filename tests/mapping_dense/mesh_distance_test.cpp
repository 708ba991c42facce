#include "vilma/mapping/dense/mesh_distance.h"

#include <algorithm>
#include <array>
#include <catch2/catch.hpp>
#include <cmath>
#include <limits>
#include <random>

#include "test_random.h"

using namespace vilma;
using namespace vilma::mapping;

namespace {

// Brute force: the nearest of a dense grid of barycentric samples of the triangle. The true
// distance is at most this and at least this minus the grid's covering radius `*slack`.
double SampledDistance(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                       const Eigen::Vector3d& c, int n, double* slack) {
  double best = std::numeric_limits<double>::infinity();
  for (int i = 0; i <= n; ++i) {
    for (int j = 0; i + j <= n; ++j) {
      const Eigen::Vector3d q = a + (b - a) * (double(i) / n) + (c - a) * (double(j) / n);
      best = std::min(best, (p - q).norm());
    }
  }
  // Every point of the triangle is within a grid cell's diameter of a sample.
  *slack = std::max({(b - a).norm(), (c - a).norm(), (c - b).norm()}) / n;
  return best;
}

double SegmentDistance(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const Eigen::Vector3d ab = b - a;
  const double t = ab.squaredNorm() > 0.0 ? std::clamp((p - a).dot(ab) / ab.squaredNorm(), 0.0, 1.0) : 0.0;
  return (p - (a + t * ab)).norm();
}

// An independent exact reference: the plane distance when p projects inside the triangle,
// else the nearest edge. `region` gets 0 for the face, 1..3 for edges ab, bc, ca and 4..6 for
// the vertices a, b, c.
double ReferenceDistance(const Eigen::Vector3d& p, const Eigen::Vector3d& a, const Eigen::Vector3d& b,
                         const Eigen::Vector3d& c, int* region) {
  const Eigen::Vector3d n = (b - a).cross(c - a);
  const Eigen::Vector3d q = p - n.dot(p - a) / n.squaredNorm() * n;  // projection on the plane
  const double wa = (b - q).cross(c - q).dot(n), wb = (c - q).cross(a - q).dot(n),
               wc = (a - q).cross(b - q).dot(n);
  if (wa >= 0.0 && wb >= 0.0 && wc >= 0.0) {
    *region = 0;
    return (p - q).norm();
  }
  const double d[3] = {SegmentDistance(p, a, b), SegmentDistance(p, b, c), SegmentDistance(p, c, a)};
  const int e = static_cast<int>(std::min_element(d, d + 3) - d);
  *region = 1 + e;
  const Eigen::Vector3d corners[3] = {a, b, c};
  for (int k = 0; k < 3; ++k) {
    if (std::abs((p - corners[k]).norm() - d[e]) < 1e-12) *region = 4 + k;
  }
  return d[e];
}

}  // namespace

TEST_CASE("point-triangle distance: every Voronoi region against references", "[mesh_distance]") {
  std::mt19937_64 rng(3);
  std::normal_distribution<double> n(0.0, 1.0);
  int regions[7] = {0, 0, 0, 0, 0, 0, 0};
  double worst_reference = 0.0;
  for (int t = 0; t < 60; ++t) {
    const auto draw = [&] { return n(rng); };
    const Eigen::Vector3d a = vilma::testing::DrawVector3(draw);
    const Eigen::Vector3d b = vilma::testing::DrawVector3(draw);
    const Eigen::Vector3d c = vilma::testing::DrawVector3(draw);
    if ((b - a).cross(c - a).norm() < 0.05) continue;  // too thin for the sampled reference
    for (int s = 0; s < 40; ++s) {
      const Eigen::Vector3d p = (a + b + c) / 3.0 + 1.5 * vilma::testing::DrawVector3(draw);
      const double d = PointTriangleDistance(p, a, b, c);
      int region = -1;
      const double reference = ReferenceDistance(p, a, b, c, &region);
      ++regions[region];
      worst_reference = std::max(worst_reference, std::abs(d - reference));
      CHECK(d == Approx(reference).margin(1e-9));
      // The vertex order does not matter.
      CHECK(PointTriangleDistance(p, b, c, a) == Approx(d).margin(1e-9));
      CHECK(PointTriangleDistance(p, c, b, a) == Approx(d).margin(1e-9));
      if (s % 8 == 0) {
        double slack = 0.0;
        const double sampled = SampledDistance(p, a, b, c, 300, &slack);
        CHECK(d <= sampled + 1e-12);
        CHECK(d >= sampled - slack);
      }
    }
  }
  INFO("worst difference to the reference " << worst_reference);
  for (int r = 0; r < 7; ++r) {
    INFO("region " << r);
    CHECK(regions[r] >= 20);
  }
  // Points on the triangle, and straight above its face.
  const Eigen::Vector3d a(0, 0, 0), b(2, 0, 0), c(0, 1, 0);
  CHECK(PointTriangleDistance(a, a, b, c) == 0.0);
  CHECK(PointTriangleDistance(Eigen::Vector3d(0.5, 0.25, 0), a, b, c) == 0.0);
  CHECK(PointTriangleDistance(Eigen::Vector3d(0.5, 0.25, -0.3), a, b, c) == Approx(0.3));
  CHECK(PointTriangleDistance(Eigen::Vector3d(-1, -1, 0), a, b, c) == Approx(std::sqrt(2.0)));
  CHECK(PointTriangleDistance(Eigen::Vector3d(3, 0, 1), a, b, c) == Approx(std::sqrt(2.0)));
  CHECK(PointTriangleDistance(Eigen::Vector3d(1, -2, 0), a, b, c) == Approx(2.0));
}

TEST_CASE("point-triangle distance of degenerate triangles: the nearest of their segments",
          "[mesh_distance]") {
  const Eigen::Vector3d a(0, 0, 0), b(2, 0, 0), m(1, 0, 0);
  const Eigen::Vector3d p(0.5, 1.0, 0.0);
  // Two corners equal (marching cubes makes these when the surface passes a voxel corner),
  // collinear corners, and all three equal.
  for (const auto& t : {std::array<Eigen::Vector3d, 3>{a, a, b}, std::array<Eigen::Vector3d, 3>{a, b, b},
                        std::array<Eigen::Vector3d, 3>{a, b, a}, std::array<Eigen::Vector3d, 3>{a, m, b},
                        std::array<Eigen::Vector3d, 3>{a, b, m}, std::array<Eigen::Vector3d, 3>{m, a, b}}) {
    const double d = PointTriangleDistance(p, t[0], t[1], t[2]);
    CHECK(d == Approx(1.0));
    CHECK(PointTriangleDistance(Eigen::Vector3d(-1, 0, 0), t[0], t[1], t[2]) == Approx(1.0));
    CHECK(PointTriangleDistance(Eigen::Vector3d(3, 0, 1), t[0], t[1], t[2]) == Approx(std::sqrt(2.0)));
  }
  CHECK(PointTriangleDistance(p, m, m, m) == Approx((p - m).norm()));
}

TEST_CASE("mesh distance index: brute force within the radius, infinity beyond", "[mesh_distance]") {
  // A wavy sheet of triangles across the origin (negative cell indices too), plus loose
  // triangles of varied sizes, one of them degenerate.
  TriangleMesh mesh;
  const int nx = 30, ny = 20;
  for (int j = 0; j <= ny; ++j) {
    for (int i = 0; i <= nx; ++i) {
      const double x = -1.5 + 0.1 * i, y = -1.0 + 0.1 * j;
      mesh.vertices.push_back({x, y, 0.1 * std::sin(3.0 * x) * std::cos(2.0 * y)});
    }
  }
  for (int j = 0; j < ny; ++j) {
    for (int i = 0; i < nx; ++i) {
      const int v = j * (nx + 1) + i;
      mesh.triangles.push_back({v, v + 1, v + nx + 2});
      mesh.triangles.push_back({v, v + nx + 2, v + nx + 1});
    }
  }
  std::mt19937_64 rng(9);
  std::normal_distribution<double> n(0.0, 1.0);
  for (int t = 0; t < 40; ++t) {
    // z, y, x: the order GCC drew them in (tests/test_random.h).
    const double z = 0.5 + std::abs(n(rng));
    const double y = 1.5 * n(rng);
    const double x = 1.5 * n(rng);
    const Eigen::Vector3d centre(x, y, z);
    const double size = 0.02 + 0.5 * std::abs(n(rng));
    const int base = static_cast<int>(mesh.vertices.size());
    for (int k = 0; k < 3; ++k) {
      mesh.vertices.push_back(centre + size * vilma::testing::DrawVector3([&] { return n(rng); }));
    }
    mesh.triangles.push_back({base, base + 1, base + 2});
  }
  const int base = static_cast<int>(mesh.vertices.size());
  mesh.vertices.push_back({0.3, 0.3, -0.8});
  mesh.vertices.push_back({0.7, 0.5, -0.8});
  mesh.triangles.push_back({base, base, base + 1});

  auto brute = [&](const Eigen::Vector3d& p) {
    double best = std::numeric_limits<double>::infinity();
    for (const Eigen::Vector3i& t : mesh.triangles) {
      best = std::min(best, PointTriangleDistance(p, mesh.vertices[t[0]], mesh.vertices[t[1]],
                                                  mesh.vertices[t[2]]));
    }
    return best;
  };

  for (const double cell : {0.05, 0.13, 0.5}) {
    const MeshDistanceIndex index(mesh, cell);
    int within = 0, beyond = 0;
    for (int q = 0; q < 400; ++q) {
      const double z = 0.8 * n(rng);  // z, y, x, as GCC drew them
      const double y = 1.2 * n(rng);
      const double x = 1.2 * n(rng);
      const Eigen::Vector3d p(x, y, z);
      const double radius = q % 2 == 0 ? 0.1 : 0.37;
      const double expected = brute(p);
      const double d = index.Distance(p, radius);
      if (expected <= radius) {
        ++within;
        CHECK(d == expected);
      } else {
        ++beyond;
        CHECK(d == std::numeric_limits<double>::infinity());
      }
    }
    INFO("cell " << cell << ": " << within << " within, " << beyond << " beyond");
    CHECK(within > 50);
    CHECK(beyond > 50);
  }
  // The degenerate triangle is the nearest below the sheet.
  const MeshDistanceIndex index(mesh, 0.1);
  CHECK(index.Distance(Eigen::Vector3d(0.5, 0.4, -0.85), 0.2) == Approx(0.05));
  // An empty mesh: nothing within any radius.
  const TriangleMesh empty;
  CHECK(MeshDistanceIndex(empty, 0.1).Distance(Eigen::Vector3d::Zero(), 1.0) ==
        std::numeric_limits<double>::infinity());
}
