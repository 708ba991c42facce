#include "vilma/mapping/evaluation/true_depth.h"

#include <cmath>

#include "vilma/core/error.h"
#include "vilma/mapping/dense/depth_map.h"

namespace vilma::mapping {

std::string TrueDepthOptions::Validate() const {
  if (cameras.empty()) return "cameras: at least one camera index";
  for (int c : cameras) {
    if (c < 0) return "cameras: indices >= 0";
  }
  if (!(max_depth_m > 0.0)) return "max_depth_m: > 0";
  if (!(depth_unit_m > 0.0) || max_depth_m / depth_unit_m > 65535.0) {
    return "depth_unit_m: > 0 and max_depth_m / depth_unit_m <= 65535 (16-bit depth)";
  }
  return "";
}

int AttachTrueDepth(mapstore::VIMap* map, const std::vector<mapstore::MissionId>& missions,
                    const sim::World& world, const TrueDepthOptions& options,
                    ProgressObserver* progress) {
  ThrowIfInvalid(options.Validate(), "true depth options");
  struct Item {
    mapstore::VertexId vertex;
    int camera;
  };
  std::vector<Item> items;
  for (const mapstore::MissionId& mid : missions.empty() ? map->mission_ids() : missions) {
    const SensorRig& rig = map->mission(mid).rig;
    for (int c : options.cameras) {
      if (c >= static_cast<int>(rig.cameras.size())) {
        throw InputError("mission " + mid.Hex() + ": cameras: expected indices below " +
                         std::to_string(rig.cameras.size()) + ", found " + std::to_string(c));
      }
    }
    for (const mapstore::VertexId& vid : map->vertex_ids(mid)) {
      for (int c : options.cameras) {
        if (c < static_cast<int>(map->vertex(vid).frames.size())) items.push_back({vid, c});
      }
    }
  }
  BeginProgress(progress, "true depth", items.size());
  for (std::size_t i = 0; i < items.size(); ++i) {
    const Item& item = items[i];
    const mapstore::Mission& mission = map->mission(map->vertex(item.vertex).mission_id);
    const Camera pinhole = mission.rig.cameras[item.camera].camera.UndistortedPinhole(0.0);
    const Transformation T_G_C = map->T_G_I(item.vertex) * mission.rig.cameras[item.camera].T_I_C;
    DepthMap depth;
    depth.fx = pinhole.fx();
    depth.fy = pinhole.fy();
    depth.cx = pinhole.cx();
    depth.cy = pinhole.cy();
    depth.depth_m = cv::Mat::zeros(pinhole.height(), pinhole.width(), CV_32FC1);
    for (int v = 0; v < pinhole.height(); ++v) {
      float* row = depth.depth_m.ptr<float>(v);
      for (int u = 0; u < pinhole.width(); ++u) {
        const Eigen::Vector3d ray_C((u - depth.cx) / depth.fx, (v - depth.cy) / depth.fy, 1.0);
        const double distance = world.RayCast(T_G_C.translation(), T_G_C.rotation() * ray_C.normalized());
        const double z = distance / ray_C.norm();
        if (std::isfinite(z) && z <= options.max_depth_m) row[u] = static_cast<float>(z);
      }
    }
    std::string bytes = EncodeDepthMap(depth, options.depth_unit_m);
    const mapstore::ResourceId id = DerivedResourceId(item.vertex, item.camera, "depth", bytes);
    map->resources().Add(mapstore::ResourceType::kDepthMap, id, kDepthMapExtension, std::move(bytes));
    map->vertex(item.vertex).frames[item.camera].depth_resource_id = id;
    ReportProgress(progress, i + 1);
  }
  return static_cast<int>(items.size());
}

}  // namespace vilma::mapping
