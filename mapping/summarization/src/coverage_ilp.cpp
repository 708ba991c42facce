#include "vilma/mapping/summarization/coverage_ilp.h"

#include <glpk.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <memory>
#include <stdexcept>

namespace vilma::mapping {
namespace {

// glp_intopt's return codes in words (GLPK reference manual, section 2.8.2).
std::string IntoptCodeName(int code) {
  switch (code) {
    case 0:
      return "solved";
    case GLP_EBOUND:
      return "incorrect bounds (GLP_EBOUND)";
    case GLP_EROOT:
      return "no optimal basis of the LP relaxation (GLP_EROOT)";
    case GLP_ENOPFS:
      return "no primal feasible solution (GLP_ENOPFS)";
    case GLP_ENODFS:
      return "no dual feasible solution (GLP_ENODFS)";
    case GLP_EFAIL:
      return "solver failure (GLP_EFAIL)";
    case GLP_EMIPGAP:
      return "relative gap reached (GLP_EMIPGAP)";
    case GLP_ETMLIM:
      return "time limit reached (GLP_ETMLIM)";
    case GLP_ESTOP:
      return "stopped (GLP_ESTOP)";
    default:
      return "return code " + std::to_string(code);
  }
}

struct ProblemDeleter {
  void operator()(glp_prob* p) const { glp_delete_prob(p); }
};

}  // namespace

std::string CoverageIlp::Validate() const {
  if (covers.size() != minimums.size()) {
    return "covers and minimums: expected one minimum per row (" + std::to_string(covers.size()) +
           " rows, " + std::to_string(minimums.size()) + " minimums)";
  }
  if (max_selected < 0) return "max_selected: expected >= 0";
  if (!(slack_penalty > 0.0)) return "slack_penalty: expected > 0";
  for (std::size_t j = 0; j < scores.size(); ++j) {
    if (!(scores[j] > 0.0) || !std::isfinite(scores[j])) {
      return "scores[" + std::to_string(j) + "]: expected a finite value > 0";
    }
  }
  const int num_columns = static_cast<int>(scores.size());
  for (std::size_t i = 0; i < covers.size(); ++i) {
    if (!(minimums[i] >= 0.0) || !std::isfinite(minimums[i])) {
      return "minimums[" + std::to_string(i) + "]: expected a finite value >= 0";
    }
    std::vector<int> sorted = covers[i];
    std::sort(sorted.begin(), sorted.end());
    if (std::adjacent_find(sorted.begin(), sorted.end()) != sorted.end()) {
      return "covers[" + std::to_string(i) + "]: a column appears twice";
    }
    for (int j : sorted) {
      if (j < 0 || j >= num_columns) {
        return "covers[" + std::to_string(i) + "]: column " + std::to_string(j) +
               " out of range [0, " + std::to_string(num_columns) + ")";
      }
    }
  }
  return "";
}

const char* CoverageIlpStatusName(CoverageIlpResult::Status status) {
  switch (status) {
    case CoverageIlpResult::Status::kOptimal:
      return "optimal";
    case CoverageIlpResult::Status::kWithinGap:
      return "within gap";
    case CoverageIlpResult::Status::kTimeLimit:
      return "time limit";
    case CoverageIlpResult::Status::kFailed:
      return "failed";
  }
  return "?";
}

CoverageIlpResult SolveCoverageIlp(const CoverageIlp& problem, const CoverageIlpOptions& options) {
  const std::string problem_error = problem.Validate();
  if (!problem_error.empty()) throw std::invalid_argument("coverage ILP: " + problem_error);
  if (!(options.time_limit_s > 0.0)) {
    throw std::invalid_argument("coverage ILP: time_limit_s: expected > 0");
  }
  if (!(options.mip_gap >= 0.0))
    throw std::invalid_argument("coverage ILP: mip_gap: expected >= 0");

  const auto t0 = std::chrono::steady_clock::now();
  CoverageIlpResult result;
  const int num_landmarks = static_cast<int>(problem.scores.size());

  // Rows with a positive minimum only: a row that asks for nothing constrains nothing.
  std::vector<int> constrained_rows;
  for (std::size_t i = 0; i < problem.covers.size(); ++i) {
    if (problem.minimums[i] > 0.0) constrained_rows.push_back(static_cast<int>(i));
  }
  const int num_slacks = static_cast<int>(constrained_rows.size());

  std::unique_ptr<glp_prob, ProblemDeleter> lp(glp_create_prob());
  glp_set_obj_dir(lp.get(), GLP_MAX);
  // Columns 1..L: x_j (binary); L+1..L+S: zeta_i (continuous, 0..minimum_i). GLPK is 1-based.
  if (num_landmarks + num_slacks > 0) glp_add_cols(lp.get(), num_landmarks + num_slacks);
  for (int j = 0; j < num_landmarks; ++j) {
    glp_set_col_kind(lp.get(), j + 1, GLP_BV);
    glp_set_obj_coef(lp.get(), j + 1, problem.scores[j]);
  }
  for (int s = 0; s < num_slacks; ++s) {
    const double minimum = problem.minimums[constrained_rows[s]];
    glp_set_col_bnds(lp.get(), num_landmarks + s + 1, GLP_DB, 0.0, minimum);
    glp_set_obj_coef(lp.get(), num_landmarks + s + 1, -problem.slack_penalty);
  }
  // Rows 1..S: coverage; row S+1: the budget.
  glp_add_rows(lp.get(), num_slacks + 1);
  std::vector<int> ia{0}, ja{0};  // index 0 unused (GLPK)
  std::vector<double> ar{0.0};
  for (int s = 0; s < num_slacks; ++s) {
    const int row = s + 1;
    glp_set_row_bnds(lp.get(), row, GLP_LO, problem.minimums[constrained_rows[s]], 0.0);
    for (int j : problem.covers[constrained_rows[s]]) {
      ia.push_back(row);
      ja.push_back(j + 1);
      ar.push_back(1.0);
    }
    ia.push_back(row);
    ja.push_back(num_landmarks + s + 1);
    ar.push_back(1.0);
  }
  const int budget_row = num_slacks + 1;
  glp_set_row_bnds(lp.get(), budget_row, GLP_UP, 0.0, problem.max_selected);
  for (int j = 0; j < num_landmarks; ++j) {
    ia.push_back(budget_row);
    ja.push_back(j + 1);
    ar.push_back(1.0);
  }
  glp_load_matrix(lp.get(), static_cast<int>(ia.size()) - 1, ia.data(), ja.data(), ar.data());

  glp_iocp parameters;
  glp_init_iocp(&parameters);
  parameters.msg_lev = GLP_MSG_OFF;
  parameters.presolve = GLP_ON;  // solves the LP relaxation itself
  parameters.fp_heur = GLP_ON;   // feasibility pump: an incumbent early
  parameters.cov_cuts = GLP_ON;  // the budget row is a knapsack
  parameters.clq_cuts = GLP_ON;
  parameters.mip_gap = options.mip_gap;
  parameters.tm_lim = static_cast<int>(std::min(options.time_limit_s * 1000.0, 2.0e9));
  // msg_lev does not silence the cut generators' set-up lines: terminal output off for the
  // call (glp_term_out returns the previous setting, restored after).
  const int previous_term_out = glp_term_out(GLP_OFF);
  const int code = glp_intopt(lp.get(), &parameters);
  glp_term_out(previous_term_out);
  const int mip_status = glp_mip_status(lp.get());
  result.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count();

  if (code == GLP_ETMLIM) {
    result.status = CoverageIlpResult::Status::kTimeLimit;
    result.message = IntoptCodeName(code);
    return result;
  }
  const bool solved =
      (code == 0 && mip_status == GLP_OPT) || (code == GLP_EMIPGAP && mip_status == GLP_FEAS);
  if (!solved) {
    result.status = CoverageIlpResult::Status::kFailed;
    result.message =
        IntoptCodeName(code) + (mip_status == GLP_NOFEAS ? ", no integer solution" : "");
    return result;
  }
  result.status =
      code == 0 ? CoverageIlpResult::Status::kOptimal : CoverageIlpResult::Status::kWithinGap;
  result.objective = glp_mip_obj_val(lp.get());
  result.selected.assign(num_landmarks, 0);
  for (int j = 0; j < num_landmarks; ++j) {
    result.selected[j] = glp_mip_col_val(lp.get(), j + 1) > 0.5 ? 1 : 0;
  }
  for (int s = 0; s < num_slacks; ++s) {
    result.slack_total += glp_mip_col_val(lp.get(), num_landmarks + s + 1);
  }
  return result;
}

}  // namespace vilma::mapping
