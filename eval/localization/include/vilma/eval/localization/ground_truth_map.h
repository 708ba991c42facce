// A localization map of an ASL dataset (e.g. a vilma-sim session) built by the map builder driven
// by the dataset's GROUND-TRUTH states, so that the map frame G is the dataset's world frame W:
// localization errors against it are errors against ground truth, without any alignment. For
// LOC-mode tests and benchmarks (vilma-locmap-gt, docs/daemon.md "Localization").
#pragma once

#include <string>

#include "vilma/localizer/localization_map.h"
#include "vilma/mapping/map_builder_options.h"

namespace vilma::eval {

struct GroundTruthMapOptions {
  int camera = 0;         // camera of the rig and dataset whose keyframe features go in (>= 0)
  double seconds = 1e9;   // the first `seconds` of the dataset (> 0) [s]
  // The map builder's options (config/map_builder.yaml; its `cameras` is replaced by
  // {camera}).
  mapping::MapBuilderOptions map_builder;
  // Empty when valid, else "field: expected ...".
  std::string Validate() const;
};

struct GroundTruthMapSummary {
  localizer::LocalizationMap map;
  int frames = 0;    // frames given to the map builder
  int vertices = 0;  // map-builder vertices
  double build_s = 0.0;  // wall time [s]
  // "901 vertices, 6447 landmarks, 46958 descriptors" (vilma-locmap-gt's line).
  std::string BriefReport() const;
  // The brief report, the frames and the build time.
  std::string FullReport() const;
};

// Reads `dataset_path` (ASL folder with rig.yaml and a ground truth sample at each frame time of
// the camera, as vilma-sim writes) and builds the map. Frames without a ground-truth sample at
// their exact time are skipped. Throws InputError naming the dataset when the camera is missing
// or it has no images or no ground truth.
GroundTruthMapSummary BuildGroundTruthLocalizationMap(const std::string& dataset_path,
                                                      const GroundTruthMapOptions& options);

}  // namespace vilma::eval
