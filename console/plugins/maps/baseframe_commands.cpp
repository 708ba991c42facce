// set_mission_baseframe_to_known / sbk: declares a mission's T_G_M as known (maplab's sbk), so
// that it anchors the global frame G for aam, optvi's gauge and localization maps.
#include "vilma/console/command_registry.h"
#include "vilma/mapping/inspection/map_statistics.h"

namespace vilma::console {
namespace {

struct SbkOptions {
  std::string map_mission;  // empty: the first (oldest) mission
};

void Register(CommandRegistry* registry) {
  registry->Add(
      Command<SbkOptions>("set_mission_baseframe_to_known")
          .Alias("sbk")
          .Group("maps")
          .Usage("[MISSION]")
          .Summary("mark a mission's baseframe T_G_M as known (default: the first, oldest "
                   "mission); T_G_M itself is not changed")
          .Access(MapAccess::kModify)
          .Positional("map_mission")
          .Flag("map_mission", &SbkOptions::map_mission,
                "mission id, unique prefix or name (default: the first mission)", {"mission"})
          .Run([](CommandContext& c, const SbkOptions& o) {
            mapstore::VIMap& map = c.map();
            if (map.mission_ids().empty()) throw CommandError("the map has no mission");
            const mapstore::MissionId id = o.map_mission.empty()
                                               ? map.mission_ids().front()
                                               : mapping::ResolveMission(map, o.map_mission);
            mapstore::Mission& mission = map.mission(id);
            c.out() << "mission " << id.Hex().substr(0, 8)
                    << (mission.name.empty() ? "" : " (" + mission.name + ")") << ": baseframe "
                    << (mission.baseframe_known ? "was already known" : "now known") << "\n";
            mission.baseframe_known = true;
          }));
}

}  // namespace
}  // namespace vilma::console

VILMA_CONSOLE_COMMANDS(vilma::console::Register)
