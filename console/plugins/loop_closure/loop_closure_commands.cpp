// loopclosure_all_missions / lc (mapping/loop_closure, docs/loop-closure.md).
#include "vilma/console/command_registry.h"
#include "vilma/mapping/inspection/map_statistics.h"
#include "vilma/mapping/loop_closure/loop_closure.h"

namespace vilma::console {
namespace {

struct LcOptions : mapping::LoopClosureOptions {
  std::string map_mission;  // "" = every mission
};

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
          .Flag("map_mission", &LcOptions::map_mission,
                "query missions: ids, unique prefixes or names, comma separated (default: all)",
                {"mission"})
          .Run([](CommandContext& c, const LcOptions& o) {
            const std::vector<mapstore::MissionId> missions =
                mapping::ResolveMissions(c.map(), o.map_mission);
            try {
              c.out() << mapping::CloseLoops(o, &c.map(), missions, c.progress()).Report();
            } catch (const std::invalid_argument& e) {
              throw CommandError(e.what());
            }
          }));
}

}  // namespace
}  // namespace vilma::console

VILMA_CONSOLE_COMMANDS(vilma::console::Register)
