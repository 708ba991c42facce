#include "vilma/mapping/dense/mesh_render.h"


#include <algorithm>
#include <cmath>
#include <filesystem>
#include <limits>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <stdexcept>

#include "vilma/core/atomic_file.h"
#include "vilma/core/error.h"

namespace vilma::mapping {
namespace {

constexpr double kDegToRad = M_PI / 180.0;

// Twice the signed area of the screen triangle (a, b, p): > 0 when p is left of a -> b in a
// y-down picture seen as x right, i.e. the edge function of Pineda (SIGGRAPH 1988).
double Edge(const Eigen::Vector2d& a, const Eigen::Vector2d& b, const Eigen::Vector2d& p) {
  return (b.x() - a.x()) * (p.y() - a.y()) - (b.y() - a.y()) * (p.x() - a.x());
}

// Unit normal of triangle t (zero for a degenerate one).
Eigen::Vector3d FaceNormal(const TriangleMesh& mesh, const Eigen::Vector3i& t) {
  const Eigen::Vector3d& a = mesh.vertices[static_cast<std::size_t>(t[0])];
  const Eigen::Vector3d& b = mesh.vertices[static_cast<std::size_t>(t[1])];
  const Eigen::Vector3d& c = mesh.vertices[static_cast<std::size_t>(t[2])];
  const Eigen::Vector3d n = (b - a).cross(c - a);
  const double norm = n.norm();
  return norm > 0.0 ? Eigen::Vector3d(n / norm) : Eigen::Vector3d::Zero();
}

Eigen::Vector3d BaseColor(const TriangleMesh& mesh, const MeshRenderOptions& options, int vertex) {
  return mesh.colors.empty() ? options.color
                                    : mesh.colors[static_cast<std::size_t>(vertex)];
}

// Lambert with a headlight, a directional light along the viewing axis (OpenGL's light in eye
// space along -z): ambient + (1 - ambient) |n . l|, l the unit direction to the camera (two-sided:
// meshes from marching cubes face either way). Flat faces get one shade.
double Shade(const Eigen::Vector3d& n, const Eigen::Vector3d& l, double ambient) {
  return ambient + (1.0 - ambient) * std::abs(n.dot(l));
}

}  // namespace

std::string MeshRenderOptions::Validate() const {
  if (width_px < 8 || width_px > 16384) return "width_px: expected 8 .. 16384";
  if (height_px < 8 || height_px > 16384) return "height_px: expected 8 .. 16384";
  if (view != "auto" && view != "top" && view != "front" && view != "side" && view != "custom") {
    return "view: expected auto, top, front, side or custom, got \"" + view + "\"";
  }
  if (!std::isfinite(azimuth_deg)) return "azimuth_deg: expected a finite angle [deg]";
  if (!std::isfinite(elevation_deg) || std::abs(elevation_deg) > 90.0) {
    return "elevation_deg: expected -90 .. 90 [deg]";
  }
  if (!(fov_deg >= 1.0 && fov_deg <= 170.0)) return "fov_deg: expected 1 .. 170 [deg]";
  if (shading != "flat" && shading != "gouraud") {
    return "shading: expected flat or gouraud, got \"" + shading + "\"";
  }
  if (!(ambient >= 0.0 && ambient <= 1.0)) return "ambient: expected 0 .. 1";
  if (!color.allFinite() || color.minCoeff() < 0.0 || color.maxCoeff() > 1.0) {
    return "color: expected RGB in [0, 1]";
  }
  return "";
}

bool MeshRenderCamera::Project(const Eigen::Vector3d& p_W, Eigen::Vector2d* uv) const {
  const Eigen::Vector3d p_C = T_C_W * p_W;
  if (p_C.z() <= 0.0) return false;
  *uv = Eigen::Vector2d(fx * p_C.x() / p_C.z() + cx, fy * p_C.y() / p_C.z() + cy);
  return true;
}

MeshRenderCamera MakeMeshRenderCamera(const TriangleMesh& mesh, const MeshRenderOptions& options) {
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (const Eigen::Vector3i& t : mesh.triangles) {
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d& v = mesh.vertices[static_cast<std::size_t>(t[k])];
      lo = lo.cwiseMin(v);
      hi = hi.cwiseMax(v);
    }
  }
  const Eigen::Vector3d centre = 0.5 * (lo + hi);
  double radius = 0.5 * (hi - lo).norm();
  if (!(radius > 0.0)) radius = 1.0;

