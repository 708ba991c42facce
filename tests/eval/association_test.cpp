#include "vilma/eval/association.h"

#include <catch2/catch.hpp>

#include <cmath>
#include <random>
#include <string>

#include "eval/test_trajectories.h"

namespace vilma {
namespace {

using namespace eval_test;  // NOLINT: the shared test trajectories

TEST_CASE("association, unique rule: tolerance, nearest first, each gt once", "[eval]") {
  Trajectory gt, est;
  for (int64_t ms : {0, 100, 200, 300, 400}) gt.Add(ms * 1000000, Transformation());
  // 3 -> 0; 95 and 102 compete for 100: 102 is nearer and wins, 95 has no other gt in reach;
  // 105 would be 5 ms from 100 but 100 is taken -> dropped; 250 is 50 ms from anything;
  // 409 -> 400 (9 ms).
  for (int64_t ms : {3, 95, 102, 105, 250, 409}) est.Add(ms * 1000000, Transformation());
  AssociationOptions options;  // 10 ms
  options.rule = AssociationRule::kUnique;
  const Association a = AssociateTrajectories(gt, est, options);
  CHECK_FALSE(a.by_index);
  CHECK(a.est_index == std::vector<std::size_t>{0, 2, 5});
  CHECK(a.gt_index == std::vector<std::size_t>{0, 1, 4});

  options.max_dt_s = 0.005;  // 409 is now too far
  const Association b = AssociateTrajectories(gt, est, options);
  CHECK(b.est_index == std::vector<std::size_t>{0, 2});
  CHECK(b.gt_index == std::vector<std::size_t>{0, 1});

  options.max_dt_s = -1.0;
  CHECK_FALSE(options.Validate().empty());
}

TEST_CASE("association, evo rule: the shorter side walks, nearest stamp, ties to the earlier",
          "[eval]") {
  AssociationOptions options;
  CHECK(options.rule == AssociationRule::kEvo);  // the default
  Trajectory gt, est;
  for (int64_t ms : {0, 10, 20, 30, 100}) gt.Add(ms * 1000000, Transformation());
  // Estimate shorter: each estimate stamp takes its nearest gt stamp. 5 is 5 ms from both 0
  // and 10: the earlier wins (numpy's argmin); 8 and 12 both take 10 (a gt pose used twice);
  // 60 is 30 ms from the nearest (30): dropped.
  for (int64_t ms : {5, 8, 12, 60}) est.Add(ms * 1000000, Transformation());
  Association a = AssociateTrajectories(gt, est, options);
  CHECK(a.est_index == std::vector<std::size_t>{0, 1, 2});
  CHECK(a.gt_index == std::vector<std::size_t>{0, 1, 1});

  // Estimate longer than gt: gt walks. gt 0 -> est 1 (1 ms), gt 50 -> nothing within 10 ms,
  // gt 100 -> est 99 (1 ms) and not 91; est 1, 2, 91 are left out.
  Trajectory gt2, est2;
  for (int64_t ms : {0, 50, 100}) gt2.Add(ms * 1000000, Transformation());
  for (int64_t ms : {1, 2, 91, 99}) est2.Add(ms * 1000000, Transformation());
  a = AssociateTrajectories(gt2, est2, options);
  CHECK(a.gt_index == std::vector<std::size_t>{0, 2});
  CHECK(a.est_index == std::vector<std::size_t>{0, 3});

  // Equally long: the estimate walks (evo's traj_2 is the short one unless strictly longer).
  Trajectory gt3, est3;
  for (int64_t ms : {0, 4}) gt3.Add(ms * 1000000, Transformation());
  for (int64_t ms : {1, 2}) est3.Add(ms * 1000000, Transformation());
  a = AssociateTrajectories(gt3, est3, options);
  CHECK(a.gt_index == std::vector<std::size_t>{0, 0});  // 1 -> 0, 2 -> 0 (tie 2 vs 2: earlier)
  CHECK(a.est_index == std::vector<std::size_t>{0, 1});

  AssociationRule rule = AssociationRule::kUnique;
  CHECK(ParseAssociationRule("evo", &rule));
  CHECK(rule == AssociationRule::kEvo);
  CHECK_FALSE(ParseAssociationRule("nearest", &rule));
}

TEST_CASE("association by index when a trajectory has no stamps (KITTI)", "[eval]") {
  Trajectory gt = MakeLoop(10);
  gt.has_timestamps = false;
  const Trajectory est = MakeLoop(8);
  const Association a = AssociateTrajectories(gt, est, AssociationOptions{});
  CHECK(a.by_index);
  REQUIRE(a.size() == 8);
  CHECK(a.gt_index[7] == 7);
  CHECK(a.est_index[7] == 7);
}

}  // namespace
}  // namespace vilma
