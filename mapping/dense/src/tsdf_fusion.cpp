#include "vilma/mapping/dense/tsdf_fusion.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <iomanip>
#include <map>
#include <omp.h>
#include <open3d/geometry/Image.h>
#include <open3d/geometry/RGBDImage.h>
#include <open3d/geometry/TriangleMesh.h>
#include <open3d/pipelines/integration/ScalableTSDFVolume.h>
#include <open3d/pipelines/integration/UniformTSDFVolume.h>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <tuple>

#include "vilma/core/error.h"
#include "vilma/mapping/dense/depth_map.h"
#include "vilma/mapping/dense/stereo_depth.h"

namespace vilma::mapping {

namespace integration = open3d::pipelines::integration;

std::string TsdfOptions::Validate() const {
  if (!(voxel_size_m > 0.0)) return "voxel_size_m: > 0";
  if (!(truncation_distance_m >= voxel_size_m)) return "truncation_distance_m: >= voxel_size_m";
  if (!(min_depth_m >= 0.0 && max_depth_m > min_depth_m)) return "min_depth_m, max_depth_m: 0 <= min < max";
  if (volume_unit_resolution < 4 || volume_unit_resolution > 64) return "volume_unit_resolution: 4..64";
  if (depth_sampling_stride < 1) return "depth_sampling_stride: >= 1";
  if (!(max_memory_mb > 0.0)) return "max_memory_mb: > 0";
  if (!(mesh_min_weight >= 0.0)) return "mesh_min_weight: >= 0";
  if (threads < 1) return "threads: >= 1";
  if (std::string e = filter.Validate(); !e.empty()) return "filter." + e;
  return "";
}

std::string TsdfSummary::BriefReport() const {
  std::vector<double> ms = milliseconds_per_integration;
  std::sort(ms.begin(), ms.end());
  std::ostringstream s;
  s << std::fixed << std::setprecision(1) << "TSDF: " << depth_maps << " depth maps of " << missions
    << " mission(s) fused, " << volume_units << " volume units, " << memory_mb << " MiB";
  if (!ms.empty()) s << ", " << ms[ms.size() / 2] << " ms median per integration";
  if (pixels_filtered > 0) {
    s << "; " << std::setprecision(1) << 100.0 * pixels_filtered / std::max(1l, pixels_fused + pixels_filtered)
      << " % of depth pixels not confirmed by a neighbouring view and left out";
  }
  if (skipped_no_depth > 0) s << " (" << skipped_no_depth << " camera frames without depth)";
  return s.str();
}

std::string TsdfSummary::FullReport() const { return BriefReport() + "\n"; }

namespace {

// OpenMP threads of Open3D's integration for one call (TsdfOptions::threads), the caller's
// settings restored after it. Open3D 0.16's loops ask for num_threads(EstimateMaxThreads()):
// the number of physical cores, whatever omp_set_num_threads said, unless OMP_NUM_THREADS or
// OMP_DYNAMIC is in the environment. So one thread is enforced by allowing no active parallel
// level (every region then runs on the calling thread alone); more threads are asked for with
// omp_set_num_threads, which Open3D honours only when one of those variables is set (else it
// takes every core).
class OmpThreadsForCall {
 public:
  explicit OmpThreadsForCall(int threads)
      : num_threads_(omp_get_max_threads()), max_active_levels_(omp_get_max_active_levels()) {
    omp_set_num_threads(threads);
    if (threads == 1) omp_set_max_active_levels(0);
  }
  ~OmpThreadsForCall() {
    omp_set_max_active_levels(max_active_levels_);
    omp_set_num_threads(num_threads_);
  }
  OmpThreadsForCall(const OmpThreadsForCall&) = delete;
  OmpThreadsForCall& operator=(const OmpThreadsForCall&) = delete;

