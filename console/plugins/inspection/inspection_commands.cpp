// Inspection: map_stats, mission_stats, check_map_consistency, print_baseframes.
#include <iomanip>

#include "vilma/console/command_registry.h"
#include "vilma/mapping/inspection/map_statistics.h"
#include "vilma/mapstore/consistency.h"

namespace vilma::console {
namespace {

struct MissionOptions {
  std::string map_mission;  // empty: every mission
};

void Register(CommandRegistry* registry) {
  registry->Add(
      Command<NoOptions>("map_stats")
          .Alias("ms")
          .Group("inspection")
          .Summary("missions, vertices, edges by type, landmarks by quality, path, duration, size")
          .Access(MapAccess::kRead)
          .Run([](CommandContext& c, const NoOptions&) {
            const mapping::MapStatistics stats = mapping::ComputeMapStatistics(c.map());
            c.out() << "map " << c.map_key() << "\n" << stats.FullReport();
            const std::string folder = c.maps().Get(c.map_key()).folder;
            if (!folder.empty()) {
              c.out() << "on disk " << std::fixed << std::setprecision(2)
                      << mapping::FolderSizeBytes(folder) / 1e6 << std::defaultfloat << " MB ("
                      << folder << ", as last loaded or saved)\n";
            }
          }));
  registry->Add(
      Command<MissionOptions>("mission_stats")
          .Group("inspection")
          .Summary("every statistic of one mission (or of each)")
          .Access(MapAccess::kRead)
          .Flag("map_mission", &MissionOptions::map_mission,
                "mission id, unique id prefix or name (default: every mission)")
          .Positional("map_mission")
          .Run([](CommandContext& c, const MissionOptions& o) {
            const mapping::MapStatistics stats = mapping::ComputeMapStatistics(c.map());
            mapstore::MissionId wanted;
            if (!o.map_mission.empty()) wanted = mapping::ResolveMission(c.map(), o.map_mission);
            for (const mapping::MissionStatistics& m : stats.missions) {
              if (wanted.IsValid() && m.id != wanted) continue;
              c.out() << mapping::MapStatistics::MissionReport(m);
            }
          }));
  registry->Add(
      Command<NoOptions>("check_map_consistency")
          .Alias("cmc")
          .Group("inspection")
          .Summary("check ids, references both ways, vertex chains, IMU samples, resources")
          .Access(MapAccess::kRead)
          .Run([](CommandContext& c, const NoOptions&) {
            const mapstore::ConsistencyReport report = mapstore::CheckMapConsistency(c.map());
            c.out() << report.FullReport() << "\n";
            if (!report.ok()) {
              throw CommandError(std::to_string(report.problems.size()) +
                                 " consistency problems");
            }
          }));
  registry->Add(
      Command<NoOptions>("print_baseframes")
          .Group("inspection")
          .Summary("each mission's T_G_M and whether it is known")
          .Access(MapAccess::kRead)
          .Run([](CommandContext& c, const NoOptions&) {
            for (const mapstore::MissionId& id : c.map().mission_ids()) {
              const mapstore::Mission& m = c.map().mission(id);
              const Eigen::Quaterniond q = m.T_G_M.rotation();
              const Eigen::Vector3d p = m.T_G_M.translation();
              c.out() << id.Hex().substr(0, 8) << " " << (m.baseframe_known ? "known  " : "unknown")
                      << " p_G_M " << p.transpose() << "  q_G_M (w x y z) " << q.w() << " "
                      << q.x() << " " << q.y() << " " << q.z() << "\n";
            }
          }));
}

}  // namespace
}  // namespace vilma::console

VILMA_CONSOLE_COMMANDS(vilma::console::Register)