  double azimuth_deg = options.azimuth_deg, elevation_deg = options.elevation_deg;
  if (options.view == "auto") {
    azimuth_deg = -60.0;  // not -45: the two side faces of a box would get the same shade
    elevation_deg = 35.0;
  } else if (options.view == "top") {
    azimuth_deg = -90.0;
    elevation_deg = 90.0;
  } else if (options.view == "front") {
    azimuth_deg = -90.0;
    elevation_deg = 0.0;
  } else if (options.view == "side") {
    azimuth_deg = 0.0;
    elevation_deg = 0.0;
  }
  const double az = azimuth_deg * kDegToRad, el = elevation_deg * kDegToRad;
  // Unit direction from the centre to the camera.
  const Eigen::Vector3d d(std::cos(el) * std::cos(az), std::cos(el) * std::sin(az), std::sin(el));
  const double half_fov = 0.5 * options.fov_deg * kDegToRad;
  // Camera axes in W: z forward (to the centre), x right, y down. Picture up is +z in W, or,
  // looking (almost) straight down or up, the horizontal direction away from the camera
  // (+y for "top").
  const Eigen::Vector3d z_W = -d;
  Eigen::Vector3d up_W(0.0, 0.0, 1.0);
  if (std::abs(z_W.dot(up_W)) > 0.999) {
    up_W = Eigen::Vector3d(-std::cos(az), -std::sin(az), 0.0) * (z_W.z() < 0 ? 1.0 : -1.0);
  }
  const Eigen::Vector3d x_W = z_W.cross(up_W).normalized();
  const Eigen::Vector3d y_W = z_W.cross(x_W);
  const double f =
      0.5 * static_cast<double>(std::min(options.width_px, options.height_px)) / std::tan(half_fov);

  // Distance from the centre: the smallest D at which every vertex of a triangle projects
  // inside the picture with a 5 % margin (a vertex o from the centre is at depth D + o.z and
  // |f (o.x) / (D + o.z)| <= 0.95 w / 2, likewise for y), and at least r / 20 in front of the
  // camera. Projection keeps convexity, so the triangles between the vertices are in too.
  const double half_w = 0.95 * 0.5 * static_cast<double>(options.width_px);
  const double half_h = 0.95 * 0.5 * static_cast<double>(options.height_px);
  double distance = 0.0;
  for (const Eigen::Vector3i& t : mesh.triangles) {
    for (int k = 0; k < 3; ++k) {
      const Eigen::Vector3d o = mesh.vertices[static_cast<std::size_t>(t[k])] - centre;
      const double oz = o.dot(z_W);
      distance = std::max({distance, f * std::abs(o.dot(x_W)) / half_w - oz,
                           f * std::abs(o.dot(y_W)) / half_h - oz, 0.05 * radius - oz});
    }
  }

  MeshRenderCamera camera;
  camera.p_W_C = centre + distance * d;
  Eigen::Matrix3d R_W_C;
  R_W_C.col(0) = x_W;
  R_W_C.col(1) = y_W;
  R_W_C.col(2) = z_W;
  camera.T_C_W = Transformation(R_W_C, camera.p_W_C).inverse();
  camera.fx = camera.fy = f;
  camera.cx = 0.5 * static_cast<double>(options.width_px - 1);
  camera.cy = 0.5 * static_cast<double>(options.height_px - 1);
  return camera;
}

