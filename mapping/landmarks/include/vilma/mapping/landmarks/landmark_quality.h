// Landmark quality over a VI-map (maplab's evaluate_landmark_quality / elq,
// reset_landmark_quality / rlq, remove_bad_landmarks / rbl; docs/landmarks.md).
//
// A landmark is judged from its observations, each a ray from an observing camera in G:
//   T_G_C = T_G_M(mission of the observing vertex) * T_M_I(vertex) * T_I_C(camera of the rig of
//   that mission),
// so observations from other missions count like the store mission's own. The rules are the
// map builder's (mapping/triangulation.h EvaluateLandmarkQuality, LandmarkQualityOptions): the
// position projects in front of every observer, at least min_observers observations, closest
// observer within [min_distance_m, max_distance_m], largest ray angle at the landmark at least
// min_observation_angle_deg, RMS reprojection error at most max_reprojection_error_px. The
// first failing rule is counted.
#pragma once

#include <array>
#include <cstddef>
#include <string>
#include <vector>

#include "vilma/core/progress.h"
#include "vilma/mapping/triangulation.h"
#include "vilma/mapstore/vi_map.h"

namespace vilma::mapping {

// The observations of a landmark as rays in G (TriangulationObservation::T_M_C holds T_G_C:
// the triangulation works in any one frame). The camera pointers point into `map`.
std::vector<TriangulationObservation> ObservationsInG(const mapstore::VIMap& map,
                                                      const mapstore::LandmarkId& id);

// The landmark at p_G judged as a triangulation result: status kBehindCamera when it lies
// behind an observer (or a projection is not finite), else kOk with the RMS reprojection error.
TriangulationResult JudgePosition(const std::vector<TriangulationObservation>& observations,
                                  const Eigen::Vector3d& p_G);

// Verdict counts and the quality totals of one pass.
struct LandmarkQualitySummary {
  std::string command;  // "elq", "rtl", "itl" (for the report)
  std::size_t landmarks = 0;
  std::array<std::size_t, kNumLandmarkVerdicts> verdicts{};
  std::size_t good_before = 0, good_after = 0;
  std::size_t bad_before = 0, bad_after = 0;
  std::size_t unknown_before = 0, unknown_after = 0;
  double seconds = 0.0;
  std::string BriefReport() const;  // good/bad/unknown before -> after, time
  std::string FullReport() const;   // the brief line, then the counts per verdict
};

// The landmarks stored in the given missions (empty: every mission), in mission order.
std::vector<mapstore::LandmarkId> LandmarksOf(const mapstore::VIMap& map,
                                              const std::vector<mapstore::MissionId>& missions);

// Sets the quality of every landmark of the missions from the rules, at its current position.
// Throws std::invalid_argument (map unchanged) for invalid options.
LandmarkQualitySummary EvaluateLandmarkQualities(const LandmarkQualityOptions& options,
                                                 mapstore::VIMap* map,
                                                 const std::vector<mapstore::MissionId>& missions,
                                                 ProgressObserver* progress = nullptr);

// Sets the quality of landmark ids[i] from verdicts[i] (good or bad) and counts into `summary`
// (landmarks, verdicts, good/bad/unknown before and after).
void ApplyVerdicts(const std::vector<mapstore::LandmarkId>& ids,
                   const std::vector<LandmarkVerdict>& verdicts, mapstore::VIMap* map,
                   LandmarkQualitySummary* summary);

// Sets every landmark of the missions to unknown quality; returns how many there are.
std::size_t ResetLandmarkQuality(mapstore::VIMap* map,
                                 const std::vector<mapstore::MissionId>& missions);

// Removes the landmarks of bad quality of the missions (their keypoints become landmark-free,
// observations from other missions too); returns how many were removed.
std::size_t RemoveBadLandmarks(mapstore::VIMap* map,
                               const std::vector<mapstore::MissionId>& missions);

}  // namespace vilma::mapping
