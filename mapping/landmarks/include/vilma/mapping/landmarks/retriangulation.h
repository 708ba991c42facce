// Landmark positions from their observations (maplab's retriangulate_landmarks / rtl and
// init_track_landmarks / itl; docs/landmarks.md).
//
// rtl: every landmark of the missions is triangulated again in G from all its observations
// (rays T_G_C of landmark_quality.h ObservationsInG, from any mission): the linear N-ray
// midpoint, refined by Gauss-Newton on the pixel errors (mapping/triangulation.h), with its
// covariance. The new position and covariance are stored in the landmark's store vertex frame
// (p_I = T_G_I^-1 p_G, Sigma_I = R_I_G Sigma_G R_I_G^T). A landmark that cannot be triangulated
// (fewer than 2 observations, parallel rays, behind a camera) keeps its position and is marked
// bad. Then, unless evaluate_quality is off, every landmark's quality is set by the elq rules.
//
// itl: the keypoints of a mission's vertices that carry a track id (the map builder's feature
// tracks) but no landmark are grouped by track id (tracks are per mission). A track none of
// whose keypoints has a landmark becomes a new landmark when it has at least min_track_length
// keypoints and triangulates: stored in its first vertex (chain order), every keypoint an
// observation, quality by the elq rules. Free keypoints of a track that has a landmark are
// added as observations of that landmark (the one most of the track's keypoints see), unless
// their frame already sees it; positions are not changed (run rtl after itl for that).
// New landmark ids are drawn from a generator seeded by the mission id and its landmark count,
// skipping ids in use: the same map gives the same ids.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "vilma/core/progress.h"
#include "vilma/mapping/landmarks/landmark_quality.h"
#include "vilma/mapping/map_builder_options.h"
#include "vilma/mapstore/vi_map.h"

namespace vilma::mapping {

struct RetriangulationOptions {
  TriangulationOptions triangulation;
  LandmarkQualityOptions quality;
  bool evaluate_quality = true;  // elq after triangulating (maplab's rtl does)
  std::string Validate() const;
};

struct RetriangulationSummary {
  std::size_t landmarks = 0;
  std::size_t triangulated = 0;  // new position stored
  std::size_t failed = 0;        // position kept, marked bad
  double median_shift_m = 0.0;   // of the triangulated ones, in G
  double max_shift_m = 0.0;
  double seconds = 0.0;
  LandmarkQualitySummary quality;  // of the elq pass (command "rtl"); empty when it is off
  std::string BriefReport() const;  // counts, shifts, time
  std::string FullReport() const;   // the brief line, then the elq report when elq ran
};

// Throws std::invalid_argument (map unchanged) for invalid options. Cancelled (from
// ReportProgress) leaves the map unchanged: positions are written after the last safe point.
RetriangulationSummary RetriangulateLandmarks(const RetriangulationOptions& options,
                                              mapstore::VIMap* map,
                                              const std::vector<mapstore::MissionId>& missions,
                                              ProgressObserver* progress = nullptr);

struct TrackLandmarkOptions {
  TriangulationOptions triangulation;
  LandmarkQualityOptions quality;
  int min_track_length = 2;  // keypoints of a track (observations) to make a landmark
  std::string Validate() const;
};

struct TrackLandmarkSummary {
  std::size_t tracks_free = 0;            // tracks without any landmark
  std::size_t too_short = 0;              // of those, shorter than min_track_length
  std::size_t triangulation_failed = 0;   // of those, no position
  std::size_t landmarks_created = 0;
  std::size_t landmarks_created_good = 0;
  std::size_t observations_created = 0;   // of the new landmarks
  std::size_t observations_attached = 0;  // free keypoints added to an existing landmark
  double seconds = 0.0;
  std::string BriefReport() const;  // counts, time
  std::string FullReport() const;   // the brief report as a line
};

// Throws std::invalid_argument (map unchanged) for invalid options. Cancelled leaves the map
// unchanged (landmarks are added after the last safe point).
TrackLandmarkSummary InitializeTrackLandmarks(const TrackLandmarkOptions& options,
                                              mapstore::VIMap* map,
                                              const std::vector<mapstore::MissionId>& missions,
                                              ProgressObserver* progress = nullptr);

}  // namespace vilma::mapping
