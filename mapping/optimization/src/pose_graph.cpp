#include "vilma/mapping/optimization/pose_graph.h"

#include <ceres/ceres.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <map>
#include <memory>
#include <numeric>
#include <sstream>
#include <stdexcept>
#include <unordered_map>

#include "jet_pose.h"
#include "vilma/mapping/optimization/pose_manifold.h"

namespace vilma::mapping {

using mapstore::EdgeId;
using mapstore::EdgeType;
using mapstore::IdHash;
using mapstore::MissionId;
using mapstore::VertexId;
using mapstore::VIMap;

std::string RelaxOptions::Validate() const {
  if (!(relax_odometry_sigma_m > 0)) return "relax_odometry_sigma_m: expected > 0";
  if (!(relax_odometry_sigma_deg > 0)) return "relax_odometry_sigma_deg: expected > 0";
  if (!(relax_loop_min_sigma_m > 0)) return "relax_loop_min_sigma_m: expected > 0";
  if (!(relax_loop_min_sigma_deg > 0)) return "relax_loop_min_sigma_deg: expected > 0";
  if (relax_robust != "switchable" && relax_robust != "cauchy" && relax_robust != "none") {
    return "relax_robust: expected switchable, cauchy or none";
  }
  if (!(relax_switch_prior_sigma > 0)) return "relax_switch_prior_sigma: expected > 0";
  if (!(relax_cauchy_scale > 0)) return "relax_cauchy_scale: expected > 0";
  if (relax_num_iterations < 1) return "relax_num_iterations: expected >= 1";
  return "";
}

std::string RelaxSummary::BriefReport() const {
  std::ostringstream out;
  out << "relax: " << vertices << " vertices, " << odometry_terms << " odometry and "
      << loop_terms << " loop-closure terms; cost " << initial_cost << " -> " << final_cost
      << " in " << iterations << " iterations; " << loops_switched_off
      << " loop edges switched off; vertices moved mean " << mean_shift_m << " m (max "
      << max_shift_m << "); " << seconds << " s";
  return out.str();
}

std::string RelaxSummary::FullReport() const { return BriefReport() + "\n"; }

namespace {

// Relative pose T_ab between two vertex blocks (T_M_I) of missions with baseframes T_G_Ma,
// T_G_Mb, against a measurement, whitened by `sqrt_info`; with a switch block when switchable.
class RelativePoseCost : public ceres::CostFunction {
 public:
  RelativePoseCost(const Transformation& T_G_Ma, const Transformation& T_G_Mb,
                   const Transformation& T_ab, const Matrix6d& sqrt_info, bool switchable)
      : T_G_Ma_(T_G_Ma), T_G_Mb_(T_G_Mb), T_ab_(T_ab), sqrt_info_(sqrt_info),
        switchable_(switchable) {
    set_num_residuals(6);
    mutable_parameter_block_sizes()->push_back(7);
    mutable_parameter_block_sizes()->push_back(7);
    if (switchable) mutable_parameter_block_sizes()->push_back(1);
  }

