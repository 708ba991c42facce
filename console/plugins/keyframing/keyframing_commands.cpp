// keyframe_heuristic / kfh (mapping/keyframing, docs/keyframing.md).
#include "vilma/console/command_registry.h"
#include "vilma/mapping/inspection/map_statistics.h"
#include "vilma/mapping/keyframing/keyframe_heuristic.h"

namespace vilma::console {
namespace {

struct KfhOptions : mapping::KeyframingOptions {
  std::string map_mission;  // "" = every mission
};

void Register(CommandRegistry* registry) {
  registry->Add(
      Command<KfhOptions>("keyframe_heuristic")
          .Alias("kfh")
          .Group("keyframing")
          .Summary("keep keyframes by distance, rotation, every n-th vertex and shared "
                   "landmarks; merge the others (IMU edges concatenated, landmarks moved)")
          .Access(MapAccess::kModify)
          .Flag("kf_distance_threshold_m", &KfhOptions::kf_distance_threshold_m,
                "a keyframe when this far from the last one [m]")
          .Flag("kf_rotation_threshold_deg", &KfhOptions::kf_rotation_threshold_deg,
                "a keyframe when turned this much from the last one [deg]")
          .Flag("kf_every_nth_vertex", &KfhOptions::kf_every_nth_vertex,
                "a keyframe at least every n-th vertex")
          .Flag("kf_min_shared_landmarks_obs", &KfhOptions::kf_min_shared_landmarks_obs,
                "a keyframe when it shares fewer landmarks with the last one")
          .Flag("map_mission", &KfhOptions::map_mission,
                "mission id, unique prefix or name (default: every mission)", {"mission"})
          .Run([](CommandContext& c, const KfhOptions& o) {
            std::vector<mapstore::MissionId> missions;
            if (!o.map_mission.empty()) {
              missions.push_back(mapping::ResolveMission(c.map(), o.map_mission));
            }
            const mapping::KeyframingSummary summary =
                mapping::KeyframeHeuristic(o, &c.map(), missions, c.progress());
            c.out() << summary.FullReport();
          }));
}

}  // namespace
}  // namespace vilma::console

VILMA_CONSOLE_COMMANDS(vilma::console::Register)
