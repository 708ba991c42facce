// Off-screen pictures of triangle meshes (the console's `render_mesh`, docs/dense.md "Mesh
// pictures"): a small software rasterizer, because Open3D's Debian build cannot render without
// a display. Pinhole camera looking at the mesh's bounding box from a named view, z-buffer,
// Lambert shading by the normal with a headlight (a directional light along the viewing axis)
// plus ambient, flat (per triangle) or Gouraud (per vertex normal, colours interpolated
// perspective-correctly); vertex colours multiply the shade.
// White background. Deterministic: the same mesh and options give the same pixels.
//
// World frame: the mesh's (vilma's G: z up). Camera frame C: x right, y down, z forward
// (OpenCV). A pixel (u, v) covers [u - 0.5, u + 0.5] x [v - 0.5, v + 0.5] around its centre
// (u, v); a triangle shades the pixels whose centres it covers.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "vilma/core/geometry.h"
#include "vilma/mapping/dense/triangle_mesh.h"

namespace vilma::mapping {


struct MeshRenderOptions {
  int width_px = 1024;
  int height_px = 768;
  // "auto": a 3/4 view from above (azimuth -60 deg, elevation 35 deg); "top": straight down
  // (x right, y up in the picture); "front": from -y looking along +y (x right, z up); "side":
  // from +x looking along -x (y right, z up); "custom": from azimuth_deg / elevation_deg.
  std::string view = "auto";
  // "custom" only: direction from the bounding box centre to the camera, azimuth from +x
  // towards +y in the x-y plane, elevation above it [deg].
  double azimuth_deg = -60.0;
  double elevation_deg = 35.0;
  // Field of view across the smaller image side [deg] (the focal length); the camera looks at
  // the bounding box centre from as close as it can with the whole mesh in the picture (5 %
  // margin).
  double fov_deg = 45.0;
  std::string shading = "gouraud";  // "flat" (a normal per triangle) or "gouraud"
  // shade = ambient + (1 - ambient) |n . l|, l the viewing axis (two-sided), in [0, 1]
  double ambient = 0.25;
  // RGB of meshes without vertex colours, in [0, 1].
  Eigen::Vector3d color = Eigen::Vector3d(0.80, 0.80, 0.82);
  std::string Validate() const;  // empty if valid, else "field: expectation"
};

// The camera a view gives: pinhole intrinsics and the world-to-camera transform.
struct MeshRenderCamera {
  double fx = 0.0, fy = 0.0, cx = 0.0, cy = 0.0;  // [px]
  Transformation T_C_W;
  Eigen::Vector3d p_W_C = Eigen::Vector3d::Zero();  // camera centre
  // Pixel of a point in W; false behind the camera (z <= 0).
  bool Project(const Eigen::Vector3d& p_W, Eigen::Vector2d* uv) const;
};

// Camera for `mesh` (Validate()d) and `options`.
MeshRenderCamera MakeMeshRenderCamera(const TriangleMesh& mesh, const MeshRenderOptions& options);

struct MeshRenderResult {
  cv::Mat image;  // CV_8UC3, BGR
  MeshRenderCamera camera;
  int64_t triangles_drawn = 0;   // that covered at least one pixel centre
  int64_t triangles_culled = 0;  // behind the camera or degenerate in the picture
  int64_t pixels_covered = 0;    // not background
  std::string BriefReport() const;
  std::string FullReport() const;  // the brief report as a line (what the command prints)
};

// Renders `mesh`. Throws std::invalid_argument for invalid options or an unusable mesh.
MeshRenderResult RenderMeshImage(const TriangleMesh& mesh, const MeshRenderOptions& options);

// The triangles whose three vertices lie at or below z_m (a room's ceiling cut off so that its
// inside shows from above); unused vertices are kept.
TriangleMesh ClipAboveZ(const TriangleMesh& mesh, double z_m);


// Writes `image` as PNG atomically (temporary file + rename). Throws InputError naming `path`.
void WritePngAtomically(const std::string& path, const cv::Mat& image);

}  // namespace vilma::mapping