  template <typename T>
  void Residual(double const* const* x, const T* delta, const T& s, T* r) const {
    T pa[3], qa[4], pb[3], qb[4];
    PlusPose(x[0], delta, pa, qa);
    PlusPose(x[1], delta + 6, pb, qb);
    // Into G: p_G = R_G_M p + t_G_M, q_G = q_G_M q.
    auto to_g = [](const Transformation& T_G_M, T* p, T* q) {
      const Eigen::Quaterniond& g = T_G_M.rotation();
      const T qg[4] = {T(g.w()), T(g.x()), T(g.y()), T(g.z())};
      T rotated[3], out[4];
      ceres::UnitQuaternionRotatePoint(qg, p, rotated);
      for (int k = 0; k < 3; ++k) p[k] = rotated[k] + T(T_G_M.translation()[k]);
      ceres::QuaternionProduct(qg, q, out);
      for (int k = 0; k < 4; ++k) q[k] = out[k];
    };
    to_g(T_G_Ma_, pa, qa);
    to_g(T_G_Mb_, pb, qb);
    T d[3], dp[3];
    for (int k = 0; k < 3; ++k) d[k] = pb[k] - pa[k];
    RotateInverse(qa, d, dp);
    T e[6];
    for (int k = 0; k < 3; ++k) e[k] = dp[k] - T(T_ab_.translation()[k]);
    T qa_inv[4], qab[4], qm_inv[4], err[4];
    Conjugate(qa, qa_inv);
    ceres::QuaternionProduct(qa_inv, qb, qab);
    const Eigen::Quaterniond& m = T_ab_.rotation();
    const T qm[4] = {T(m.w()), T(m.x()), T(m.y()), T(m.z())};
    Conjugate(qm, qm_inv);
    ceres::QuaternionProduct(qm_inv, qab, err);
    if (err[0] < T(0)) {
      for (T& v : err) v = -v;
    }
    ceres::QuaternionToAngleAxis(err, e + 3);
    for (int i = 0; i < 6; ++i) {
      r[i] = T(0);
      for (int k = 0; k < 6; ++k) r[i] += T(sqrt_info_(i, k)) * e[k];
      r[i] *= s;
    }
  }

  bool Evaluate(double const* const* parameters, double* residuals,
                double** jacobians) const override {
    const double s = switchable_ ? parameters[2][0] : 1.0;
    if (jacobians == nullptr) {
      const double zero[12] = {};
      Residual(parameters, zero, s, residuals);
      return true;
    }
    using Jet = ceres::Jet<double, 13>;
    Jet delta[12];
    for (int k = 0; k < 12; ++k) delta[k] = Jet(0.0, k);
    const Jet js(s, 12);
    Jet r[6];
    Residual(parameters, delta, js, r);
    for (int i = 0; i < 6; ++i) {
      residuals[i] = r[i].a;
      for (int b = 0; b < 2; ++b) {
        if (jacobians[b] == nullptr) continue;
        for (int k = 0; k < 7; ++k) jacobians[b][i * 7 + k] = k < 6 ? r[i].v[6 * b + k] : 0.0;
      }
      if (switchable_ && jacobians[2] != nullptr) jacobians[2][i] = r[i].v[12];
    }
    return true;
  }

