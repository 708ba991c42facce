#include "vilma/console/locmap_command.h"

#include <algorithm>
#include <chrono>
#include <exception>
#include <filesystem>
#include <iomanip>
#include <limits>
#include <sstream>

#include "vilma/core/error.h"
#include "vilma/core/timing.h"
#include "vilma/mapping/locmap/localization_map_file.h"
#include "vilma/mapstore/map_io.h"
#include "vilma/mapstore/vi_map.h"

namespace vilma::console {
namespace {

namespace fs = std::filesystem;

// min / median / max of counts (median: the upper middle element; 0 0 0 when empty).
struct CountSpread {
  std::size_t min = 0, median = 0, max = 0;
};
CountSpread Spread(std::vector<std::size_t> v) {
  CountSpread s;
  if (v.empty()) return s;
  std::sort(v.begin(), v.end());
  s.min = v.front();
  s.median = v[v.size() / 2];
  s.max = v.back();
  return s;
}

std::string Bytes(long long bytes) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(1);
  if (bytes >= 1024LL * 1024) {
    s << static_cast<double>(bytes) / (1024.0 * 1024.0) << " MiB";
  } else {
    s << static_cast<double>(bytes) / 1024.0 << " KiB";
  }
  s << " (" << bytes << " bytes)";
  return s.str();
}

// A VI-map folder, with an error that says what the user probably meant.
mapstore::VIMap LoadVIMapFolder(const std::string& dir) {
  std::error_code ec;
  if (!fs::exists(dir, ec)) {
    throw InputError(FormatInputError(dir, "VIMAP_DIR", "an existing VI-map folder"));
  }
  if (!fs::is_directory(dir, ec)) {
    throw InputError(
        FormatInputError(dir, "VIMAP_DIR", "a VI-map folder (vilma vio --save-map), not a file"));
  }
  return mapstore::LoadMap(dir);
}

int RunBuild(const std::vector<std::string>& args, std::ostream& out) {
  std::string vimap_dir, out_path, config_path;
  for (ArgCursor arg(args); arg.Next();) {
    if (arg.name() == "--config") {
      config_path = arg.Value();
    } else if (arg.is_option()) {
      throw UsageError("unknown option '" + arg.word() + "'");
    } else if (vimap_dir.empty()) {
      vimap_dir = arg.name();
    } else if (out_path.empty()) {
      out_path = arg.name();
    } else {
      throw UsageError("unexpected argument '" + arg.name() + "'");
    }
  }
  if (vimap_dir.empty()) throw UsageError("build: expected VIMAP_DIR and OUT.vlocmap");
  if (out_path.empty()) throw UsageError("build: expected OUT.vlocmap after VIMAP_DIR");
  std::error_code ec;
  if (fs::is_directory(out_path, ec)) {
    throw InputError(FormatInputError(out_path, "OUT.vlocmap", "a file path, not a folder"));
  }
  // Options first: a bad --config fails before the (slow) map load.
  const localizer::LocalizerOptions options = config_path.empty()
                                                  ? localizer::LocalizerOptions()
                                                  : localizer::LoadLocalizerOptions(config_path);
  const std::string options_error = options.Validate();
  if (!options_error.empty()) {
    throw InputError(FormatInputError(config_path.empty() ? "built-in defaults" : config_path, "",
                                      options_error));
  }

  const auto t0 = std::chrono::steady_clock::now();
  const mapstore::VIMap vimap = LoadVIMapFolder(vimap_dir);
  const double load_ms = MsSince(t0);
  std::size_t landmarks_total = 0, landmarks_good = 0;
  for (const mapstore::MissionId& m : vimap.mission_ids()) {
    for (const mapstore::LandmarkId& l : vimap.landmark_ids(m)) {
      ++landmarks_total;
      if (vimap.landmark(l).quality == mapstore::LandmarkQuality::kGood) ++landmarks_good;
    }
  }
  const mapping::LocalizationMapFileReport r =
      mapping::BuildAndSaveLocalizationMap(vimap, options, vimap_dir, out_path);
  const std::size_t missions = vimap.mission_ids().size();

  out << std::fixed << std::setprecision(1) << "vilma locmap build: " << vimap_dir << " -> "
      << out_path << "\n"
      << "  VI-map           " << missions << (missions == 1 ? " mission, " : " missions, ")
      << vimap.num_vertices() << " vertices, " << landmarks_good << " good of " << landmarks_total
      << " landmarks (loaded in " << load_ms << " ms)\n"
      << "  missions used    " << r.missions.missions_used << " of " << missions
      << (r.missions.missions_skipped > 0
              ? " (the others are not anchored: their frames are unknown in G)"
              : "")
      << "\n"
      << "  options          " << (config_path.empty() ? "built-in defaults" : config_path)
      << " (map: min_observations " << options.map.min_observations
      << ", max_descriptors_per_landmark " << options.map.max_descriptors_per_landmark << ")\n"
      << "  landmarks        " << r.landmarks << " kept\n"
      << "  descriptors      " << r.descriptors << " (" << r.descriptor_bits
      << " bit)\n"
      << "  observers        " << r.observers << " vertices\n"
      << "  projection       " << r.projection_rows << " x " << r.projection_cols
      << " (stored; trained in " << r.train_ms << " ms, index built in " << r.index_ms << " ms)\n"
      << "  build            " << r.build_ms << " ms (summary map), saved in " << r.save_ms
      << " ms\n"
      << "  file             " << Bytes(r.file_bytes) << "\n";
  return kExitOk;
}

int RunInfo(const std::vector<std::string>& args, std::ostream& out) {
  std::string path;
  for (const std::string& a : args) {
    if (!a.empty() && a[0] == '-') throw UsageError("unknown option '" + a + "'");
    if (!path.empty()) throw UsageError("unexpected argument '" + a + "' (one FILE only)");
    path = a;
  }
  if (path.empty()) throw UsageError("info: expected FILE.vlocmap");
  std::error_code ec;
  if (fs::is_directory(path, ec)) {
    throw InputError(FormatInputError(
        path, "FILE.vlocmap",
        "a localization map file, not a folder (a VI-map folder? 'vilma locmap build' makes one)"));
  }
  const localizer::LocalizationMap map = localizer::LoadLocalizationMap(path);
  out << "vilma locmap info: " << path << "\n";
  WriteLocalizationMapInfo(out, map, static_cast<long long>(fs::file_size(path, ec)));
  return kExitOk;
}

}  // namespace

