#include "vilma/mapping/dense/triangle_mesh.h"

#include <cstring>
#include <filesystem>
#include <open3d/geometry/TriangleMesh.h>
#include <open3d/io/TriangleMeshIO.h>

#include "vilma/core/atomic_file.h"
#include "vilma/core/error.h"

namespace vilma::mapping {

std::string TriangleMesh::Validate() const {
  if (triangles.empty()) return "triangles: expected at least one triangle";
  for (const Eigen::Vector3d& v : vertices) {
    if (!v.allFinite()) return "vertices: expected finite coordinates";
  }
  const int n = static_cast<int>(vertices.size());
  for (std::size_t i = 0; i < triangles.size(); ++i) {
    const Eigen::Vector3i& t = triangles[i];
    if (t.minCoeff() < 0 || t.maxCoeff() >= n) {
      return "triangles: triangle " + std::to_string(i) + " has a vertex index outside [0, " +
             std::to_string(n) + ")";
    }
  }
  if (!colors.empty() && colors.size() != vertices.size()) {
    return "colors: expected none or one per vertex (" + std::to_string(vertices.size()) +
           "), got " + std::to_string(colors.size());
  }
  return "";
}

TriangleMesh ReadMeshFile(const std::string& path) {
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) {
    throw InputError(FormatInputError(path, "", "an existing mesh file (PLY, OBJ, OFF)"));
  }
  open3d::geometry::TriangleMesh o3d_mesh;
  if (!open3d::io::ReadTriangleMesh(path, o3d_mesh)) {
    throw InputError(FormatInputError(path, "", "a triangle mesh Open3D can read (PLY, OBJ, OFF)"));
  }
  if (o3d_mesh.triangles_.empty()) {
    throw InputError(FormatInputError(path, "faces",
                                      "triangles; found " +
                                          std::to_string(o3d_mesh.vertices_.size()) +
                                          " vertices and no triangle (a point cloud?)"));
  }
  TriangleMesh mesh;
  mesh.vertices = o3d_mesh.vertices_;
  mesh.triangles = o3d_mesh.triangles_;
  if (o3d_mesh.HasVertexColors()) mesh.colors = o3d_mesh.vertex_colors_;
  const std::string problem = mesh.Validate();
  if (!problem.empty()) throw InputError(FormatInputError(path, "", problem));
  return mesh;
}

void WriteMeshPly(const TriangleMesh& mesh, const std::string& path) {
  // Open3D's writer refuses a mesh without vertices: say so, not "not writable".
  if (mesh.vertices.empty()) throw InputError(path + ": expected a mesh to write, found no vertices");
  open3d::geometry::TriangleMesh o3d;
  o3d.vertices_ = mesh.vertices;
  o3d.triangles_ = mesh.triangles;
  o3d.vertex_colors_ = mesh.colors;
  // Written beside the target and renamed into place: a reader never sees half a file.
  const std::string partial = path + ".partial.ply";
  const bool written = open3d::io::WriteTriangleMesh(partial, o3d, /*write_ascii=*/false,
                                                      /*compressed=*/false,
                                                      /*write_vertex_normals=*/false,
                                                      /*write_vertex_colors=*/!mesh.colors.empty(),
                                                      /*write_triangle_uvs=*/false);
  std::error_code ec;
  if (!written) {
    std::filesystem::remove(partial, ec);
    throw InputError(path + ": expected a writable file for the mesh (PLY)");
  }
  // fsync, rename, fsync of the folder (core's one atomic writer; the partial file is removed
  // when that fails).
  if (const int err = TryCommitFileAtomically(partial, path); err != 0) {
    throw InputError(path + ": expected a writable file for the mesh (PLY): " +
                     std::strerror(err));
  }
}

}  // namespace vilma::mapping
