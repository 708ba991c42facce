// Map summarization (docs/summarization.md): landmark_sparsify (lsparsify), the ILP landmark
// selection and its baselines; compact_map, keypoints without a landmark dropped; generate_summary_map_and_save_to_disk (summary_map), the
// `.vlocmap` localization map of the selected map that vilma-estimatord --localization-map loads.
#include <filesystem>
#include <iomanip>
#include <sstream>

#include "vilma/console/command_registry.h"
#include "vilma/core/error.h"
#include "vilma/mapping/locmap/localization_map_file.h"
#include "vilma/localizer/localizer.h"
#include "vilma/mapping/summarization/landmark_sparsification.h"
#include "vilma/mapstore/compaction.h"

namespace vilma::console {
namespace {

struct SummaryMapOptions {
  std::string summary_map_save_path;  // the .vlocmap file
  std::string localizer_config;       // localizer YAML ("" = built-in defaults)
  std::string Validate() const {
    if (summary_map_save_path.empty()) return "summary_map_save_path: expected a file path";
    std::error_code ec;
    if (std::filesystem::is_directory(summary_map_save_path, ec)) {
      return "summary_map_save_path: expected a file path, not a folder";
    }
    return "";
  }
};

struct CompactMapOptions {};

void Register(CommandRegistry* registry) {
  registry->Add(
      Command<CompactMapOptions>("compact_map")
          .Group("summarization")
          .Summary("drop every keypoint without a landmark (its descriptor is most of a raw "
                   "map's size); landmarks, observations and poses are unchanged")
          .Access(MapAccess::kModify)
          .Run([](CommandContext& c, const CompactMapOptions&) {
            const mapstore::KeypointCompactionStats stats =
                mapstore::RemoveKeypointsWithoutLandmark(&c.map());
            c.out() << "compact_map: keypoints " << stats.keypoints_before << " -> "
                    << stats.keypoints_after << "\n";
          }));

  using L = mapping::LandmarkSparsificationOptions;
  registry->Add(
      Command<L>("landmark_sparsify")
          .Alias("lsparsify")
          .Group("summarization")
          .Summary("keep at most N good landmarks — an ILP that maximizes their observations "
                   "while every keyframe keeps a minimum (or the random / most-observed "
                   "baseline) — and remove every other landmark")
          .Access(MapAccess::kModify)
          .Flag("num_landmarks_to_keep", &L::num_landmarks_to_keep,
                "landmarks to keep (0: --lsparsify_keep_fraction of the good ones)")
          .Flag("lsparsify_keep_fraction", &L::keep_fraction,
                "share of the good landmarks to keep when --num_landmarks_to_keep is 0")
          .Flag("lsparsify_method", &L::method, "ilp, most_observed or random")
          .Flag("sparsification_min_keypoints_per_keyframe", &L::min_landmarks_per_keyframe,
                "landmarks every keyframe keeps (or all it sees, if fewer; ILP constraint "
                "with slack)")
          .Flag("lsparsify_partition_landmarks", &L::partition_max_landmarks,
                "landmarks per ILP: the map is solved in parts of about this many")
          .Flag("lsparsify_time_limit_s", &L::time_limit_s,
                "time limit of each part's ILP [s]; reaching it fails the command (map "
                "unchanged)")
          .Flag("lsparsify_mip_gap", &L::mip_gap, "relative optimality gap at which the ILP stops")
          .Flag("lsparsify_seed", &L::random_seed, "seed of the random baseline")
          .Run([](CommandContext& c, const L& o) {
            c.out() << mapping::SparsifyLandmarks(o, &c.map(), c.progress()).FullReport();
          }));

  using S = SummaryMapOptions;
  registry->Add(
      Command<S>("generate_summary_map_and_save_to_disk")
          .Alias("summary_map")
          .Group("summarization")
          .Summary("write the localization map (.vlocmap: good landmarks in G, descriptors, "
                   "observers, trained projection) of the selected map's anchored missions")
          .Access(MapAccess::kRead)
          .PathFlag("summary_map_save_path", &S::summary_map_save_path,
                    "the .vlocmap file (written atomically)", {"out"})
          .Positional("summary_map_save_path")
          .PathFlag("localizer_config", &S::localizer_config,
                    "localizer YAML (config/localizer.yaml; default: built-in defaults)")
          .Run([](CommandContext& c, const S& o) {
            const localizer::LocalizerOptions options =
                o.localizer_config.empty() ? localizer::LocalizerOptions()
                                           : localizer::LoadLocalizerOptions(o.localizer_config);
            const std::string problem = options.Validate();
            if (!problem.empty()) {
              throw CommandError(FormatInputError(
                  o.localizer_config.empty() ? "built-in defaults" : o.localizer_config, "",
                  problem));
            }
            const mapping::LocalizationMapFileReport r = mapping::BuildAndSaveLocalizationMap(
                c.map(), options, "map '" + c.map_key() + "'", o.summary_map_save_path);
            std::ostringstream s;
            s << std::fixed << std::setprecision(1) << "summary_map: " << o.summary_map_save_path
              << ": " << r.landmarks << " landmarks, " << r.descriptors << " descriptors, "
              << r.observers << " observers from " << r.missions.missions_used << " of "
              << (r.missions.missions_used + r.missions.missions_skipped)
              << " missions (the others are not anchored); " << r.file_bytes / 1024.0
              << " KiB; built " << r.build_ms << " ms, projection " << r.train_ms << " ms, saved "
              << r.save_ms << " ms\n";
            c.out() << s.str();
          }));
}

}  // namespace
}  // namespace vilma::console

VILMA_CONSOLE_COMMANDS(vilma::console::Register)
