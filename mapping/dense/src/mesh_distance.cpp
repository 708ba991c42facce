#include "vilma/mapping/dense/mesh_distance.h"

#include <algorithm>
#include <cmath>
#include <limits>
#include <unordered_set>

namespace vilma::mapping {

namespace {

double PointSegmentDistance(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                            const Eigen::Vector3d& b) {
  const Eigen::Vector3d ab = b - a;
  const double length2 = ab.squaredNorm();
  const double t = length2 > 0.0 ? std::clamp((p - a).dot(ab) / length2, 0.0, 1.0) : 0.0;
  return (p - (a + t * ab)).norm();
}

}  // namespace

double PointTriangleDistance(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                             const Eigen::Vector3d& b, const Eigen::Vector3d& c) {
  const Eigen::Vector3d ab = b - a, ac = c - a, ap = p - a;
  // A triangle without area (two corners equal, as marching cubes makes where the surface
  // passes a voxel corner, or collinear corners) is its longest edge: the regions below would
  // divide 0 by 0.
  if (ab.cross(ac).squaredNorm() <= 1e-24 * ab.squaredNorm() * ac.squaredNorm()) {
    return std::min({PointSegmentDistance(p, a, b), PointSegmentDistance(p, b, c),
                     PointSegmentDistance(p, c, a)});
  }
  // Closest point by the region of p among the triangle's vertices, edges and face.
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0.0 && d2 <= 0.0) return (p - a).norm();
  const Eigen::Vector3d bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0.0 && d4 <= d3) return (p - b).norm();
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0.0 && d1 >= 0.0 && d3 <= 0.0) return (p - (a + d1 / (d1 - d3) * ab)).norm();
  const Eigen::Vector3d cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0.0 && d5 <= d6) return (p - c).norm();
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0.0 && d2 >= 0.0 && d6 <= 0.0) return (p - (a + d2 / (d2 - d6) * ac)).norm();
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0.0 && (d4 - d3) >= 0.0 && (d5 - d6) >= 0.0) {
    return (p - (b + (d4 - d3) / ((d4 - d3) + (d5 - d6)) * (c - b))).norm();
  }
  const double denom = va + vb + vc;
  if (!(std::abs(denom) > 0.0)) return (p - a).norm();  // degenerate triangle
  const double v = vb / denom, w = vc / denom;
  return (p - (a + v * ab + w * ac)).norm();
}

long long MeshDistanceIndex::Key(long long ix, long long iy, long long iz) const {
  // 21 bits per axis (cells up to +-10^6 apart): plenty for any map at centimetre cells.
  const long long mask = (1ll << 21) - 1;
  return ((ix & mask) << 42) | ((iy & mask) << 21) | (iz & mask);
}

MeshDistanceIndex::MeshDistanceIndex(const TriangleMesh& mesh, double cell_size_m)
    : mesh_(mesh), cell_size_m_(cell_size_m) {
  for (int t = 0; t < static_cast<int>(mesh.triangles.size()); ++t) {
    const Eigen::Vector3i& tri = mesh.triangles[t];
    Eigen::Vector3d lo = mesh.vertices[tri[0]], hi = lo;
    for (int k = 1; k < 3; ++k) {
      lo = lo.cwiseMin(mesh.vertices[tri[k]]);
      hi = hi.cwiseMax(mesh.vertices[tri[k]]);
    }
    const Eigen::Vector3d l = (lo / cell_size_m_).array().floor();
    const Eigen::Vector3d h = (hi / cell_size_m_).array().floor();
    for (long long x = static_cast<long long>(l.x()); x <= static_cast<long long>(h.x()); ++x) {
      for (long long y = static_cast<long long>(l.y()); y <= static_cast<long long>(h.y()); ++y) {
        for (long long z = static_cast<long long>(l.z()); z <= static_cast<long long>(h.z()); ++z) {
          cells_[Key(x, y, z)].push_back(t);
        }
      }
    }
  }
}

double MeshDistanceIndex::Distance(const Eigen::Vector3d& p, double max_distance_m) const {
  const long long r = static_cast<long long>(std::ceil(max_distance_m / cell_size_m_));
  const Eigen::Vector3d c = (p / cell_size_m_).array().floor();
  double best = std::numeric_limits<double>::infinity();
  std::unordered_set<int> seen;
  for (long long x = -r; x <= r; ++x) {
    for (long long y = -r; y <= r; ++y) {
      for (long long z = -r; z <= r; ++z) {
        const auto it = cells_.find(Key(static_cast<long long>(c.x()) + x,
                                        static_cast<long long>(c.y()) + y,
                                        static_cast<long long>(c.z()) + z));
        if (it == cells_.end()) continue;
        for (int t : it->second) {
          if (!seen.insert(t).second) continue;
          const Eigen::Vector3i& tri = mesh_.triangles[t];
          best = std::min(best, PointTriangleDistance(p, mesh_.vertices[tri[0]],
                                                      mesh_.vertices[tri[1]], mesh_.vertices[tri[2]]));
        }
      }
    }
  }
  return best <= max_distance_m ? best : std::numeric_limits<double>::infinity();
}

}  // namespace vilma::mapping