std::string MeshRenderResult::BriefReport() const {
  std::ostringstream s;
  s << image.cols << " x " << image.rows << " px, " << triangles_drawn << " triangles drawn, "
    << triangles_culled << " culled, " << pixels_covered << " pixels covered ("
    << (image.total() > 0
            ? 100.0 * static_cast<double>(pixels_covered) / static_cast<double>(image.total())
            : 0.0)
    << " %)";
  return s.str();
}

std::string MeshRenderResult::FullReport() const { return BriefReport() + "\n"; }

TriangleMesh ClipAboveZ(const TriangleMesh& mesh, double z_m) {
  TriangleMesh clipped = mesh;
  clipped.triangles.clear();
  for (const Eigen::Vector3i& t : mesh.triangles) {
    bool below = true;
    for (int k = 0; k < 3; ++k) below = below && mesh.vertices[static_cast<std::size_t>(t[k])].z() <= z_m;
    if (below) clipped.triangles.push_back(t);
  }
  return clipped;
}

MeshRenderResult RenderMeshImage(const TriangleMesh& mesh, const MeshRenderOptions& options) {
  std::string problem = options.Validate();
  if (!problem.empty()) throw std::invalid_argument("render mesh: options: " + problem);
  problem = mesh.Validate();
  if (!problem.empty()) throw std::invalid_argument("render mesh: mesh: " + problem);

  MeshRenderResult result;
  result.camera = MakeMeshRenderCamera(mesh, options);
  const MeshRenderCamera& cam = result.camera;
  const int w = options.width_px, h = options.height_px;
  const bool flat = options.shading == "flat";
  // Towards the camera along its axis: -z of C in W.
  const Eigen::Vector3d l_W = -(cam.T_C_W.rotation().conjugate() * Eigen::Vector3d::UnitZ());

  // Vertices in C and their pixels.
  const std::size_t nv = mesh.vertices.size();
  std::vector<Eigen::Vector3d> p_C(nv);
  std::vector<Eigen::Vector2d> uv(nv);
  for (std::size_t i = 0; i < nv; ++i) {
    p_C[i] = cam.T_C_W * mesh.vertices[i];
    const double z = p_C[i].z();
    uv[i] = Eigen::Vector2d(cam.fx * p_C[i].x() / z + cam.cx, cam.fy * p_C[i].y() / z + cam.cy);
  }
  // Gouraud: shaded colour per vertex from the area-weighted vertex normal.
  std::vector<Eigen::Vector3d> vertex_rgb;
  if (!flat) {
    std::vector<Eigen::Vector3d> normals(nv, Eigen::Vector3d::Zero());
    for (const Eigen::Vector3i& t : mesh.triangles) {
      const Eigen::Vector3d& a = mesh.vertices[static_cast<std::size_t>(t[0])];
      const Eigen::Vector3d n = (mesh.vertices[static_cast<std::size_t>(t[1])] - a)
                                    .cross(mesh.vertices[static_cast<std::size_t>(t[2])] - a);
      for (int k = 0; k < 3; ++k) normals[static_cast<std::size_t>(t[k])] += n;
    }
    vertex_rgb.resize(nv);
    for (std::size_t i = 0; i < nv; ++i) {
      const double norm = normals[i].norm();
      const Eigen::Vector3d n = norm > 0.0 ? Eigen::Vector3d(normals[i] / norm) : normals[i];
      const double shade = norm > 0.0 ? Shade(n, l_W, options.ambient) : 1.0;
      vertex_rgb[i] = shade * BaseColor(mesh, options, static_cast<int>(i));
    }
  }

  // Depth buffer of camera depths z; colours as RGB doubles.
  std::vector<double> depth(static_cast<std::size_t>(w) * static_cast<std::size_t>(h),
                            std::numeric_limits<double>::infinity());
  std::vector<Eigen::Vector3d> rgb(depth.size(), Eigen::Vector3d::Ones());
  for (const Eigen::Vector3i& t : mesh.triangles) {
    const std::size_t i0 = static_cast<std::size_t>(t[0]), i1 = static_cast<std::size_t>(t[1]),
                      i2 = static_cast<std::size_t>(t[2]);
    const double z0 = p_C[i0].z(), z1 = p_C[i1].z(), z2 = p_C[i2].z();
    const Eigen::Vector2d &a = uv[i0], &b = uv[i1], &c = uv[i2];
    const double area = Edge(a, b, c);
    // The fitted camera sees every vertex in front (z > 0); guard anyway.
    if (!(z0 > 0.0 && z1 > 0.0 && z2 > 0.0) || std::abs(area) < 1e-12) {
      ++result.triangles_culled;
      continue;
    }
    Eigen::Vector3d c0, c1, c2;
    if (flat) {
      const double shade = Shade(FaceNormal(mesh, t), l_W, options.ambient);
      c0 = shade * BaseColor(mesh, options, t[0]);
      c1 = shade * BaseColor(mesh, options, t[1]);
      c2 = shade * BaseColor(mesh, options, t[2]);
    } else {
      c0 = vertex_rgb[i0];
      c1 = vertex_rgb[i1];
      c2 = vertex_rgb[i2];
    }
    // Pixel centres inside the triangle's box.
    const int x_min = std::max(0, static_cast<int>(std::ceil(std::min({a.x(), b.x(), c.x()}))));
    const int x_max =
        std::min(w - 1, static_cast<int>(std::floor(std::max({a.x(), b.x(), c.x()}))));
    const int y_min = std::max(0, static_cast<int>(std::ceil(std::min({a.y(), b.y(), c.y()}))));
    const int y_max =
        std::min(h - 1, static_cast<int>(std::floor(std::max({a.y(), b.y(), c.y()}))));
    const double inv_area = 1.0 / area;
    bool drawn = false;
    for (int y = y_min; y <= y_max; ++y) {
      for (int x = x_min; x <= x_max; ++x) {
        const Eigen::Vector2d p(x, y);
        // Barycentric weights in the picture (same sign as the area inside).
        const double b0 = Edge(b, c, p) * inv_area;
        const double b1 = Edge(c, a, p) * inv_area;
        const double b2 = Edge(a, b, p) * inv_area;
        if (b0 < 0.0 || b1 < 0.0 || b2 < 0.0) continue;
        drawn = true;
        // Perspective-correct: 1/z and attribute/z are affine in the picture.
        const double inv_z = b0 / z0 + b1 / z1 + b2 / z2;
        const double z = 1.0 / inv_z;
        const std::size_t index =
            static_cast<std::size_t>(y) * static_cast<std::size_t>(w) + static_cast<std::size_t>(x);
        if (z >= depth[index]) continue;
        depth[index] = z;
        rgb[index] = (b0 / z0 * c0 + b1 / z1 * c1 + b2 / z2 * c2) * z;
      }
    }
    if (drawn) ++result.triangles_drawn;
  }

  result.image = cv::Mat(h, w, CV_8UC3, cv::Scalar(255, 255, 255));
  for (int y = 0; y < h; ++y) {
    cv::Vec3b* row = result.image.ptr<cv::Vec3b>(y);
    for (int x = 0; x < w; ++x) {
      const std::size_t index =
          static_cast<std::size_t>(y) * static_cast<std::size_t>(w) + static_cast<std::size_t>(x);
      if (!std::isfinite(depth[index])) continue;
      ++result.pixels_covered;
      const Eigen::Vector3d& c = rgb[index];
      auto byte = [](double v) {
        return static_cast<uchar>(std::lround(std::clamp(v, 0.0, 1.0) * 255.0));
      };
      row[x] = cv::Vec3b(byte(c.z()), byte(c.y()), byte(c.x()));  // BGR
    }
  }
  return result;
}

void WritePngAtomically(const std::string& path, const cv::Mat& image) {
  std::vector<uchar> png;
  if (image.empty() || !cv::imencode(".png", image, png)) {
    throw InputError(FormatInputError(path, "", "an image to write as PNG (encoding failed)"));
  }
  WriteFileAtomically(path, std::string(png.begin(), png.end()));
}

}  // namespace vilma::mapping
