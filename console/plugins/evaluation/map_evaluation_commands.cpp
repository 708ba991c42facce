// eval_map: the selected map against a dataset's ground truth (mapping/evaluation,
// docs/evaluation.md "Maps").
#include "vilma/console/command_registry.h"
#include "vilma/core/asl_dataset.h"
#include "vilma/mapping/evaluation/map_evaluation.h"
#include "vilma/mapping/inspection/map_statistics.h"

namespace vilma::console {
namespace {

struct EvalMapOptions {
  std::string dataset;      // ASL dataset folder with ground truth
  std::string map_mission;  // "" = the first mission
  std::string align = "posyaw";
  bool world = true;        // landmarks against a simulated dataset's world
  std::string json;         // also write the figures as JSON here
};

void Register(CommandRegistry* registry) {
  registry->Add(
      Command<EvalMapOptions>("eval_map")
          .Group("evaluation")
          .Summary("a mission against a dataset's ground truth: vertex ATE, velocity and bias "
                   "errors, reprojection of good landmarks, landmarks to the simulated surfaces")
          .Access(MapAccess::kRead)
          .Positional("dataset")
          .PathFlag("dataset", &EvalMapOptions::dataset,
                    "ASL dataset folder with mav0/state_groundtruth_estimate0 (required)")
          .Flag("map_mission", &EvalMapOptions::map_mission,
                "mission id, unique prefix or name (default: the first)", {"mission"})
          .Flag("align", &EvalMapOptions::align,
                "alignment of the vertices to the ground truth: posyaw, se3, sim3 or none")
          .Flag("world", &EvalMapOptions::world,
                "distances of good landmarks to the world of a vilma-sim dataset (sim.yaml)")
          .PathFlag("json", &EvalMapOptions::json, "also write the figures as JSON to this file")
          .Run([](CommandContext& c, const EvalMapOptions& o) {
            if (o.dataset.empty()) throw CommandError("--dataset: expected a dataset folder");
            mapping::MapEvaluationOptions options;
            if (!ParseAlignmentType(o.align, &options.alignment)) {
              throw CommandError("--align: expected posyaw, se3, sim3 or none, got '" + o.align +
                                 "'");
            }
            const mapstore::VIMap& map = c.map();
            if (map.mission_ids().empty()) throw CommandError("the map has no mission");
            const mapstore::MissionId mission = o.map_mission.empty()
                                                    ? map.mission_ids().front()
                                                    : mapping::ResolveMission(map, o.map_mission);
            const AslDataset dataset = AslDataset::Open(o.dataset);
            if (dataset.ground_truth().empty()) {
              throw CommandError(o.dataset + ": no ground truth (mav0/state_groundtruth_estimate0)");
            }
            sim::World world;
            const bool has_world = o.world && mapping::LoadDatasetWorld(o.dataset, &world);
            const mapping::MapEvaluation e = mapping::EvaluateMap(
                map, mission, dataset.ground_truth(), has_world ? &world : nullptr, options);
            c.out() << e.FullReport();
            if (!o.json.empty()) {
              WriteFileAtomically(o.json, e.ToJson() + "\n");
              c.out() << "wrote " << o.json << "\n";
            }
          }));
}

}  // namespace
}  // namespace vilma::console

VILMA_CONSOLE_COMMANDS(vilma::console::Register)
