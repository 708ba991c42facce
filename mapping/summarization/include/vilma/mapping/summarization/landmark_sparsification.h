// Landmark summarization of a VI-map (maplab's landmark_sparsify / lsparsify;
// docs/summarization.md): keep at most N good landmarks so that localization still works
// everywhere the map goes, and remove the others.
//
// Methods:
//   ilp            the coverage ILP of coverage_ilp.h (Dymczyk et al. 2015): score of a landmark
//                  = its number of observations; every keyframe (vertex) keeps
//                  min(min_landmarks_per_keyframe, the good landmarks it sees), with slack;
//                  solved per partition (below);
//   most_observed  the N landmarks with the most observations (ties: map order);
//   random         N landmarks drawn uniformly (seeded Fisher-Yates over map order).
//
// Partitions (maplab splits maps of >= 5,000 landmarks): vertices are walked in map order
// (missions in order, each along its chain); each landmark belongs to the partition of its
// first observer; a partition closes at the vertex where its landmarks reach
// partition_max_landmarks. Partitions are solved in order, each with the budget share of its
// landmarks (rounded, unused budget carried on). Every vertex that sees a partition's landmarks
// gets a row in it, wherever the vertex lies (after loop closure, later missions see mostly the
// first mission's landmarks): its demand left after the earlier partitions, split over the
// partitions not solved yet in proportion to its landmarks in each (rounded up). One ILP per
// partition keeps the solve time bounded (time_limit_s each) at the price of not trading
// landmarks across partition borders.
//
// Every landmark that is not kept is removed — the bad and unknown ones too (localization and
// optimization use good landmarks only); their keypoints stay (without a landmark).
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

#include "vilma/core/progress.h"
#include "vilma/mapstore/vi_map.h"

namespace vilma::mapping {

struct LandmarkSparsificationOptions {
  int num_landmarks_to_keep = 0;        // N; 0 = use keep_fraction
  double keep_fraction = 0.0;           // N = round(fraction * good landmarks) when N is 0
  std::string method = "ilp";           // ilp | most_observed | random
  int min_landmarks_per_keyframe = 30;  // maplab's sparsification_min_keypoints_per_keyframe
  int partition_max_landmarks = 5000;   // landmarks per ILP
  double time_limit_s = 60.0;           // per partition's ILP [s]; reaching it fails the command
  double mip_gap = 1e-2;                // relative optimality gap the ILP stops at
  uint64_t random_seed = 1;             // method random
  std::string Validate() const;         // "" or "field: expectation"
};

struct SparsificationPartition {
  std::size_t keyframes = 0;
  std::size_t candidates = 0;  // good landmarks first observed in the partition
  std::size_t budget = 0;
  std::size_t kept = 0;
  std::string status;  // "optimal", "within gap", "all kept", ...
  double objective = 0.0;
  double slack = 0.0;  // landmarks keyframes lack in total (the ILP's zeta sum)
  double seconds = 0.0;
};

struct LandmarkSparsificationSummary {
  std::string method;
  std::size_t landmarks_before = 0, good_before = 0;
  std::size_t landmarks_after = 0;  // all good
  std::size_t observations_before = 0, observations_after = 0;
  std::size_t keyframes = 0;
  // Keyframes that keep fewer than min(min_landmarks_per_keyframe, their good landmarks):
  std::size_t keyframes_below_minimum = 0;
  std::size_t keyframes_without_landmarks = 0;      // of those that saw a good landmark before
  std::vector<SparsificationPartition> partitions;  // ilp only
  double seconds = 0.0;
  std::string BriefReport() const;  // one line
  std::string FullReport() const;   // the line, then one per partition
};

// Which good landmarks to keep (the map is not changed); throws std::invalid_argument for
// invalid options and std::runtime_error, naming the partition and what to change, when an
// ILP fails or reaches its time limit. Cancellable at partition boundaries.
std::vector<mapstore::LandmarkId> SelectLandmarksToKeep(
    const LandmarkSparsificationOptions& options, const mapstore::VIMap& map,
    LandmarkSparsificationSummary* summary, ProgressObserver* progress = nullptr);

// SelectLandmarksToKeep, then removes every other landmark. The map is unchanged when it throws.
LandmarkSparsificationSummary SparsifyLandmarks(const LandmarkSparsificationOptions& options,
                                                mapstore::VIMap* map,
                                                ProgressObserver* progress = nullptr);

}  // namespace vilma::mapping
