// Hard localization cases made from one real KITTI stereo slice (docs/localizer.md,
// "Acceptance"), reproducing how a localizer comes to accept a wrong pose: a map of another
// part of the slice or with its nearest frames far away, wrong matches injected into the
// query, few keypoints, keypoints from one image corner, a map of far landmarks only, and
// repetitive structure (the map's landmarks repeated 2.5 m to the side with the same
// descriptors and observers, so that two poses are supported equally).
#pragma once

#include <string>
#include <vector>

#include "vilma/eval/localization/acceptance_eval.h"
#include "vilma/eval/localization/kitti_localization.h"
#include "vilma/localizer/localization_map.h"

namespace vilma::eval {

// The localizer's types this harness is written in.
using localizer::LocalizationMap;

struct KittiScenario {
  std::string name;
  std::string description;
  std::vector<int> map_frames;    // stereo frames the map is built from
  std::vector<int> query_frames;  // left images localized against it
  QueryPerturbation perturbation;
  // Map edits after BuildLocalizationMap.
  double min_landmark_distance_m = 0.0;     // > 0: drop landmarks nearer to a map camera
  Eigen::Vector3d repeat_shift_W = Eigen::Vector3d::Zero();  // non-zero: add shifted copies
  int repeat_every_nth = 1;                                  // of every n-th landmark
};

// The named scenarios of a slice of `frames` frames: even-odd (the existing check), sparse-map,
// other-part, swapped-50, swapped-80, few-keypoints, corner, far-landmarks, repeated, repeated-third.
std::vector<KittiScenario> KittiScenarios(int frames);

// Landmarks at least `min_distance_m` from every position in `camera_positions_G` (with their
// descriptors and observers); the projection is dropped (retrained at load).
LocalizationMap KeepFarLandmarks(const LocalizationMap& map,
                                 const std::vector<Eigen::Vector3d>& camera_positions_G,
                                 double min_distance_m);
// The map plus a copy of every n-th landmark moved by shift_G, with the same descriptors and
// the same observers (so the covisibility filter cannot separate the copies).
LocalizationMap RepeatLandmarks(const LocalizationMap& map, const Eigen::Vector3d& shift_G,
                                int every_nth = 1);

// Builds the scenario's map (ground-truth poses, as the KITTI check) and localizes its queries.
std::vector<AcceptanceQuery> RunKittiScenario(const KittiSequence& sequence,
                                              const KittiLocalizationOptions& options,
                                              const KittiScenario& scenario,
                                              const AcceptanceGates& gates);

}  // namespace vilma::eval
