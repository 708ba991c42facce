#include "vilma/mapping/locmap/localization_map_file.h"

#include <chrono>
#include <filesystem>
#include <iomanip>
#include <memory>
#include <sstream>

#include "vilma/core/error.h"
#include "vilma/core/timing.h"
#include "vilma/mapstore/map_io.h"

namespace vilma::mapping {

using localizer::LocalizationMap;
using localizer::Localizer;

LocalizationMapFileReport BuildAndSaveLocalizationMap(const mapstore::VIMap& vimap,
                                                      const localizer::LocalizerOptions& options,
                                                      const std::string& source,
                                                      const std::string& path) {
  LocalizationMapFileReport report;
  auto t0 = std::chrono::steady_clock::now();
  auto map =
      std::make_shared<LocalizationMap>(BuildLocalizationMap(vimap, options.map, &report.missions));
  report.build_ms = MsSince(t0);
  if (map->num_landmarks() == 0 || map->num_descriptors() < 2) {
    std::size_t total = 0, good = 0;
    for (const mapstore::MissionId& m : vimap.mission_ids()) {
      for (const mapstore::LandmarkId& l : vimap.landmark_ids(m)) {
        ++total;
        if (vimap.landmark(l).quality == mapstore::LandmarkQuality::kGood) ++good;
      }
    }
    throw InputError(FormatInputError(source, "landmarks",
                                      "good landmarks with at least " +
                                          std::to_string(options.map.min_observations) +
                                          " observations (the map has " + std::to_string(good) +
                                          " good of " + std::to_string(total) + ")"));
  }
  // The projection is trained by the Localizer itself (the one place that knows how the index
  // wants it), then stored; the trainer, which shares the map, is gone before the map changes.
  Eigen::MatrixXf projection;
  {
    const Localizer trainer(map, options);
    report.train_ms = trainer.projection_train_ms();
    report.index_ms = trainer.index_build_ms();
    projection = trainer.projection();
  }
  map->projection = std::move(projection);
  t0 = std::chrono::steady_clock::now();
  SaveLocalizationMap(*map, path);
  report.save_ms = MsSince(t0);
  std::error_code ec;
  report.file_bytes = static_cast<long long>(std::filesystem::file_size(path, ec));
  report.landmarks = map->num_landmarks();
  report.descriptors = map->num_descriptors();
  report.observers = map->observers.size();
  report.descriptor_bits = static_cast<int>(map->descriptor_bytes * 8);
  report.projection_rows = static_cast<int>(map->projection.rows());
  report.projection_cols = static_cast<int>(map->projection.cols());
  return report;
}

std::string OpenedLocalizationMap::BriefReport() const {
  std::ostringstream d;
  d << std::fixed << std::setprecision(0);
  if (from_vimap) {
    d << "VI-map folder, " << vimap_missions << (vimap_missions == 1 ? " mission" : " missions")
      << " (" << missions.missions_used << " in the common frame G), summary built in " << load_ms
      << " ms";
  } else {
    d << "localization map file, loaded in " << load_ms << " ms";
  }
  return d.str();
}

std::string OpenedLocalizationMap::FullReport() const { return BriefReport() + "\n"; }

OpenedLocalizationMap OpenLocalizationMap(const std::string& path,
                                          const localizer::LocalizationMapOptions& options,
                                          const std::string& what) {
  namespace fs = std::filesystem;
  std::error_code ec;
  OpenedLocalizationMap opened;
  opened.map = std::make_shared<LocalizationMap>();
  const auto t0 = std::chrono::steady_clock::now();
  if (fs::is_directory(path, ec)) {
    const mapstore::VIMap vimap = mapstore::LoadMap(path);
    *opened.map = BuildLocalizationMap(vimap, options, &opened.missions);
    opened.from_vimap = true;
    opened.vimap_missions = vimap.mission_ids().size();
  } else if (fs::is_regular_file(path, ec)) {
    *opened.map = localizer::LoadLocalizationMap(path);
  } else {
    throw InputError(FormatInputError(path, what, "a .vlocmap file or a VI-map folder"));
  }
  opened.load_ms = MsSince(t0);
  if (opened.map->num_landmarks() == 0 || opened.map->num_descriptors() < 2) {
    throw InputError(FormatInputError(path, "landmarks", "a map with good landmarks"));
  }
  return opened;
}

}  // namespace vilma::mapping
