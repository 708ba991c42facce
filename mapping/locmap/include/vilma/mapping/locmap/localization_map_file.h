// A VI-map to a `.vlocmap` file in one call (maplab's generate_summary_map_and_save_to_disk):
// the localization map of its missions in the common frame G (BuildLocalizationMap), the
// descriptor projection trained by the Localizer itself and stored with it (loading the file
// needs no training), written atomically. Used by `vilma locmap build` and the console's
// `generate_summary_map_and_save_to_disk` (docs/localizer.md).
#pragma once

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

}  // namespace vilma::mapping
