// Dense reconstruction (maplab's dense-reconstruction plugin; docs/dense.md):
// stereo_dense_reconstruction and import_tum_depth make depth resources,
// create_tsdf_from_depth_resource fuses them into a TSDF volume that the session keeps beside
// the map, export_tsdf writes its surface mesh.
#include <memory>

#include "vilma/console/command_registry.h"
#include "vilma/mapping/dense/stereo_depth.h"
#include "vilma/mapping/dense/tsdf_fusion.h"
#include "vilma/mapping/dense/tum_depth_import.h"
#include "vilma/mapping/inspection/map_statistics.h"

namespace vilma::console {
namespace {

// The session's TSDF of a map (MapStore::Entry::derived): dropped when the map changes.
constexpr const char* kTsdfKey = "tsdf";

struct StereoDenseCommandOptions : mapping::StereoDepthOptions {
  std::string mission;
};

struct TumDepthCommandOptions : mapping::TumDepthImportOptions {
  std::string mission;
};

struct CreateTsdfCommandOptions : mapping::TsdfOptions {
  std::string mission;
};

struct ExportTsdfCommandOptions {
  std::string mesh_file;
  std::string Validate() const {
    return mesh_file.empty() ? "dense_result_mesh_output_file: a .ply file to write" : "";
  }
};

void RegisterStereo(CommandRegistry* registry) {
  using O = StereoDenseCommandOptions;
  using S = mapping::StereoDepthOptions;
  registry->Add(
      Command<O>("stereo_dense_reconstruction")
          .Group("dense")
          .Summary("depth maps of every vertex from its stereo images (rectified, OpenCV "
                   "StereoSGBM), stored as depth resources")
          .Access(MapAccess::kModify)
          .Flag("mission", &O::mission,
                kMissionListHelp,
                {"map_mission"})
          .FlagAt("sgbm_num_disparities", [](O& o) -> int& { return o.sgbm.num_disparities; },
                  "disparity search range [px], a multiple of 16 (depths down to f*B/range)")
          .FlagAt("sgbm_min_disparity", [](O& o) -> int& { return o.sgbm.min_disparity; },
                  "smallest disparity searched [px]")
          .FlagAt("sgbm_block_size", [](O& o) -> int& { return o.sgbm.block_size; },
                  "matched block size [px], odd")
          .FlagAt("sgbm_p1_per_pixel", [](O& o) -> int& { return o.sgbm.p1_per_pixel; },
                  "smoothness penalty of +-1 disparity changes, times block_size^2")
          .FlagAt("sgbm_p2_per_pixel", [](O& o) -> int& { return o.sgbm.p2_per_pixel; },
                  "smoothness penalty of larger disparity changes, times block_size^2 (> p1)")
          .FlagAt("sgbm_uniqueness_ratio", [](O& o) -> int& { return o.sgbm.uniqueness_ratio; },
                  "best match must beat the second by this margin [%]")
          .FlagAt("sgbm_disp12_max_diff", [](O& o) -> int& { return o.sgbm.disp12_max_diff; },
                  "left-right consistency check [px]; < 0: off")
          .FlagAt("sgbm_speckle_window_size",
                  [](O& o) -> int& { return o.sgbm.speckle_window_size; },
                  "largest speckle (blob of disparity) removed [px]; 0: no filter")
          .FlagAt("sgbm_speckle_range", [](O& o) -> int& { return o.sgbm.speckle_range; },
                  "disparity variation within a connected blob [px]")
          .FlagAt("sgbm_mode", [](O& o) -> std::string& { return o.sgbm.mode; },
                  "sgbm (5 paths), hh (8 paths, slower) or 3way")
          .Flag("dense_min_depth_m", &S::min_depth_m, "depths below are dropped [m]")
          .Flag("dense_max_depth_m", &S::max_depth_m, "depths beyond are dropped [m]")
          .Flag("dense_depth_unit_m", &S::depth_unit_m,
                "quantization of the stored 16-bit depth [m]")
          .Flag("dense_rectified_focal_scale", &S::focal_scale,
                "rectified focal length / the left camera's (< 1 keeps more of the image)")
          .FlagAt("stereo_min_baseline_m", [](O& o) -> double& { return o.pairs.min_baseline_m; },
                  "camera pairs with a shorter baseline are not used [m]")
          .FlagAt("stereo_max_axis_angle_deg",
                  [](O& o) -> double& { return o.pairs.max_axis_angle_deg; },
                  "optical axes of a pair at most this far apart [deg]")
          .Flag("overwrite", &S::overwrite, "replace depth maps the frames already have")
          .Run([](CommandContext& c, const O& o) {
            const std::vector<mapstore::MissionId> missions =
                mapping::ResolveMissions(c.map(), o.mission);
            const mapping::StereoDenseSummary summary =
                mapping::StereoDenseReconstruction(&c.map(), missions, o, c.progress());
            c.out() << summary.FullReport();
          }));

  using T = TumDepthCommandOptions;
  using TB = mapping::TumDepthImportOptions;
  registry->Add(
      Command<T>("import_tum_depth")
          .Group("dense")
          .Summary("depth images of a TUM RGB-D dataset (depth.txt, depth/*.png) attached to the "
                   "vertices by time as depth resources")
          .Usage("[DATASET]")
          .Access(MapAccess::kModify)
          .PathFlag("dataset", &TB::dataset, "TUM RGB-D folder with depth.txt and depth/ (required)")
          .Positional("dataset")
          .Flag("camera", &TB::camera, "rig camera the depth is registered to")
          .Flag("depth_scale_factor", &TB::depth_scale_factor,
                "depth image value per metre (TUM: 5000)")
          .Flag("max_time_difference_s", &TB::max_time_difference_s,
                "a vertex takes the nearest depth image within this [s]")
          .Flag("dense_depth_unit_m", &TB::depth_unit_m, "quantization of the stored depth [m]")
          .Flag("overwrite", &TB::overwrite, "replace depth maps the frames already have")
          .Flag("mission", &T::mission,
                kMissionListHelp,
                {"map_mission"})
          .Run([](CommandContext& c, const T& o) {
            const mapping::TumDepthImportSummary summary = mapping::ImportTumDepth(
                &c.map(), mapping::ResolveMissions(c.map(), o.mission), o, c.progress());
            c.out() << summary.FullReport();
          }));
}

void RegisterTsdf(CommandRegistry* registry) {
  using O = CreateTsdfCommandOptions;
  using B = mapping::TsdfOptions;
  registry->Add(
      Command<O>("create_tsdf_from_depth_resource")
          .Group("dense")
          .Summary("fuses the depth resources into a TSDF volume with the map's poses (Open3D); "
                   "the session keeps it for export_tsdf until the map changes")
          .Access(MapAccess::kRead)
          .Flag("dense_tsdf_voxel_size_m", &B::voxel_size_m, "voxel edge [m]")
          .Flag("dense_tsdf_truncation_distance_m", &B::truncation_distance_m,
                "TSDF truncation distance [m] (>= the voxel size)")
          .Flag("dense_tsdf_min_depth_m", &B::min_depth_m, "depth below is not fused [m]")
          .Flag("dense_tsdf_max_depth_m", &B::max_depth_m, "depth beyond is not fused [m]")
          .Flag("dense_tsdf_max_memory_mb", &B::max_memory_mb,
                "stop with an error when the voxels would need more [MiB]")
          .Flag("dense_tsdf_color", &B::color, "gray values from the image resources")
          .Flag("dense_tsdf_threads", &B::threads,
                "OpenMP threads of the integration (1: deterministic timing under load)")
          .Flag("dense_mesh_min_weight", &B::mesh_min_weight,
                "surface seen by fewer depth maps (mean voxel weight) is left out of the mesh")
          .FlagAt("dense_depth_filter_neighbours",
                  [](O& o) -> int& { return o.filter.neighbours; },
                  "depth pixels are checked against this many views before and after (same "
                  "camera); 0: every pixel is fused")
          .FlagAt("dense_depth_filter_min_views",
                  [](O& o) -> int& { return o.filter.min_consistent_views; },
                  "a depth pixel is fused when at least this many of those views confirm it")
          .FlagAt("dense_depth_filter_relative_tolerance",
                  [](O& o) -> double& { return o.filter.relative_tolerance; },
                  "a view confirms a depth within this share of it")
          .Flag("mission", &O::mission,
                kMissionListHelp,
                {"map_mission"})
          .Run([](CommandContext& c, const O& o) {
            mapping::TsdfSummary summary;
            auto volume = std::make_shared<mapping::TsdfVolume>(mapping::FuseDepthResources(
                c.map(), mapping::ResolveMissions(c.map(), o.mission), o, &summary,
                c.progress()));
            c.maps().Get(c.map_key()).derived[kTsdfKey] = volume;
            c.out() << summary.FullReport();
          }));

  using E = ExportTsdfCommandOptions;
  registry->Add(
      Command<E>("export_tsdf")
          .Group("dense")
          .Summary("the surface of the session's TSDF (marching cubes) as a PLY mesh")
          .Usage("[FILE.ply]")
          .Access(MapAccess::kRead)
          .PathFlag("dense_result_mesh_output_file", &E::mesh_file, "PLY file to write (required)")
          .Positional("dense_result_mesh_output_file")
          .Run([](CommandContext& c, const E& o) {
            auto& derived = c.maps().Get(c.map_key()).derived;
            const auto it = derived.find(kTsdfKey);
            if (it == derived.end()) {
              throw CommandError("no TSDF for map '" + c.map_key() +
                                 "': run create_tsdf_from_depth_resource first (a command that "
                                 "changes the map drops its TSDF)");
            }
            const auto& volume = *std::static_pointer_cast<mapping::TsdfVolume>(it->second);
            const mapping::TriangleMesh mesh = volume.ExtractMesh();
            if (mesh.triangles.empty()) {
              throw CommandError("the TSDF holds no surface (no depth near any voxel)");
            }
            mapping::WriteMeshPly(mesh, o.mesh_file);
            c.out() << "wrote " << o.mesh_file << ": " << mesh.vertices.size() << " vertices, "
                    << mesh.triangles.size() << " triangles\n";
          }));
}

void Register(CommandRegistry* registry) {
  RegisterStereo(registry);
  RegisterTsdf(registry);
}

}  // namespace
}  // namespace vilma::console

VILMA_CONSOLE_COMMANDS(vilma::console::Register)
