// The integer linear program of landmark summarization (Dymczyk et al., "The gist of maps",
// IROS 2015, eq. 2-4; docs/summarization.md), solved with GLPK's branch and cut:
//
//   maximize    sum_j score_j x_j  -  sum_i slack_penalty zeta_i
//   subject to  sum_{j in cover_i} x_j + zeta_i >= minimum_i      for every row i (a keyframe)
//               sum_j x_j <= max_selected
//               x_j in {0, 1},  0 <= zeta_i <= minimum_i
//
// x_j: keep landmark j; row i: the landmarks keyframe i observes; zeta_i: how many landmarks
// keyframe i may lack (the slack keeps the program feasible when the budget cannot cover every
// keyframe). A slack penalty larger than every score makes covering a keyframe worth more than
// any single landmark's score.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

namespace vilma::mapping {

struct CoverageIlp {
  std::vector<double> scores;            // per column j (> 0)
  std::vector<std::vector<int>> covers;  // per row i: distinct column indices
  std::vector<double> minimums;          // per row i (>= 0)
  double slack_penalty = 1.0;            // per missing landmark of a row
  int max_selected = 0;                  // budget
  // "" or what is malformed (indices out of range, sizes that disagree, negative values).
  std::string Validate() const;
};

struct CoverageIlpOptions {
  double time_limit_s = 60.0;  // wall time of the branch and cut; exceeded = failure
  double mip_gap = 1e-3;       // relative gap |best bound - incumbent| / |incumbent| to stop at
};

struct CoverageIlpResult {
  enum class Status {
    kOptimal,    // proven optimal (within GLPK's tolerances)
    kWithinGap,  // stopped at the relative gap of the options: feasible, near-optimal
    kTimeLimit,  // the time limit hit first: no result is used
    kFailed,     // the solver failed (numerical trouble, no integer solution)
  };
  Status status = Status::kFailed;
  std::vector<char> selected;  // per column: 1 = kept (empty unless optimal / within gap)
  double objective = 0.0;
  double slack_total = 0.0;  // sum of zeta_i
  double seconds = 0.0;
  std::string message;  // GLPK's return code in words for kTimeLimit / kFailed
  bool ok() const { return status == Status::kOptimal || status == Status::kWithinGap; }
};

const char* CoverageIlpStatusName(CoverageIlpResult::Status status);

// Solves the program with GLPK (glp_intopt: presolver, feasibility pump, cover and clique cuts).
// Deterministic for the same program unless the time limit is reached. Throws
// std::invalid_argument when problem.Validate() fails.
CoverageIlpResult SolveCoverageIlp(const CoverageIlp& problem,
                                   const CoverageIlpOptions& options = {});

}  // namespace vilma::mapping
