// Judging dense results (docs/dense.md): eval_mesh against a simulated dataset's true surfaces,
// depth_consistency between neighbouring keyframes (any dataset).
#include <memory>

#include "vilma/console/command_registry.h"
#include "vilma/core/asl_dataset.h"
#include "vilma/core/atomic_file.h"
#include "vilma/mapping/dense/dense_evaluation.h"
#include "vilma/mapping/dense/tsdf_fusion.h"
#include "vilma/mapping/evaluation/map_evaluation.h"
#include "vilma/mapping/evaluation/mesh_evaluation.h"
#include "vilma/mapping/evaluation/true_depth.h"
#include "vilma/mapping/inspection/map_statistics.h"

namespace vilma::console {
namespace {

struct EvalMeshCommandOptions : mapping::MeshEvaluationOptions {
  std::string dataset;
  std::string mesh;  // "" = the session's TSDF
  std::string align = "posyaw";
  std::string mission;
  std::string json;
  std::string error_mesh;  // also write the mesh coloured by error here
  double error_mesh_red_at_m = 0.10;
};

struct TrueDepthCommandOptions : mapping::TrueDepthOptions {
  std::string dataset;
  int camera = 0;
  std::string mission;
};

struct DepthConsistencyCommandOptions : mapping::DepthConsistencyOptions {
  std::string mission;
};

void Register(CommandRegistry* registry) {
  using O = EvalMeshCommandOptions;
  using B = mapping::MeshEvaluationOptions;
  registry->Add(
      Command<O>("eval_mesh")
          .Group("dense")
          .Summary("a mesh against a simulated dataset's true surfaces: accuracy (mesh vertices "
                   "to the surfaces) and completeness (seen surface within a threshold)")
          .Usage("[DATASET]")
          .Access(MapAccess::kRead)
          .PathFlag("dataset", &O::dataset,
                    "vilma-sim dataset folder (sim.yaml, ground truth; required)")
          .Positional("dataset")
          .PathFlag("mesh", &O::mesh, "PLY mesh (default: the session's TSDF surface)")
          .Flag("align", &O::align,
                "map to ground truth by the vertices of --mission: posyaw, se3, sim3 or none "
                "(none: the map frame G is the dataset's world, e.g. a map from its poses)")
          .Flag("mission", &O::mission,
                "missions whose depth views count as seen and whose first gives the alignment "
                "(default: all)",
                {"map_mission"})
          .Flag("completeness_threshold_m", &B::completeness_threshold_m,
                "seen surface within this of the mesh counts as covered [m]")
          .Flag("sample_spacing_m", &B::sample_spacing_m, "true-surface sample grid [m]")
          .Flag("min_view_depth_m", &B::min_view_depth_m, "a view sees surface from this depth [m]")
          .Flag("max_view_depth_m", &B::max_view_depth_m, "... up to this depth [m]")
          .PathFlag("json", &O::json, "also write the figures as JSON to this file")
          .PathFlag("error_mesh_output_file", &O::error_mesh,
                    "also write the mesh coloured by vertex error (green 0, red >= "
                    "error_mesh_red_at_m) as PLY")
          .Flag("error_mesh_red_at_m", &O::error_mesh_red_at_m,
                "vertex error drawn full red in the error mesh [m]")
          .Run([](CommandContext& c, const O& o) {
            if (o.dataset.empty()) throw CommandError("--dataset: expected a vilma-sim dataset folder");
            const mapstore::VIMap& map = c.map();
            sim::World world;
            if (!mapping::LoadDatasetWorld(o.dataset, &world)) {
              throw CommandError(o.dataset + ": expected a vilma-sim dataset (sim.yaml): the true "
                                 "surfaces are known only there");
            }
            const std::vector<mapstore::MissionId> missions = mapping::ResolveMissions(map, o.mission);
            Alignment S_W_G;
            if (o.align != "none") {
              mapping::MapEvaluationOptions align_options;
              if (!ParseAlignmentType(o.align, &align_options.alignment)) {
                throw CommandError("--align: expected posyaw, se3, sim3 or none, got '" + o.align + "'");
              }
              const AslDataset dataset = AslDataset::Open(o.dataset);
              const mapstore::MissionId first = missions.empty() ? map.mission_ids().at(0) : missions[0];
              S_W_G = mapping::EvaluateMap(map, first, dataset.ground_truth(), nullptr, align_options)
                          .trajectory.alignment;
            }
            mapping::TriangleMesh mesh;
            if (!o.mesh.empty()) {
              mesh = mapping::ReadMeshFile(o.mesh);
            } else {
              const auto& derived = c.maps().Get(c.map_key()).derived;
              const auto it = derived.find("tsdf");
              if (it == derived.end()) {
                throw CommandError("--mesh: expected a mesh file, or a TSDF made in this session "
                                   "(create_tsdf_from_depth_resource)");
              }
              mesh = std::static_pointer_cast<mapping::TsdfVolume>(it->second)->ExtractMesh();
            }
            const mapping::MeshEvaluation e =
                mapping::EvaluateMesh(mesh, mapping::DepthViews(map, missions), world, S_W_G, o);
            c.out() << e.FullReport();
            if (!o.error_mesh.empty()) {
              mapping::WriteMeshPly(
                  mapping::ColorMeshByError(mesh, e.vertex_error_m, o.error_mesh_red_at_m),
                  o.error_mesh);
              c.out() << "wrote " << o.error_mesh << "\n";
            }
            if (!o.json.empty()) {
              std::ostringstream json;
              json << "{\"mesh_vertices\": " << e.mesh_vertices
                   << ", \"accuracy_median_m\": " << e.accuracy_m.median
                   << ", \"accuracy_p90_m\": " << e.accuracy_p90_m
                   << ", \"completeness\": " << e.completeness
                   << ", \"seen_samples\": " << e.seen_samples
                   << ", \"covered_samples\": " << e.covered_samples << "}\n";
              WriteFileAtomically(o.json, json.str());
              c.out() << "wrote " << o.json << "\n";
            }
          }));

  using T = TrueDepthCommandOptions;
  registry->Add(
      Command<T>("attach_true_depth")
          .Group("dense")
          .Summary("depth maps ray-cast in a simulated dataset's world from the map's poses "
                   "(maps in the world frame, e.g. map-from-poses with gt): judges TSDF fusion "
                   "apart from stereo")
          .Usage("[DATASET]")
          .Access(MapAccess::kModify)
          .PathFlag("dataset", &T::dataset, "vilma-sim dataset folder (sim.yaml; required)")
          .Positional("dataset")
          .Flag("camera", &T::camera, "rig camera that gets depth")
          .Flag("max_depth_m", &mapping::TrueDepthOptions::max_depth_m,
                "farther surfaces give no depth [m]")
          .Flag("mission", &T::mission,
                kMissionListHelp,
                {"map_mission"})
          .Run([](CommandContext& c, const T& o) {
            sim::World world;
            if (o.dataset.empty() || !mapping::LoadDatasetWorld(o.dataset, &world)) {
              throw CommandError("--dataset: expected a vilma-sim dataset folder (sim.yaml)");
            }
            mapping::TrueDepthOptions options = o;
            options.cameras = {o.camera};
            const int n = mapping::AttachTrueDepth(
                &c.map(), mapping::ResolveMissions(c.map(), o.mission), world, options, c.progress());
            c.out() << n << " true depth maps attached (camera " << o.camera << ")\n";
          }));

  using D = DepthConsistencyCommandOptions;
  registry->Add(
      Command<D>("depth_consistency")
          .Group("dense")
          .Summary("how well the depth maps of neighbouring keyframes agree where they overlap "
                   "(median / p90 of the depth difference)")
          .Access(MapAccess::kRead)
          .Flag("pixel_stride", &mapping::DepthConsistencyOptions::pixel_stride,
                "every n-th pixel in u and v is compared")
          .Flag("mission", &D::mission,
                kMissionListHelp,
                {"map_mission"})
          .Run([](CommandContext& c, const D& o) {
            const mapping::DepthConsistency result = mapping::MeasureDepthConsistency(
                c.map(), mapping::ResolveMissions(c.map(), o.mission), o);
            if (result.pairs == 0) {
              throw CommandError("no two consecutive vertices have depth maps of the same camera");
            }
            c.out() << result.FullReport();
          }));
}

}  // namespace
}  // namespace vilma::console

VILMA_CONSOLE_COMMANDS(vilma::console::Register)
