// Triangle meshes of dense reconstruction (docs/dense.md): the TSDF's surface, what render_mesh
// draws and eval_mesh judges, and their files (PLY, and what else Open3D reads).
#pragma once

#include <Eigen/Core>
#include <string>
#include <vector>

namespace vilma::mapping {

struct TriangleMesh {
  std::vector<Eigen::Vector3d> vertices;   // [m]
  std::vector<Eigen::Vector3i> triangles;  // vertex indices
  std::vector<Eigen::Vector3d> colors;     // RGB in [0, 1]; empty, or one per vertex
  // Empty if usable, else what is not: no triangle, an index out of range, a non-finite
  // vertex, colours that do not match the vertices.
  std::string Validate() const;
};

// A PLY (or another format Open3D reads: OBJ, OFF) triangle mesh with its vertex colours.
// Throws InputError naming the file when it does not exist, cannot be read, or holds no
// triangle.
TriangleMesh ReadMeshFile(const std::string& path);

// Writes a binary PLY (Open3D's writer: vertices x y z, optional red green blue, faces) into a
// temporary file renamed into place; throws InputError naming the file when it cannot be
// written or the mesh has no vertex.
void WriteMeshPly(const TriangleMesh& mesh, const std::string& path);

}  // namespace vilma::mapping