 private:
  Transformation T_G_Ma_, T_G_Mb_, T_ab_;
  Matrix6d sqrt_info_;
  bool switchable_;
};

// (1 - s) / sigma: the switch's prior.
struct SwitchPrior {
  double inverse_sigma;
  template <typename T>
  bool operator()(const T* s, T* r) const {
    r[0] = (T(1) - s[0]) * T(inverse_sigma);
    return true;
  }
};

Matrix6d DiagonalSqrtInfo(double sigma_m, double sigma_rad) {
  Matrix6d W = Matrix6d::Zero();
  for (int k = 0; k < 3; ++k) {
    W(k, k) = 1.0 / sigma_m;
    W(3 + k, 3 + k) = 1.0 / sigma_rad;
  }
  return W;
}

}  // namespace

RelaxSummary RelaxPoseGraph(const RelaxOptions& options, VIMap* map,
                            const std::vector<MissionId>& missions, ProgressObserver* progress) {
  const auto start = std::chrono::steady_clock::now();
  const std::string problem_text = options.Validate();
  if (!problem_text.empty()) throw std::invalid_argument("relax options: " + problem_text);
  const std::vector<MissionId> selected = missions.empty() ? map->mission_ids() : missions;
  std::unordered_map<MissionId, int, IdHash> mission_index;
  for (std::size_t i = 0; i < selected.size(); ++i) mission_index[selected[i]] = static_cast<int>(i);

  // Blocks in one arena, in map order (deterministic, as optvi).
  std::vector<double> arena;
  std::size_t n_vertices = 0;
  for (const MissionId& m : selected) n_vertices += map->vertex_ids(m).size();
  arena.reserve(n_vertices * 7 + map->num_edges());
  std::unordered_map<VertexId, double*, IdHash> poses;
  std::vector<std::vector<VertexId>> chains;
  for (const MissionId& m : selected) {
    chains.push_back(map->VertexChain(m));
    if (chains.back().size() != map->vertex_ids(m).size()) {
      throw std::invalid_argument("mission " + m.Hex() + ": its vertices are not one chain of "
                                  "IMU edges (check_map_consistency names the break)");
    }
    for (const VertexId& v : chains.back()) {
      const std::size_t offset = arena.size();
      arena.resize(offset + 7);
      PoseToBlock(map->vertex(v).T_M_I, arena.data() + offset);
      poses[v] = arena.data() + offset;
    }
  }

  ceres::Problem::Options problem_options;
  problem_options.manifold_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  problem_options.loss_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  PoseManifold manifold;
  std::unique_ptr<ceres::LossFunction> cauchy;
  if (options.relax_robust == "cauchy") {
    cauchy = std::make_unique<ceres::CauchyLoss>(options.relax_cauchy_scale);
  }
  RelaxSummary s;
  const double deg = M_PI / 180.0;
  for (std::size_t mi = 0; mi < selected.size(); ++mi) {
    const Transformation& T_G_M = map->mission(selected[mi]).T_G_M;
    for (std::size_t k = 0; k + 1 < chains[mi].size(); ++k) {
      const mapstore::Vertex& a = map->vertex(chains[mi][k]);
      const mapstore::Vertex& b = map->vertex(chains[mi][k + 1]);
      const double root_dt = std::sqrt(std::max(1e-3, 1e-9 * static_cast<double>(b.t_ns - a.t_ns)));
      problem.AddResidualBlock(
          new RelativePoseCost(T_G_M, T_G_M, a.T_M_I.inverse() * b.T_M_I,
                               DiagonalSqrtInfo(options.relax_odometry_sigma_m * root_dt,
                                                options.relax_odometry_sigma_deg * deg * root_dt),
                               false),
          nullptr, poses.at(a.id), poses.at(b.id));
      ++s.odometry_terms;
    }
  }
  // Loop-closure edges between selected missions; clusters of loop-connected missions.
  std::vector<int> parent(selected.size());
  std::iota(parent.begin(), parent.end(), 0);
  std::function<int(int)> find = [&](int i) { return parent[i] == i ? i : parent[i] = find(parent[i]); };
  std::vector<std::pair<EdgeId, double*>> switches;
  std::vector<double> switch_values;
  switch_values.reserve(map->num_edges());
  for (const MissionId& m : selected) {
    for (const EdgeId& id : map->edge_ids(m)) {
      const mapstore::Edge& e = map->edge(id);
      if (e.type != EdgeType::kLoopClosure) continue;
      const MissionId ma = map->vertex(e.from).mission_id, mb = map->vertex(e.to).mission_id;
      if (mission_index.count(ma) == 0 || mission_index.count(mb) == 0) continue;
      // The edge's covariance, floored (RANSAC's is optimistic), as a square-root information.
      Matrix6d cov = e.covariance;
      for (int k = 0; k < 3; ++k) {
        cov(k, k) = std::max(cov(k, k), options.relax_loop_min_sigma_m * options.relax_loop_min_sigma_m);
        const double r = options.relax_loop_min_sigma_deg * deg;
        cov(3 + k, 3 + k) = std::max(cov(3 + k, 3 + k), r * r);
      }
      Eigen::LLT<Matrix6d> llt(cov.inverse());
      const Matrix6d sqrt_info = llt.info() == Eigen::Success
                                     ? Matrix6d(llt.matrixU())
                                     : DiagonalSqrtInfo(options.relax_loop_min_sigma_m,
                                                        options.relax_loop_min_sigma_deg * deg);
      const bool switchable = options.relax_robust == "switchable";
      auto* cost = new RelativePoseCost(map->mission(ma).T_G_M, map->mission(mb).T_G_M, e.T_A_B,
                                        sqrt_info, switchable);
      if (switchable) {
        switch_values.push_back(1.0);
        double* sw = &switch_values.back();
        problem.AddResidualBlock(cost, nullptr, poses.at(e.from), poses.at(e.to), sw);
        problem.AddResidualBlock(
            new ceres::AutoDiffCostFunction<SwitchPrior, 1, 1>(
                new SwitchPrior{1.0 / options.relax_switch_prior_sigma}),
            nullptr, sw);
        problem.SetParameterLowerBound(sw, 0, 0.0);
        problem.SetParameterUpperBound(sw, 0, 1.0);
        switches.emplace_back(id, sw);
      } else {
        problem.AddResidualBlock(cost, cauchy.get(), poses.at(e.from), poses.at(e.to));
      }
      ++s.loop_terms;
      const int a = find(mission_index.at(ma)), b = find(mission_index.at(mb));
      if (a != b) parent[std::max(a, b)] = std::min(a, b);
    }
  }
  if (s.loop_terms == 0) {
    throw std::invalid_argument("relax: no loop-closure edges in the selected missions (run lc)");
  }
  for (auto& [id, block] : poses) {
    (void)id;
    problem.SetManifold(block, &manifold);
  }
  for (std::size_t i = 0; i < selected.size(); ++i) {
    if (find(static_cast<int>(i)) == static_cast<int>(i) && !chains[i].empty()) {
      problem.SetParameterBlockConstant(poses.at(chains[i].front()));
    }
  }
  s.vertices = poses.size();

  class Cancel : public ceres::IterationCallback {
   public:
    explicit Cancel(ProgressObserver* p) : p_(p) {}
    ceres::CallbackReturnType operator()(const ceres::IterationSummary& it) override {
      if (p_ == nullptr) return ceres::SOLVER_CONTINUE;
      p_->Advance(static_cast<std::size_t>(it.iteration));
      cancelled = p_->CancelRequested();
      return cancelled ? ceres::SOLVER_ABORT : ceres::SOLVER_CONTINUE;
    }
    bool cancelled = false;

   private:
    ProgressObserver* p_;
  } cancel(progress);
  BeginProgress(progress, "relax", static_cast<std::size_t>(options.relax_num_iterations));
  ceres::Solver::Options solver;
  solver.linear_solver_type = ceres::SPARSE_NORMAL_CHOLESKY;
  solver.max_num_iterations = options.relax_num_iterations;
  solver.num_threads = 1;
  solver.logging_type = ceres::SILENT;
  solver.callbacks.push_back(&cancel);
  ceres::Solver::Summary summary;
  ceres::Solve(solver, &problem, &summary);
  if (cancel.cancelled) throw Cancelled();
  if (summary.termination_type == ceres::FAILURE) {
    throw std::runtime_error("relax: the solver failed: " + summary.message);
  }
  s.initial_cost = summary.initial_cost;
  s.final_cost = summary.final_cost;
  s.iterations = static_cast<int>(summary.iterations.size()) - 1;

  // Write back: poses; velocities turned with their vertex (v_M = R_new R_oldᵀ v_M).
  double sum = 0.0;
  for (const auto& [id, block] : poses) {
    mapstore::Vertex& v = map->vertex(id);
    const Transformation after = BlockToPose(block);
    const double shift = (after.translation() - v.T_M_I.translation()).norm();
    sum += shift;
    s.max_shift_m = std::max(s.max_shift_m, shift);
    v.v_M = after.rotation() * (v.T_M_I.rotation().conjugate() * v.v_M);
    v.T_M_I = after;
  }
  s.mean_shift_m = poses.empty() ? 0.0 : sum / static_cast<double>(poses.size());
  for (const auto& [id, sw] : switches) {
    if (*sw < 0.5) {
      ++s.loops_switched_off;
      s.switched_off.push_back(id);
    }
  }
  s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return s;
}

}  // namespace vilma::mapping