 private:
  int num_threads_;
  int max_active_levels_;
};

}  // namespace

struct TsdfVolume::Impl {
  explicit Impl(const TsdfOptions& o)
      : volume(o.voxel_size_m, o.truncation_distance_m,
               o.color ? integration::TSDFVolumeColorType::Gray32
                       : integration::TSDFVolumeColorType::NoColor,
               o.volume_unit_resolution, o.depth_sampling_stride) {}
  integration::ScalableTSDFVolume volume;
};

TsdfVolume::TsdfVolume(const TsdfOptions& options) : options_(options) {
  ThrowIfInvalid(options.Validate(), "TSDF options");
  impl_ = std::make_unique<Impl>(options);
}
TsdfVolume::~TsdfVolume() = default;
TsdfVolume::TsdfVolume(TsdfVolume&&) noexcept = default;
TsdfVolume& TsdfVolume::operator=(TsdfVolume&&) noexcept = default;

void TsdfVolume::Integrate(const float* depth_m, const float* gray, int width, int height,
                           double fx, double fy, double cx, double cy,
                           const Eigen::Matrix4d& T_G_D) {
  open3d::geometry::Image depth, color;
  depth.Prepare(width, height, 1, 4);
  color.Prepare(width, height, 1, 4);
  float* d = depth.PointerAs<float>();
  float* c = color.PointerAs<float>();
  const std::size_t n = static_cast<std::size_t>(width) * height;
  for (std::size_t i = 0; i < n; ++i) {
    const float z = depth_m[i];
    d[i] = std::isfinite(z) && z >= options_.min_depth_m && z <= options_.max_depth_m ? z : 0.0f;
    c[i] = gray != nullptr ? gray[i] : 0.7f;
  }
  // depth_scale 1 (metres already), depth_trunc max_depth_m, keep the gray channel as is.
  const auto rgbd = open3d::geometry::RGBDImage::CreateFromColorAndDepth(
      color, depth, 1.0, options_.max_depth_m, false);
  const open3d::camera::PinholeCameraIntrinsic intrinsic(width, height, fx, fy, cx, cy);
  // Open3D takes the extrinsic as world -> camera: T_D_G.
  const Eigen::Matrix4d T_D_G = T_G_D.inverse();
  const OmpThreadsForCall threads(options_.threads);
  impl_->volume.Integrate(*rgbd, intrinsic, T_D_G);
}

long TsdfVolume::volume_units() const { return static_cast<long>(impl_->volume.volume_units_.size()); }

double TsdfVolume::memory_mb() const {
  const double voxels_per_unit = std::pow(options_.volume_unit_resolution, 3);
  return volume_units() * voxels_per_unit * sizeof(open3d::geometry::TSDFVoxel) / (1024.0 * 1024.0);
}

double TsdfVolume::WeightAt(const Eigen::Vector3d& p_G) const {
  const integration::ScalableTSDFVolume& volume = impl_->volume;
  const double voxel = options_.voxel_size_m;
  const int resolution = options_.volume_unit_resolution;
  // Voxel centres sit at (i + 0.5) * voxel; the 8 around p are floor(p / voxel - 0.5) + {0, 1}.
  const Eigen::Vector3d g = p_G / voxel - Eigen::Vector3d::Constant(0.5);
  const Eigen::Vector3i base(static_cast<int>(std::floor(g.x())), static_cast<int>(std::floor(g.y())),
                             static_cast<int>(std::floor(g.z())));
  double sum = 0.0;
  for (int corner = 0; corner < 8; ++corner) {
    const Eigen::Vector3i v = base + Eigen::Vector3i(corner & 1, (corner >> 1) & 1, (corner >> 2) & 1);
    const Eigen::Vector3i unit(static_cast<int>(std::floor(static_cast<double>(v.x()) / resolution)),
                               static_cast<int>(std::floor(static_cast<double>(v.y()) / resolution)),
                               static_cast<int>(std::floor(static_cast<double>(v.z()) / resolution)));
    const auto it = volume.volume_units_.find(unit);
    if (it == volume.volume_units_.end() || !it->second.volume_) continue;
    const Eigen::Vector3i local = v - unit * resolution;
    sum += it->second.volume_->voxels_[it->second.volume_->IndexOf(local)].weight_;
  }
  return sum / 8.0;
}

TriangleMesh TsdfVolume::ExtractMesh() const {
  const std::shared_ptr<open3d::geometry::TriangleMesh> o3d = impl_->volume.ExtractTriangleMesh();
  TriangleMesh mesh;
  std::vector<int> new_index(o3d->vertices_.size(), -1);
  for (std::size_t i = 0; i < o3d->vertices_.size(); ++i) {
    if (options_.mesh_min_weight > 0.0 && WeightAt(o3d->vertices_[i]) < options_.mesh_min_weight) continue;
    new_index[i] = static_cast<int>(mesh.vertices.size());
    mesh.vertices.push_back(o3d->vertices_[i]);
    if (options_.color && i < o3d->vertex_colors_.size()) mesh.colors.push_back(o3d->vertex_colors_[i]);
  }
  for (const Eigen::Vector3i& t : o3d->triangles_) {
    const Eigen::Vector3i n(new_index[t[0]], new_index[t[1]], new_index[t[2]]);
    if (n.minCoeff() >= 0) mesh.triangles.push_back(n);
  }
  // Vertices whose triangles all went are dropped too.
  std::vector<int> used(mesh.vertices.size(), 0);
  for (const Eigen::Vector3i& t : mesh.triangles) used[t[0]] = used[t[1]] = used[t[2]] = 1;
  TriangleMesh compact;
  std::vector<int> remap(mesh.vertices.size(), -1);
  for (std::size_t i = 0; i < mesh.vertices.size(); ++i) {
    if (!used[i]) continue;
    remap[i] = static_cast<int>(compact.vertices.size());
    compact.vertices.push_back(mesh.vertices[i]);
    if (!mesh.colors.empty()) compact.colors.push_back(mesh.colors[i]);
  }
  for (const Eigen::Vector3i& t : mesh.triangles) compact.triangles.emplace_back(remap[t[0]], remap[t[1]], remap[t[2]]);
  return compact;
}

namespace {

// Gray values of a depth view D from the camera's image: remap tables from D's pixels to the
// camera's (its own distortion model), cached per (mission, camera, view).
class GrayViewCache {
 public:
  cv::Mat GrayOfView(const mapstore::VIMap& map, const mapstore::Mission& mission,
                     const mapstore::VertexId& vertex, int camera, const DepthMap& depth) {
    const Key key{mission.id, camera, depth.width(), depth.height(), depth.fx, depth.fy,
                  depth.cx, depth.cy, depth.q_C_D.w(), depth.q_C_D.x(), depth.q_C_D.y(),
                  depth.q_C_D.z()};
    auto it = maps_.find(key);
    if (it == maps_.end()) {
      const Camera& model = mission.rig.cameras[camera].camera;
      const Eigen::Matrix3d R_C_D = depth.q_C_D.toRotationMatrix();
      cv::Mat map_x(depth.height(), depth.width(), CV_32FC1), map_y(map_x.size(), CV_32FC1);
      for (int v = 0; v < depth.height(); ++v) {
        for (int u = 0; u < depth.width(); ++u) {
          Eigen::Vector2d kp(-1.0, -1.0);
          const Eigen::Vector3d p_C = R_C_D * Eigen::Vector3d((u - depth.cx) / depth.fx,
                                                              (v - depth.cy) / depth.fy, 1.0);
          if (model.Project(p_C, &kp) != Camera::ProjectionResult::kValid) kp.setConstant(-1.0);
          map_x.at<float>(v, u) = static_cast<float>(kp.x());
          map_y.at<float>(v, u) = static_cast<float>(kp.y());
        }
      }
      it = maps_.emplace(key, std::make_pair(map_x, map_y)).first;
    }
    const cv::Mat image = LoadGrayImage(map, vertex, camera);
    cv::Mat view, gray;
    cv::remap(image, view, it->second.first, it->second.second, cv::INTER_LINEAR,
              cv::BORDER_CONSTANT, cv::Scalar(0));
    view.convertTo(gray, CV_32FC1, 1.0 / 255.0);
    return gray;
  }

