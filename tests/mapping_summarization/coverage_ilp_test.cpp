// The coverage ILP (GLPK): hand-made instances with known optima, random small instances
// against brute force, validation and the time limit.
#include "vilma/mapping/summarization/coverage_ilp.h"

#include <catch2/catch.hpp>
#include <random>

namespace vilma::mapping {
namespace {

std::vector<int> Selected(const CoverageIlpResult& r) {
  std::vector<int> s;
  for (std::size_t j = 0; j < r.selected.size(); ++j) {
    if (r.selected[j]) s.push_back(static_cast<int>(j));
  }
  return s;
}

// Two keyframes, four landmarks: keyframe 0 sees {0, 1}, keyframe 1 sees {2, 3}.
CoverageIlp TwoKeyframes(int budget) {
  CoverageIlp p;
  p.scores = {5.0, 4.0, 3.0, 1.0};
  p.covers = {{0, 1}, {2, 3}};
  p.minimums = {1.0, 1.0};
  p.slack_penalty = 11.0;
  p.max_selected = budget;
  return p;
}

TEST_CASE("coverage ILP: the known optimum of a hand-made instance", "[coverage_ilp]") {
  SECTION("budget 2: the best landmark of each keyframe, not the two best overall") {
    const CoverageIlpResult r = SolveCoverageIlp(TwoKeyframes(2));
    REQUIRE(r.ok());
    CHECK(r.status == CoverageIlpResult::Status::kOptimal);
    CHECK(Selected(r) == std::vector<int>{0, 2});
    CHECK(r.objective == Approx(8.0));
    CHECK(r.slack_total == Approx(0.0).margin(1e-9));
  }
  SECTION("budget 1: one keyframe cannot be covered; the slack says by how much") {
    const CoverageIlpResult r = SolveCoverageIlp(TwoKeyframes(1));
    REQUIRE(r.ok());
    CHECK(Selected(r) == std::vector<int>{0});
    CHECK(r.slack_total == Approx(1.0));
    CHECK(r.objective == Approx(5.0 - 11.0));
  }
  SECTION("budget 4: everything") {
    const CoverageIlpResult r = SolveCoverageIlp(TwoKeyframes(4));
    REQUIRE(r.ok());
    CHECK(Selected(r) == std::vector<int>{0, 1, 2, 3});
  }
  SECTION("minimum 2 per keyframe, budget 3: one keyframe lacks one") {
    CoverageIlp p = TwoKeyframes(3);
    p.minimums = {2.0, 2.0};
    const CoverageIlpResult r = SolveCoverageIlp(p);
    REQUIRE(r.ok());
    CHECK(r.slack_total == Approx(1.0));
    CHECK(Selected(r) == std::vector<int>{0, 1, 2});  // 12 - 11 beats 9 - 11
  }
}

// Brute force over every subset of at most max_selected columns.
double BruteForceOptimum(const CoverageIlp& p) {
  const int n = static_cast<int>(p.scores.size());
  double best = -1e300;
  for (uint32_t mask = 0; mask < (1u << n); ++mask) {
    if (__builtin_popcount(mask) > p.max_selected) continue;
    double value = 0.0;
    for (int j = 0; j < n; ++j) {
      if (mask & (1u << j)) value += p.scores[j];
    }
    for (std::size_t i = 0; i < p.covers.size(); ++i) {
      int covered = 0;
      for (int j : p.covers[i]) covered += (mask >> j) & 1u;
      value -= p.slack_penalty * std::max(0.0, p.minimums[i] - covered);
    }
    best = std::max(best, value);
  }
  return best;
}

TEST_CASE("coverage ILP: random small instances reach the brute-force optimum", "[coverage_ilp]") {
  std::mt19937_64 rng(5);
  for (int trial = 0; trial < 40; ++trial) {
    CoverageIlp p;
    const int n = 6 + static_cast<int>(rng() % 9);  // 6..14 columns
    for (int j = 0; j < n; ++j) p.scores.push_back(1.0 + static_cast<double>(rng() % 20));
    const int rows = 2 + static_cast<int>(rng() % 6);
    for (int i = 0; i < rows; ++i) {
      std::vector<int> cover;
      for (int j = 0; j < n; ++j) {
        if (rng() % 3 == 0) cover.push_back(j);
      }
      p.covers.push_back(cover);
      p.minimums.push_back(static_cast<double>(rng() % 4));
    }
    p.slack_penalty = 41.0;
    p.max_selected = 1 + static_cast<int>(rng() % static_cast<uint64_t>(n));
    CoverageIlpOptions o;
    o.mip_gap = 0.0;
    const CoverageIlpResult r = SolveCoverageIlp(p, o);
    INFO("trial " << trial << ", " << n << " columns, budget " << p.max_selected);
    REQUIRE(r.ok());
    CHECK(static_cast<int>(Selected(r).size()) <= p.max_selected);
    CHECK(r.objective == Approx(BruteForceOptimum(p)).margin(1e-6));
  }
}

TEST_CASE("coverage ILP: malformed programs are refused", "[coverage_ilp]") {
  CoverageIlp p = TwoKeyframes(2);
  p.covers[0] = {0, 0};
  CHECK_THROWS_WITH(SolveCoverageIlp(p), Catch::Contains("appears twice"));
  p = TwoKeyframes(2);
  p.covers[1] = {2, 7};
  CHECK_THROWS_WITH(SolveCoverageIlp(p), Catch::Contains("out of range"));
  p = TwoKeyframes(2);
  p.minimums.pop_back();
  CHECK_THROWS_WITH(SolveCoverageIlp(p), Catch::Contains("one minimum per row"));
  p = TwoKeyframes(2);
  p.scores[1] = 0.0;
  CHECK_THROWS_WITH(SolveCoverageIlp(p), Catch::Contains("scores[1]"));
}

// A program too large to finish in 1 ms: many overlapping keyframes and a tight budget.
CoverageIlp LargeProgram() {
  std::mt19937_64 rng(11);
  CoverageIlp p;
  const int n = 4000;
  for (int j = 0; j < n; ++j) p.scores.push_back(2.0 + static_cast<double>(rng() % 50));
  for (int i = 0; i < 800; ++i) {
    std::vector<int> cover;
    const int first = static_cast<int>(rng() % (n - 60));
    for (int j = first; j < first + 60; j += 1 + static_cast<int>(rng() % 3)) cover.push_back(j);
    p.covers.push_back(cover);
    p.minimums.push_back(7.0);
  }
  p.slack_penalty = 103.0;
  p.max_selected = 900;
  return p;
}

TEST_CASE("coverage ILP: reaching the time limit is a status, not a result", "[coverage_ilp]") {
  CoverageIlpOptions o;
  o.time_limit_s = 0.001;
  o.mip_gap = 0.0;
  const CoverageIlpResult r = SolveCoverageIlp(LargeProgram(), o);
  CHECK(r.status == CoverageIlpResult::Status::kTimeLimit);
  CHECK_FALSE(r.ok());
  CHECK(r.selected.empty());
  CHECK_THAT(r.message, Catch::Contains("time limit"));
}

}  // namespace
}  // namespace vilma::mapping
