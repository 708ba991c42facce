// Point-to-mesh distances for judging reconstructions (docs/dense.md): a uniform hash grid of
// the triangles' bounding boxes, queried within a radius; exact point-to-triangle distances
// (closest point on the triangle by its Voronoi regions, Ericson, Real-Time Collision
// Detection, section 5.1.5).
#pragma once

#include <Eigen/Core>
#include <unordered_map>
#include <vector>

#include "vilma/mapping/dense/tsdf_fusion.h"

namespace vilma::mapping {

// Distance [m] from p to the triangle (a, b, c).
double PointTriangleDistance(const Eigen::Vector3d& p, const Eigen::Vector3d& a,
                             const Eigen::Vector3d& b, const Eigen::Vector3d& c);

class MeshDistanceIndex {
 public:
  // `cell_size_m`: grid cell edge; queries are fastest with radii of about one cell. The index
  // refers to `mesh`, which must outlive it.
  MeshDistanceIndex(const TriangleMesh& mesh, double cell_size_m);
  // Distance to the nearest triangle if it is within `max_distance_m`, else +infinity.
  double Distance(const Eigen::Vector3d& p, double max_distance_m) const;

 private:
  const TriangleMesh& mesh_;
  double cell_size_m_;
  std::unordered_map<long long, std::vector<int>> cells_;  // key of (ix, iy, iz) -> triangles
  long long Key(long long ix, long long iy, long long iz) const;
};

}  // namespace vilma::mapping
