// Visual loop closure over a VI-map (maplab's loopclosure_all_missions / lc;
// docs/loop-closure.md).
//
// For each query mission, the database is the good landmarks of the missions that share its
// frame G (the missions with a known baseframe when the query's is known, else the query mission
// alone), with the localizer's index (projected descriptors, inverted multi-index) and P3P
// RANSAC. Every camera frame of every query vertex is localized against it, after dropping the
// matches to landmarks whose observers all lie within lc_min_time_gap_s of the query in the same
// mission (its own recent track: not a loop). A result is a loop when it has at least
// lc_min_inliers inliers and its pose agrees with the vertex's current pose within
// lc_max_correction_m / lc_max_correction_deg (the drift a loop may correct; anything larger is
// a wrong place that happens to look alike). Then:
//   - each inlier keypoint is tied to the matched landmark L: its own landmark Q (if any) is
//     merged into L (all of Q's observations move to L, except where the frame already sees L;
//     Q is removed), or the keypoint becomes an observation of L; each keypoint that joins L
//     this way gets at least lc_merged_keypoint_sigma_px as its noise (a refined track's
//     keypoints agree with their own track's first observation to ~0.15 px, but with L's only
//     up to the detector's placement noise: docs/loop-closure.md "Method");
//   - a loop-closure edge from the query vertex to the database vertex that observes most of
//     the inliers, T_A_B = T_G_A^-1 T_G_B with T_G_A from the RANSAC pose, covariance from it.
// Positions are not changed: run rtl and optvi (or relax) after lc. Deterministic.
#pragma once

#include <array>
#include <cstddef>
#include <string>
#include <vector>

#include "vilma/core/progress.h"
#include "vilma/localizer/localizer.h"
#include "vilma/mapstore/vi_map.h"

namespace vilma::mapping {

// LOC mode's localizer defaults with 3000 RANSAC samples instead of 20000: loop closure
// queries every vertex and most are no loop, so each would run all of them; 20000 found 3 %
// more loops on the real EuRoC keyframes (the same 59 revisits, 0 wrong either way) at 2.8x
// the time (docs/loop-closure.md, "RANSAC samples").
inline localizer::LocalizerOptions LoopClosureLocalizerDefaults() {
  localizer::LocalizerOptions o;
  o.ransac.max_iterations = 3000;
  return o;
}

struct LoopClosureOptions {
  // index, matching, RANSAC (LOC mode's defaults but ransac.max_iterations 3000, above)
  localizer::LocalizerOptions localizer = LoopClosureLocalizerDefaults();
  // RANSAC inliers of a loop (20 let one loop 0.30 m / 5.3 deg wrong through on the real EuRoC
  // keyframes, 25 none: docs/loop-closure.md "Real images").
  int lc_min_inliers = 25;
  double lc_min_time_gap_s = 10.0;        // same mission: landmarks seen only this recently skip
  double lc_max_correction_m = 0.5;       // a loop moves the vertex at most this far [m]
  double lc_max_correction_deg = 10.0;    // and turns it at most this much [deg]
  int lc_every_nth_vertex = 1;            // query every n-th vertex
  bool lc_add_edges = true;               // loop-closure edges for relax
  // Keypoints that join a landmark of another track (merged or added) get at least this
  // measurement noise (mapstore::Keypoint::sigma_px; the map builder's detector noise,
  // triangulation.keypoint_sigma_px) [px]; 0: each keeps its own.
  double lc_merged_keypoint_sigma_px = 1.0;
  std::string Validate() const;
};

enum class LoopRejection {
  kNoMatches,          // localizer status other than ok / too few inliers
  kTooFewInliers,
  kTooLargeCorrection,
  kNumReasons
};

struct LoopClosureSummary {
  std::size_t queries = 0;   // camera frames localized
  std::size_t verified = 0;  // loops accepted
  std::array<std::size_t, static_cast<int>(LoopRejection::kNumReasons)> rejected{};
  std::size_t landmarks_merged = 0;
  std::size_t observations_added = 0;
  std::size_t edges_added = 0;
  double seconds = 0.0;
  double ms_per_query() const { return queries == 0 ? 0.0 : 1000.0 * seconds / queries; }
  std::string BriefReport() const;  // "lc: N frames queried, M loops verified; ...; T s (...)"
  std::string FullReport() const;   // the brief report as a line (what `lc` prints)
};

// Throws std::invalid_argument (map unchanged) for invalid options or an empty database.
// Cancelled (from ReportProgress) may leave the map partly merged: the console runs lc on a copy.
LoopClosureSummary CloseLoops(const LoopClosureOptions& options, mapstore::VIMap* map,
                              const std::vector<mapstore::MissionId>& missions = {},
                              ProgressObserver* progress = nullptr);

}  // namespace vilma::mapping
