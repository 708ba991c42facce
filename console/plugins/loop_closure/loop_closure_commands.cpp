// loopclosure_all_missions / lc and anchor_all_missions / aam (mapping/loop_closure,
// docs/loop-closure.md).
#include "vilma/console/command_registry.h"
#include "vilma/mapping/inspection/map_statistics.h"
#include "vilma/mapping/loop_closure/anchoring.h"
#include "vilma/mapping/loop_closure/loop_closure.h"

namespace vilma::console {
namespace {

struct LcOptions : mapping::LoopClosureOptions {
  std::string map_mission;  // "" = every mission
};
using AamOptions = mapping::AnchoringOptions;

void Register(CommandRegistry* registry) {
  registry->Add(
      Command<LcOptions>("loopclosure_all_missions")
          .Alias("lc")
          .Group("loop closure")
          .Summary("find revisits of places (the localizer's index + P3P RANSAC), merge the "
                   "re-observed landmarks, add loop-closure edges")
          .Access(MapAccess::kModify)
          .Flag("lc_min_inliers", &LcOptions::lc_min_inliers, "RANSAC inliers of a loop")
          .Flag("lc_min_time_gap_s", &LcOptions::lc_min_time_gap_s,
                "same mission: landmarks seen only this recently are not a loop [s]")
          .Flag("lc_max_correction_m", &LcOptions::lc_max_correction_m,
                "a loop moves a vertex at most this far [m]")
          .Flag("lc_max_correction_deg", &LcOptions::lc_max_correction_deg,
                "a loop turns a vertex at most this much [deg]")
          .Flag("lc_every_nth_vertex", &LcOptions::lc_every_nth_vertex, "query every n-th vertex")
          .Flag("lc_add_edges", &LcOptions::lc_add_edges, "add loop-closure edges (for relax)")
          .Flag("lc_merged_keypoint_sigma_px", &LcOptions::lc_merged_keypoint_sigma_px,
                "keypoints joining another track's landmark get at least this noise (0: keep) "
                "[px]")
          .Flag("map_mission", &LcOptions::map_mission,
                "query missions: ids, unique prefixes or names, comma separated (default: all)",
                {"mission"})
          .Run([](CommandContext& c, const LcOptions& o) {
            const std::vector<mapstore::MissionId> missions =
                mapping::ResolveMissions(c.map(), o.map_mission);
            try {
              c.out() << mapping::CloseLoops(o, &c.map(), missions, c.progress()).FullReport();
            } catch (const std::invalid_argument& e) {
              throw CommandError(e.what());
            }
          }));

  registry->Add(
      Command<AamOptions>("anchor_all_missions")
          .Alias("aam")
          .Group("loop closure")
          .Summary("place every mission with an unknown baseframe in G by localizing its "
                   "vertices against the known missions (consensus); unanchored ones stay "
                   "unknown")
          .Access(MapAccess::kModify)
          .Flag("aam_min_inliers", &AamOptions::aam_min_inliers,
                "RANSAC inliers of a usable localization")
          .Flag("aam_min_support", &AamOptions::aam_min_support, "vertices agreeing on T_G_M")
          .Flag("aam_consensus_m", &AamOptions::aam_consensus_m, "agreement in position [m]")
          .Flag("aam_consensus_deg", &AamOptions::aam_consensus_deg,
                "agreement in rotation [deg]")
          .Flag("aam_every_nth_vertex", &AamOptions::aam_every_nth_vertex,
                "query every n-th vertex")
          .Run([](CommandContext& c, const AamOptions& o) {
            try {
              c.out() << mapping::AnchorAllMissions(o, &c.map(), c.progress()).FullReport();
            } catch (const std::invalid_argument& e) {
              throw CommandError(e.what());
            }
          }));
}

}  // namespace
}  // namespace vilma::console

VILMA_CONSOLE_COMMANDS(vilma::console::Register)
