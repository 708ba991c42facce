// Anchoring of missions (maplab's anchor_all_missions / aam; docs/loop-closure.md "Anchoring").
//
// Every mission with an unknown baseframe is placed in G by localizing its vertices against the
// good landmarks of the missions whose baseframe is known (if none is known, the first mission
// is made known first, as `sbk` does, and the report says so). Each localized camera frame of a
// vertex gives a candidate baseframe
//   T_G_M = T_G_I(RANSAC) * T_M_I(vertex)^-1.
// Consensus: the candidate with the most others within aam_consensus_m / aam_consensus_deg wins;
// with at least aam_min_support supporting vertices, T_G_M becomes the mean of its supporters
// (positions averaged, rotations by the normalized sum of sign-aligned quaternions) and the
// baseframe is marked known. A mission without such consensus stays unknown and is reported:
// never placed on a guess. Vertex poses and landmarks are not changed (they are in M).
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "vilma/core/progress.h"
#include "vilma/localizer/localizer.h"
#include "vilma/mapstore/vi_map.h"

namespace vilma::mapping {

struct AnchoringOptions {
  localizer::LocalizerOptions localizer;  // index, matching, RANSAC (LOC mode's defaults)
  int aam_min_inliers = 20;          // RANSAC inliers of a usable localization
  int aam_min_support = 5;           // vertices agreeing on T_G_M
  double aam_consensus_m = 0.2;      // agreement in position [m]
  double aam_consensus_deg = 2.0;    // and in rotation [deg]
  int aam_every_nth_vertex = 1;      // query every n-th vertex
  std::string Validate() const;
};

struct MissionAnchoring {
  mapstore::MissionId mission;
  std::size_t vertices_tried = 0, localized = 0, support = 0;
  bool anchored = false;
  Transformation T_G_M;         // the new baseframe (anchored) or the old one
  double change_m = 0.0, change_deg = 0.0;  // from the previous T_G_M
};

struct AnchoringSummary {
  bool first_made_known = false;  // no mission was known: the first one anchors G
  std::vector<MissionAnchoring> missions;
  double seconds = 0.0;
  std::string BriefReport() const;  // "aam: A of N unknown missions anchored; T s"
  std::string FullReport() const;   // the brief line, then one line per mission
};

// Throws std::invalid_argument (map unchanged) for invalid options. Missions already known are
// left alone. Cancelled leaves the map unchanged (baseframes are set at the end).
AnchoringSummary AnchorAllMissions(const AnchoringOptions& options, mapstore::VIMap* map,
                                   ProgressObserver* progress = nullptr);

}  // namespace vilma::mapping