void PrintLocmapHelp(std::ostream& out) {
  out << "usage: vilma locmap build VIMAP_DIR OUT.vlocmap [--config LOCALIZER.yaml]\n"
         "       vilma locmap info FILE.vlocmap\n"
         "\n"
         "Localization summary maps (docs/localizer.md, \"Command line\"): what\n"
         "vilma-estimatord --localization-map and 'vilma localize' load.\n"
         "\n"
         "  build   loads a VI-map folder (vilma vio --save-map, vilma-mapstored), keeps its good\n"
         "          landmarks with their positions p_G and a subset of their descriptors (the\n"
         "          `map` section of --config), trains the descriptor projection (the\n"
         "          `projection` section) and stores it in the file, so that loading it needs\n"
         "          no training; writes OUT atomically and prints a summary\n"
         "  info    prints what a .vlocmap holds: counts, projection, bounding box of p_G,\n"
         "          descriptors and observers per landmark (min / median / max)\n"
         "\n"
         "options:\n"
         "  --config FILE   localizer options (config/localizer.yaml format; default: the\n"
         "                  built-in defaults, which are config/localizer.yaml)\n"
         "  -h, --help      this text\n"
         "\n"
         "exit codes: 0 ok, 1 input error (the message names the file and field), 2 usage error\n";
}

void WriteLocalizationMapInfo(std::ostream& out, const localizer::LocalizationMap& map,
                              long long file_bytes) {
  const std::size_t n = map.num_landmarks();
  std::vector<std::size_t> descriptors_per_landmark(n, 0), observers_per_landmark(n, 0);
  for (uint32_t l : map.descriptor_landmark) ++descriptors_per_landmark[l];
  for (std::size_t l = 0; l < n; ++l) {
    observers_per_landmark[l] = map.observer_begin[l + 1] - map.observer_begin[l];
  }
  Eigen::Vector3d lo = Eigen::Vector3d::Constant(std::numeric_limits<double>::infinity());
  Eigen::Vector3d hi = -lo;
  for (const Eigen::Vector3d& p : map.p_G) {
    lo = lo.cwiseMin(p);
    hi = hi.cwiseMax(p);
  }
  const CountSpread dpl = Spread(descriptors_per_landmark);
  const CountSpread opl = Spread(observers_per_landmark);
  out << std::fixed << std::setprecision(2) << "  format           version "
      << localizer::LocalizationMap::kFormatVersion << ", " << map.descriptor_bytes * 8
      << "-bit descriptors\n"
      << "  landmarks        " << n << "\n"
      << "  descriptors      " << map.num_descriptors() << " (per landmark min " << dpl.min
      << ", median " << dpl.median << ", max " << dpl.max << ")\n"
      << "  observers        " << map.observers.size() << " vertices, " << map.observer_index.size()
      << " landmark-vertex links (per landmark min " << opl.min << ", median " << opl.median
      << ", max " << opl.max << ")\n";
  if (map.projection.rows() > 0) {
    out << "  projection       stored, " << map.projection.rows() << " x " << map.projection.cols()
        << " (no training at load)\n";
  } else {
    out << "  projection       none (the localizer trains one at load; 'vilma locmap build'"
           " stores it)\n";
  }
  if (n > 0) {
    out << "  p_G bounding box min (" << lo.x() << ", " << lo.y() << ", " << lo.z() << ") max ("
        << hi.x() << ", " << hi.y() << ", " << hi.z() << ") m, size " << (hi - lo).x() << " x "
        << (hi - lo).y() << " x " << (hi - lo).z() << " m\n";
  }
  if (file_bytes >= 0) out << "  file             " << Bytes(file_bytes) << "\n";
}

int RunLocmapCommand(const std::vector<std::string>& args, std::ostream& out, std::ostream& err) {
  std::string verb = args.empty() ? std::string() : args[0];
  try {
    for (const std::string& a : args) {
      if (a == "--help" || a == "-h") {
        PrintLocmapHelp(out);
        return kExitOk;
      }
    }
    if (verb.empty()) throw UsageError("expected 'build' or 'info'");
    const std::vector<std::string> rest(args.begin() + 1, args.end());
    if (verb == "build") return RunBuild(rest, out);
    if (verb == "info") return RunInfo(rest, out);
    throw UsageError("unknown verb '" + verb + "' (expected 'build' or 'info')");
  } catch (const UsageError& e) {
    err << "vilma locmap: " << e.what() << "\n(see 'vilma locmap --help')\n";
    return kExitUsage;
  } catch (const std::exception& e) {
    err << "vilma locmap " << verb << ": error: " << e.what() << "\n";
    return kExitInputError;
  }
}

}  // namespace vilma::console
