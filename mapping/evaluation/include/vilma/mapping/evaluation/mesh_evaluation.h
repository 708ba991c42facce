// A reconstructed mesh judged against the simulator's true surfaces (docs/dense.md, the dense
// targets of docs/benchmarks.md):
//   accuracy      distance of every mesh vertex to the nearest true surface (median, p90);
//   completeness  share of the true surface the depth views saw (in a view's image and depth
//                 range, facing it, not occluded) that lies within `completeness_threshold_m`
//                 of the mesh (point-to-triangle distance).
// The mesh and views are in the map's frame G; `alignment` (S_W_G, e.g. of the map's vertices
// to ground truth, EvaluateMap) takes them into the world frame W.
#pragma once

#include <string>
#include <vector>

#include "vilma/eval/evaluate.h"
#include "vilma/mapping/dense/dense_evaluation.h"
#include "vilma/mapping/dense/tsdf_fusion.h"
#include "vilma/sim/world.h"

namespace vilma::mapping {

struct MeshEvaluationOptions {
  double completeness_threshold_m = 0.05;
  double sample_spacing_m = 0.05;  // true-surface samples on a grid of this spacing
  double min_view_depth_m = 0.2;   // a view "saw" surface within this depth range
  double max_view_depth_m = 6.0;
  double occlusion_tolerance_m = 0.02;
  std::string Validate() const;
};

struct MeshEvaluation {
  std::size_t mesh_vertices = 0;
  ErrorStats accuracy_m;        // mesh vertices to the true surfaces
  double accuracy_p90_m = 0.0;
  std::size_t surface_samples = 0;  // on all quads
  std::size_t seen_samples = 0;     // seen by a view
  std::size_t covered_samples = 0;  // seen and within the threshold of the mesh
  double completeness = 0.0;        // covered / seen
  std::vector<double> vertex_error_m;  // per mesh vertex: distance to the true surfaces
  std::string BriefReport() const;  // "mesh: N vertices; accuracy ...; completeness ..."
  std::string FullReport() const;   // the brief report as a line
};

// The mesh with its vertices coloured by error: green (0) through yellow to red (>= red_at_m).
TriangleMesh ColorMeshByError(const TriangleMesh& mesh, const std::vector<double>& vertex_error_m,
                              double red_at_m);

MeshEvaluation EvaluateMesh(const TriangleMesh& mesh_G, const std::vector<DepthView>& views_G,
                            const sim::World& world, const Alignment& S_W_G,
                            const MeshEvaluationOptions& options = {});

}  // namespace vilma::mapping
