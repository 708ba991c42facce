// A VI-map to a `.vlocmap` file in one call (maplab's generate_summary_map_and_save_to_disk):
// the localization map of its missions in the common frame G (BuildLocalizationMap), the
// descriptor projection trained by the Localizer itself and stored with it (loading the file
// needs no training), written atomically. Used by `vilma locmap build` and the console's
// `generate_summary_map_and_save_to_disk` (docs/localizer.md).
#pragma once

#include <memory>
#include <string>

#include "vilma/localizer/localizer.h"
#include "vilma/mapping/locmap/localization_map_builder.h"
#include "vilma/mapstore/vi_map.h"

namespace vilma::mapping {

struct LocalizationMapFileReport {
  LocalizationMapReport missions;  // which missions were in the common frame
  std::size_t landmarks = 0, descriptors = 0, observers = 0;
  int descriptor_bits = 0;
  int projection_rows = 0, projection_cols = 0;
  double build_ms = 0.0, train_ms = 0.0, index_ms = 0.0, save_ms = 0.0;
  long long file_bytes = 0;
};

// Throws InputError naming `source` (the map's folder or key) when the map has no good
// landmark with options.map.min_observations observations, and `path` when it cannot be
// written. Options are validated by the caller.
LocalizationMapFileReport BuildAndSaveLocalizationMap(const mapstore::VIMap& vimap,
                                                      const localizer::LocalizerOptions& options,
                                                      const std::string& source,
                                                      const std::string& path);

// A localization map opened from `path`: a `.vlocmap` file (loaded) or a VI-map folder (its
// missions in the common frame G summarized now with `options`, BuildLocalizationMap). The one
// way programs open a map for localization (vilma-estimatord's LOC stage, `vilma localize`), so
// that both accept the same inputs and make the same checks.
struct OpenedLocalizationMap {
  std::shared_ptr<localizer::LocalizationMap> map;
  bool from_vimap = false;         // a VI-map folder, summarized at load
  std::size_t vimap_missions = 0;  // missions in the folder (from_vimap)
  LocalizationMapReport missions;  // which of them were in the common frame G (from_vimap)
  double load_ms = 0.0;            // load (and summary) wall time [ms]
  // "VI-map folder, 2 missions (1 in the common frame G), summary built in 120 ms" or
  // "localization map file, loaded in 8 ms".
  std::string BriefReport() const;
  std::string FullReport() const;  // the brief report as a line
};

// Throws InputError naming `path` and `what` (the option or argument that named it) when it is
// neither a file nor a folder, and "path: landmarks: a map with good landmarks" when
// the map has no landmark or fewer than 2 descriptors (nothing to match against); loader errors
// name the file.
OpenedLocalizationMap OpenLocalizationMap(const std::string& path,
                                          const localizer::LocalizationMapOptions& options,
                                          const std::string& what);

}  // namespace vilma::mapping