 private:
  using Key = std::tuple<mapstore::MissionId, int, int, int, double, double, double, double,
                         double, double, double, double>;
  std::map<Key, std::pair<cv::Mat, cv::Mat>> maps_;
};

}  // namespace

TsdfVolume FuseDepthResources(const mapstore::VIMap& map,
                              const std::vector<mapstore::MissionId>& missions,
                              const TsdfOptions& options, TsdfSummary* summary,
                              ProgressObserver* progress) {
  TsdfSummary local;
  TsdfSummary& s = summary != nullptr ? *summary : local;
  s = TsdfSummary();
  const std::vector<mapstore::MissionId> selected = missions.empty() ? map.mission_ids() : missions;

  struct Item {
    const mapstore::Mission* mission;
    mapstore::VertexId vertex;
    int camera;
  };
  std::vector<Item> items;
  for (const mapstore::MissionId& mid : selected) {
    const mapstore::Mission& mission = map.mission(mid);
    bool any = false;
    for (const mapstore::VertexId& vid : map.vertex_ids(mid)) {
      const mapstore::Vertex& v = map.vertex(vid);
      for (int c = 0; c < static_cast<int>(v.frames.size()); ++c) {
        if (v.frames[c].depth_resource_id.IsValid() && c < static_cast<int>(mission.rig.cameras.size())) {
          items.push_back({&mission, vid, c});
          any = true;
        } else {
          ++s.skipped_no_depth;
        }
      }
    }
    s.missions += any;
  }
  if (items.empty()) {
    throw InputError("no frame of the selected missions has a depth map (compute them with "
                     "stereo_dense_reconstruction, or import RGB-D depth with import_tum_depth)");
  }

  TsdfVolume volume(options);
  GrayViewCache gray_views;
  BeginProgress(progress, "TSDF integration", items.size());
  // Neighbours of an item: the items of the same mission and camera, in vertex order.
  std::map<std::pair<mapstore::MissionId, int>, std::vector<std::size_t>> chains;
  std::vector<std::size_t> position_in_chain(items.size());
  for (std::size_t i = 0; i < items.size(); ++i) {
    std::vector<std::size_t>& chain = chains[{items[i].mission->id, items[i].camera}];
    position_in_chain[i] = chain.size();
    chain.push_back(i);
  }
  // Decoded depth maps and poses of the sliding window of neighbours (bounded memory).
  std::map<std::size_t, std::pair<DepthMap, Eigen::Matrix4d>> window;
  auto posed = [&](std::size_t i) -> const std::pair<DepthMap, Eigen::Matrix4d>& {
    auto it = window.find(i);
    if (it == window.end()) {
      DepthMap d = LoadDepthMap(map, items[i].vertex, items[i].camera);
      const Eigen::Matrix4d T_G_D = DepthViewPose(map, items[i].vertex, items[i].camera, d);
      it = window.emplace(i, std::make_pair(std::move(d), T_G_D)).first;
    }
    return it->second;
  };

  for (std::size_t i = 0; i < items.size(); ++i) {
    const Item& item = items[i];
    DepthMap depth = posed(i).first;
    depth.depth_m = depth.depth_m.clone();  // the window keeps the unfiltered map
    const Eigen::Matrix4d T_G_D = posed(i).second;
    const std::vector<std::size_t>& chain = chains[{item.mission->id, item.camera}];
    const std::size_t at = position_in_chain[i];
    if (options.filter.neighbours > 0) {
      std::vector<PosedDepth> others;
      const std::size_t k = static_cast<std::size_t>(options.filter.neighbours);
      for (std::size_t j = at >= k ? at - k : 0; j <= std::min(chain.size() - 1, at + k); ++j) {
        if (j != at) others.push_back({&posed(chain[j]).first, posed(chain[j]).second});
      }
      s.pixels_filtered += FilterDepthByNeighbours(&depth, T_G_D, others, options.filter);
    }
    s.pixels_fused += depth.ValidPixels();
    // Drop window entries no later item of this chain needs.
    if (at >= static_cast<std::size_t>(options.filter.neighbours)) {
      window.erase(chain[at - static_cast<std::size_t>(options.filter.neighbours)]);
    }
    cv::Mat gray;
    const mapstore::VisualFrame& frame = map.vertex(item.vertex).frames[item.camera];
    if (options.color && frame.image_resource_id.IsValid()) {
      gray = gray_views.GrayOfView(map, *item.mission, item.vertex, item.camera, depth);
    }
    const cv::Mat depth_continuous = depth.depth_m.isContinuous() ? depth.depth_m : depth.depth_m.clone();
    const auto start = std::chrono::steady_clock::now();
    volume.Integrate(depth_continuous.ptr<float>(), gray.empty() ? nullptr : gray.ptr<float>(),
                     depth.width(), depth.height(), depth.fx, depth.fy, depth.cx, depth.cy, T_G_D);
    s.milliseconds_per_integration.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
    ++s.depth_maps;
    if (volume.memory_mb() > options.max_memory_mb) {
      std::ostringstream message;
      message << std::fixed << std::setprecision(0) << "the TSDF would take more than "
              << options.max_memory_mb << " MiB (" << volume.memory_mb() << " MiB after "
              << s.depth_maps << " of " << items.size()
              << " depth maps): raise max_memory_mb, use larger voxels or a smaller max_depth_m";
      throw InputError(message.str());
    }
    ReportProgress(progress, i + 1);
  }
  s.volume_units = volume.volume_units();
  s.memory_mb = volume.memory_mb();
  return volume;
}

}  // namespace vilma::mapping
