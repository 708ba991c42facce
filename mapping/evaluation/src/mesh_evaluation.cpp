#include "vilma/mapping/evaluation/mesh_evaluation.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <sstream>

#include "vilma/core/error.h"
#include "vilma/mapping/dense/mesh_distance.h"

namespace vilma::mapping {

std::string MeshEvaluationOptions::Validate() const {
  if (!(completeness_threshold_m > 0.0)) return "completeness_threshold_m: > 0";
  if (!(sample_spacing_m > 0.0)) return "sample_spacing_m: > 0";
  if (!(min_view_depth_m >= 0.0 && max_view_depth_m > min_view_depth_m)) {
    return "min_view_depth_m, max_view_depth_m: 0 <= min < max";
  }
  if (!(occlusion_tolerance_m >= 0.0)) return "occlusion_tolerance_m: >= 0";
  return "";
}

std::string MeshEvaluation::BriefReport() const {
  std::ostringstream s;
  s << std::fixed << std::setprecision(4) << "mesh: " << mesh_vertices
    << " vertices; accuracy (to the true surfaces) median " << accuracy_m.median << " m, p90 "
    << accuracy_p90_m << " m; completeness " << std::setprecision(1) << 100.0 * completeness
    << " % (" << covered_samples << " of " << seen_samples << " seen surface samples; "
    << surface_samples << " in the world)";
  return s.str();
}

std::string MeshEvaluation::FullReport() const { return BriefReport() + "\n"; }

TriangleMesh ColorMeshByError(const TriangleMesh& mesh, const std::vector<double>& vertex_error_m,
                              double red_at_m) {
  TriangleMesh colored = mesh;
  colored.colors.resize(mesh.vertices.size());
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    const double x = i < vertex_error_m.size() ? std::min(1.0, vertex_error_m[i] / red_at_m) : 1.0;
    colored.colors[i] = Eigen::Vector3d(std::min(1.0, 2.0 * x), std::min(1.0, 2.0 * (1.0 - x)), 0.1);
  }
  return colored;
}

MeshEvaluation EvaluateMesh(const TriangleMesh& mesh_G, const std::vector<DepthView>& views_G,
                            const sim::World& world, const Alignment& S_W_G,
                            const MeshEvaluationOptions& options) {
  ThrowIfInvalid(options.Validate(), "mesh evaluation options");
  MeshEvaluation e;
  e.mesh_vertices = mesh_G.vertices.size();

  // Accuracy: mesh vertices taken into W.
  const Eigen::Matrix3d R_W_G = S_W_G.T_G_E.rotationMatrix();
  const Eigen::Vector3d p_W_G = S_W_G.T_G_E.translation();
  auto to_W = [&](const Eigen::Vector3d& p_G) { return Eigen::Vector3d(S_W_G.scale * (R_W_G * p_G) + p_W_G); };
  std::vector<double> distances;
  distances.reserve(mesh_G.vertices.size());
  for (const Eigen::Vector3d& p_G : mesh_G.vertices) distances.push_back(sim::DistanceToWorld(world, to_W(p_G)));
  e.accuracy_m = ComputeErrorStats(distances);
  e.vertex_error_m = distances;
  if (!distances.empty()) {
    const std::size_t k = std::min(distances.size() - 1, static_cast<std::size_t>(0.9 * distances.size()));
    std::nth_element(distances.begin(), distances.begin() + static_cast<std::ptrdiff_t>(k), distances.end());
    e.accuracy_p90_m = distances[k];
  }

  // Views in W: T_W_D = S_W_G T_G_D (scale applies to the translation).
  struct ViewW {
    Eigen::Matrix3d R_D_W;
    Eigen::Vector3d p_W_D;
    const DepthView* view;
  };
  std::vector<ViewW> views;
  for (const DepthView& v : views_G) {
    const Eigen::Matrix3d R_W_D = R_W_G * v.T_G_D.topLeftCorner<3, 3>();
    views.push_back({R_W_D.transpose(), to_W(v.T_G_D.topRightCorner<3, 1>()), &v});
  }

  // Completeness: samples of the true surfaces, in the mesh's frame G for the distance query.
  const Eigen::Matrix3d R_G_W = R_W_G.transpose();
  // Queries are in G, so the threshold and the cells are in G's units (a sim3 alignment scales).
  const double threshold_G = options.completeness_threshold_m / S_W_G.scale;
  const MeshDistanceIndex index(mesh_G, 2.0 * threshold_G);
  for (const sim::Quad& quad : world.quads) {
    const int nu = std::max(1, static_cast<int>(std::ceil(quad.edge_u_W.norm() / options.sample_spacing_m)));
    const int nv = std::max(1, static_cast<int>(std::ceil(quad.edge_v_W.norm() / options.sample_spacing_m)));
    const Eigen::Vector3d normal = quad.Normal();
    for (int i = 0; i < nu; ++i) {
      for (int j = 0; j < nv; ++j) {
        const Eigen::Vector3d p_W = quad.origin_W + (i + 0.5) / nu * quad.edge_u_W + (j + 0.5) / nv * quad.edge_v_W;
        ++e.surface_samples;
        bool seen = false;
        for (const ViewW& v : views) {
          const Eigen::Vector3d ray_W = p_W - v.p_W_D;
          if (!quad.two_sided && ray_W.dot(normal) >= 0.0) continue;  // the back of the quad
          const Eigen::Vector3d p_D = v.R_D_W * ray_W;
          if (p_D.z() < options.min_view_depth_m || p_D.z() > options.max_view_depth_m) continue;
          const double u = v.view->fx * p_D.x() / p_D.z() + v.view->cx;
          const double w = v.view->fy * p_D.y() / p_D.z() + v.view->cy;
          if (u < 0.0 || w < 0.0 || u > v.view->width - 1.0 || w > v.view->height - 1.0) continue;
          const double distance = ray_W.norm();
          if (world.RayCast(v.p_W_D, ray_W / distance) < distance - options.occlusion_tolerance_m) continue;
          seen = true;
          break;
        }
        if (!seen) continue;
        ++e.seen_samples;
        const Eigen::Vector3d p_G = R_G_W * (p_W - p_W_G) / S_W_G.scale;
        if (std::isfinite(index.Distance(p_G, threshold_G))) ++e.covered_samples;
      }
    }
  }
  e.completeness = e.seen_samples > 0 ? static_cast<double>(e.covered_samples) / e.seen_samples : 0.0;
  return e;
}

}  // namespace vilma::mapping
