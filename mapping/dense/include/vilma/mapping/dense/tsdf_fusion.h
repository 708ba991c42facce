// TSDF fusion of a map's depth resources and surface meshes (maplab's
// create_tsdf_from_depth_resource / export_tsdf; docs/dense.md), on Open3D's
// ScalableTSDFVolume: a hashed grid of volume units, each a small uniform TSDF, so that memory
// grows with the observed surface, not with the bounding box. Each depth map D is integrated
// with the map's pose of its camera, T_G_D = T_G_I T_I_C R_C_D (docs/vi-map.md frames); the
// surface is the zero level set, extracted by marching cubes.
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "vilma/core/progress.h"
#include "vilma/mapping/dense/depth_map.h"
#include "vilma/mapping/dense/triangle_mesh.h"
#include "vilma/mapstore/vi_map.h"

namespace vilma::mapping {

struct TsdfOptions {
  double voxel_size_m = 0.10;             // maplab's --dense_tsdf_voxel_size_m
  double truncation_distance_m = 0.30;    // --dense_tsdf_truncation_distance_m
  double min_depth_m = 0.1;               // depth outside [min, max] is not integrated
  double max_depth_m = 6.0;
  int volume_unit_resolution = 16;        // voxels along a volume unit's edge
  int depth_sampling_stride = 4;          // pixels skipped when allocating volume units
  bool color = true;                      // gray values from the image resources
  // Surface where the voxels were observed by fewer depth maps than this (the mean weight of
  // the 8 voxels around a mesh vertex) is left out of the mesh: what a single stray depth put
  // behind a wall, where no other view can carve it, goes (voxblox's mesh min weight).
  double mesh_min_weight = 3.0;
  // Depth pixels that neighbouring views of the same camera do not confirm are not fused
  // (depth_map.h, FilterDepthByNeighbours); neighbours = 0 fuses every pixel.
  DepthFilterOptions filter;
  // The fusion stops with an error (nothing half-done is kept) when the voxels would take more
  // memory than this [MiB]: larger voxels or a shorter max_depth_m bound it.
  double max_memory_mb = 4096.0;
  // OpenMP threads of Open3D's integration. 1 by default: Open3D's threads spin while they
  // wait, so on a loaded 2-core machine 2 threads took 41 s where 1 took 3 s (98 depth maps).
  int threads = 1;
  std::string Validate() const;
};

struct TsdfSummary {
  int depth_maps = 0;
  int missions = 0;
  int skipped_no_depth = 0;  // camera frames without a depth map
  long pixels_fused = 0;
  long pixels_filtered = 0;  // not confirmed by neighbouring views
  long volume_units = 0;
  double memory_mb = 0.0;    // voxel memory of the volume
  std::vector<double> milliseconds_per_integration;
  std::string BriefReport() const;
  std::string FullReport() const;  // the brief report as a line (what the command prints)
};

// A TSDF volume being built. Not copyable; move-only.
class TsdfVolume {
 public:
  explicit TsdfVolume(const TsdfOptions& options);
  ~TsdfVolume();
  TsdfVolume(TsdfVolume&&) noexcept;
  TsdfVolume& operator=(TsdfVolume&&) noexcept;

  // Integrates one depth image (CV_32FC1 metres, 0 = none) of a pinhole view with pose T_G_D;
  // `gray` (CV_32FC1 in [0, 1], same size) or empty.
  void Integrate(const float* depth_m, const float* gray, int width, int height, double fx,
                 double fy, double cx, double cy, const Eigen::Matrix4d& T_G_D);
  long volume_units() const;
  double memory_mb() const;
  // Marching cubes; triangles with a vertex below options().mesh_min_weight are dropped.
  TriangleMesh ExtractMesh() const;
  // Mean weight (number of fused observations) of the 8 voxels around p_G (0 outside).
  double WeightAt(const Eigen::Vector3d& p_G) const;
  const TsdfOptions& options() const { return options_; }

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
  TsdfOptions options_;
};

// Integrates every depth resource of the missions (empty: all), vertex by vertex, loading one
// depth map at a time through the map's bounded resource cache. Throws InputError when no frame
// has a depth map or the memory bound is exceeded; Cancelled through `progress`.
TsdfVolume FuseDepthResources(const mapstore::VIMap& map,
                              const std::vector<mapstore::MissionId>& missions,
                              const TsdfOptions& options, TsdfSummary* summary,
                              ProgressObserver* progress = nullptr);


}  // namespace vilma::mapping
