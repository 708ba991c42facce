// Pose-graph relaxation of a VI-map (maplab's relax; docs/optimization.md "Relaxation").
//
// Unknowns: the vertex poses T_M_I of the selected missions (baseframes T_G_M held). Terms:
//   - odometry: consecutive vertices of a mission keep their current relative pose
//     T_ab = T_G_a^-1 T_G_b, with the noise of a random walk over the time between them:
//     σ_p = relax_odometry_sigma_m * sqrt(Δt/1 s), σ_θ likewise — the VIO's drift, which the
//     loops are there to correct;
//   - loop closures: every loop-closure edge (lc) pulls T_G_a^-1 T_G_b towards its measurement,
//     with its covariance floored at relax_loop_min_sigma_m / _deg (RANSAC covariances are
//     optimistic), and switchable (Sünderhauf & Protzel, IROS 2012): r = s * r_loop with a
//     switch s in [0, 1] and a prior (1 - s) / relax_switch_prior_sigma, so an edge the rest of
//     the graph contradicts is switched off; or a Cauchy loss (relax_robust = cauchy).
// The relative-pose residual is r = [R_aᵀ(p_b - p_a) - p_ab; Log(q_abᵀ q_aᵀ q_b)] (positions and
// rotations in G), whitened; Jacobians by automatic differentiation over the tangent.
// Gauge: the first vertex of each cluster of loop-connected missions is held. After relaxation
// the landmarks move with their store vertices (they are stored relative to them); velocities are
// rotated with their vertex. Run optvi after relax to refine.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "vilma/core/progress.h"
#include "vilma/mapstore/vi_map.h"

namespace vilma::mapping {

struct RelaxOptions {
  double relax_odometry_sigma_m = 0.02;    // per sqrt(second) of the edge [m]
  double relax_odometry_sigma_deg = 0.2;   // per sqrt(second) [deg]
  double relax_loop_min_sigma_m = 0.02;    // floor of a loop edge's position sigma [m]
  double relax_loop_min_sigma_deg = 0.5;   // floor of its rotation sigma [deg]
  std::string relax_robust = "switchable";  // switchable, cauchy or none
  double relax_switch_prior_sigma = 0.2;   // of (1 - s)
  double relax_cauchy_scale = 3.0;         // in sigmas
  int relax_num_iterations = 50;
  std::string Validate() const;
};

struct RelaxSummary {
  std::size_t vertices = 0, odometry_terms = 0, loop_terms = 0;
  std::size_t loops_switched_off = 0;  // switch < 0.5 after the solve
  double initial_cost = 0.0, final_cost = 0.0;
  int iterations = 0;
  double seconds = 0.0;
  double mean_shift_m = 0.0, max_shift_m = 0.0;  // vertex positions in G
  std::vector<mapstore::EdgeId> switched_off;    // the loop edges the graph rejected
  std::string BriefReport() const;  // "relax: N vertices, ...; T s"
  std::string FullReport() const;   // the brief report as a line (what `relax` prints)
};

// Throws std::invalid_argument (map unchanged) for invalid options or a map without
// loop-closure edges in the selected missions; Cancelled leaves the map unchanged.
RelaxSummary RelaxPoseGraph(const RelaxOptions& options, mapstore::VIMap* map,
                            const std::vector<mapstore::MissionId>& missions = {},
                            ProgressObserver* progress = nullptr);

}  // namespace vilma::mapping
