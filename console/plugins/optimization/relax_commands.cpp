// relax: pose-graph relaxation over loop-closure edges (mapping/optimization/pose_graph.h,
// docs/optimization.md "Relaxation").
#include "vilma/console/command_registry.h"
#include "vilma/mapping/inspection/map_statistics.h"
#include "vilma/mapping/optimization/pose_graph.h"

namespace vilma::console {
namespace {

struct RelaxCommandOptions : mapping::RelaxOptions {
  std::string map_mission;  // "" = every mission
};
using O = RelaxCommandOptions;

void Register(CommandRegistry* registry) {
  registry->Add(
      Command<O>("relax")
          .Group("optimization")
          .Summary("pose-graph relaxation: vertices keep their relative poses and follow the "
                   "loop-closure edges (switchable constraints)")
          .Access(MapAccess::kModify)
          .Flag("relax_odometry_sigma_m", &O::relax_odometry_sigma_m,
                "odometry position noise per sqrt(second) [m]")
          .Flag("relax_odometry_sigma_deg", &O::relax_odometry_sigma_deg,
                "odometry rotation noise per sqrt(second) [deg]")
          .Flag("relax_loop_min_sigma_m", &O::relax_loop_min_sigma_m,
                "floor of a loop edge's position sigma [m]")
          .Flag("relax_loop_min_sigma_deg", &O::relax_loop_min_sigma_deg,
                "floor of a loop edge's rotation sigma [deg]")
          .Flag("relax_robust", &O::relax_robust, "switchable, cauchy or none")
          .Flag("relax_switch_prior_sigma", &O::relax_switch_prior_sigma,
                "sigma of a switch's prior (1 - s)")
          .Flag("relax_cauchy_scale", &O::relax_cauchy_scale, "Cauchy scale [sigmas]")
          .Flag("relax_num_iterations", &O::relax_num_iterations, "solver iterations")
          .Flag("map_mission", &O::map_mission,
                "mission ids, unique prefixes or names, comma separated (default: all)",
                {"mission"})
          .Run([](CommandContext& c, const O& o) {
            try {
              c.out() << mapping::RelaxPoseGraph(o, &c.map(),
                                                 mapping::ResolveMissions(c.map(), o.map_mission),
                                                 c.progress())
                             .FullReport();
            } catch (const std::invalid_argument& e) {
              throw CommandError(e.what());
            }
          }));
}

}  // namespace
}  // namespace vilma::console

VILMA_CONSOLE_COMMANDS(vilma::console::Register)
