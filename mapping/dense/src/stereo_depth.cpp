#include "vilma/mapping/dense/stereo_depth.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <iomanip>
#include <map>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <stdexcept>

#include "vilma/core/error.h"

namespace vilma::mapping {
namespace {

constexpr double kDegToRad = M_PI / 180.0;

// Angles between a camera pair that decide whether it can be rectified.
struct PairGeometry {
  Transformation T_i_j;
  double baseline_m = 0.0;
  double axis_angle_deg = 0.0;      // optical axes
  double baseline_angle_deg = 0.0;  // baseline against camera i's x axis (either direction)
};

PairGeometry MeasurePair(const CameraConfig& ci, const CameraConfig& cj) {
  PairGeometry g;
  g.T_i_j = ci.T_I_C.inverse() * cj.T_I_C;
  const Eigen::Vector3d b = g.T_i_j.translation();
  g.baseline_m = b.norm();
  const Eigen::Vector3d z_j = g.T_i_j.rotationMatrix().col(2);
  g.axis_angle_deg = std::acos(std::clamp(z_j.z(), -1.0, 1.0)) / kDegToRad;
  g.baseline_angle_deg =
      g.baseline_m > 0.0 ? std::acos(std::clamp(std::abs(b.x()) / g.baseline_m, 0.0, 1.0)) / kDegToRad
                         : 90.0;
  return g;
}

std::string Fixed(double x, int digits) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(digits) << x;
  return s.str();
}

}  // namespace

std::string StereoPairOptions::Validate() const {
  if (!(min_baseline_m > 0.0)) return "min_baseline_m: > 0";
  if (!(max_axis_angle_deg > 0.0 && max_axis_angle_deg < 90.0)) return "max_axis_angle_deg: in (0, 90)";
  if (!(max_baseline_angle_deg > 0.0 && max_baseline_angle_deg < 90.0)) {
    return "max_baseline_angle_deg: in (0, 90)";
  }
  return "";
}

std::vector<StereoPair> FindStereoPairs(const SensorRig& rig, const StereoPairOptions& options) {
  std::vector<StereoPair> candidates;
  const int n = static_cast<int>(rig.cameras.size());
  for (int i = 0; i < n; ++i) {
    for (int j = i + 1; j < n; ++j) {
      const PairGeometry g = MeasurePair(rig.cameras[i], rig.cameras[j]);
      if (g.baseline_m < options.min_baseline_m || g.axis_angle_deg > options.max_axis_angle_deg ||
          g.baseline_angle_deg > options.max_baseline_angle_deg) {
        continue;
      }
      StereoPair pair;
      pair.baseline_m = g.baseline_m;
      if (g.T_i_j.translation().x() > 0.0) {  // j is on i's +x side: i is the left camera
        pair.left = i;
        pair.right = j;
        pair.T_L_R = g.T_i_j;
      } else {
        pair.left = j;
        pair.right = i;
        pair.T_L_R = g.T_i_j.inverse();
      }
      candidates.push_back(pair);
    }
  }
  std::stable_sort(candidates.begin(), candidates.end(),
                   [](const StereoPair& a, const StereoPair& b) { return a.baseline_m > b.baseline_m; });
  std::vector<StereoPair> pairs;
  std::vector<bool> used(n, false);
  for (const StereoPair& p : candidates) {
    if (used[p.left] || used[p.right]) continue;
    used[p.left] = used[p.right] = true;
    pairs.push_back(p);
  }
  std::sort(pairs.begin(), pairs.end(),
            [](const StereoPair& a, const StereoPair& b) { return a.left < b.left; });
  return pairs;
}

std::string ExplainNoStereoPair(const SensorRig& rig, const StereoPairOptions& options) {
  const int n = static_cast<int>(rig.cameras.size());
  if (n < 2) return "the rig has " + std::to_string(n) + " camera(s); stereo needs two";
  std::string why;
  for (int i = 0; i < n; ++i) {
    for (int j = i + 1; j < n; ++j) {
      const PairGeometry g = MeasurePair(rig.cameras[i], rig.cameras[j]);
      why += (why.empty() ? "" : "; ") + rig.cameras[i].name + "/" + rig.cameras[j].name +
             ": baseline " + Fixed(g.baseline_m, 3) + " m (>= " + Fixed(options.min_baseline_m, 3) +
             "), optical axes " + Fixed(g.axis_angle_deg, 1) + " deg apart (<= " +
             Fixed(options.max_axis_angle_deg, 1) + "), baseline " + Fixed(g.baseline_angle_deg, 1) +
             " deg off the image x axis (<= " + Fixed(options.max_baseline_angle_deg, 1) + ")";
    }
  }
  return why;
}

StereoRectification ComputeStereoRectification(const Camera& left, const Camera& right,
                                               const Transformation& T_L_R, double focal_scale) {
  StereoRectification r;
  const Eigen::Vector3d b = T_L_R.translation();
  r.baseline_m = b.norm();
  const Eigen::Matrix3d R_L_R = T_L_R.rotationMatrix();
  const Eigen::Vector3d x_D = b.normalized();
  Eigen::Vector3d z_D = Eigen::Vector3d::UnitZ() + R_L_R.col(2);
  z_D = (z_D - z_D.dot(x_D) * x_D).normalized();
  const Eigen::Vector3d y_D = z_D.cross(x_D);
  r.R_L_D.col(0) = x_D;
  r.R_L_D.col(1) = y_D;
  r.R_L_D.col(2) = z_D;
  r.R_R_D = R_L_R.transpose() * r.R_L_D;
  r.width = left.width();
  r.height = left.height();
  r.f = focal_scale * 0.5 * (left.fx() + left.fy());
  r.cx = left.cx();
  r.cy = left.cy();

  // Remap tables: pixel of D -> ray -> the camera's pixel (its own distortion model).
  auto make_maps = [&r](const Camera& camera, const Eigen::Matrix3d& R_C_D, cv::Mat* map_x,
                        cv::Mat* map_y) {
    map_x->create(r.height, r.width, CV_32FC1);
    map_y->create(r.height, r.width, CV_32FC1);
    for (int v = 0; v < r.height; ++v) {
      float* mx = map_x->ptr<float>(v);
      float* my = map_y->ptr<float>(v);
      for (int u = 0; u < r.width; ++u) {
        const Eigen::Vector3d p_C = R_C_D * Eigen::Vector3d((u - r.cx) / r.f, (v - r.cy) / r.f, 1.0);
        Eigen::Vector2d kp;
        const Camera::ProjectionResult result = camera.Project(p_C, &kp);
        const bool usable = result == Camera::ProjectionResult::kValid;
        mx[u] = usable ? static_cast<float>(kp.x()) : -1.0f;
        my[u] = usable ? static_cast<float>(kp.y()) : -1.0f;
      }
    }
  };
  make_maps(left, r.R_L_D, &r.map_left_x, &r.map_left_y);
  make_maps(right, r.R_R_D, &r.map_right_x, &r.map_right_y);
  return r;
}

std::string SgbmOptions::Validate() const {
  if (num_disparities < 16 || num_disparities % 16 != 0) return "num_disparities: a positive multiple of 16";
  if (block_size < 1 || block_size > 21 || block_size % 2 == 0) return "block_size: odd, 1..21";
  if (p1_per_pixel < 0 || p2_per_pixel <= p1_per_pixel) return "p2_per_pixel: > p1_per_pixel >= 0";
  if (uniqueness_ratio < 0 || uniqueness_ratio > 100) return "uniqueness_ratio: 0..100 [%]";
  if (speckle_window_size < 0 || speckle_range < 0) return "speckle_window_size, speckle_range: >= 0";
  if (pre_filter_cap < 1) return "pre_filter_cap: >= 1";
  if (mode != "sgbm" && mode != "hh" && mode != "3way") return "mode: sgbm, hh or 3way";
  return "";
}

std::string StereoDepthOptions::Validate() const {
  if (std::string e = pairs.Validate(); !e.empty()) return e;
  if (std::string e = sgbm.Validate(); !e.empty()) return e;
  if (!(focal_scale > 0.1 && focal_scale <= 2.0)) return "focal_scale: in (0.1, 2]";
  if (!(min_depth_m > 0.0 && max_depth_m > min_depth_m)) return "min_depth_m, max_depth_m: 0 < min < max";
  if (!(depth_unit_m > 0.0) || max_depth_m / depth_unit_m > 65535.0) {
    return "depth_unit_m: > 0 and max_depth_m / depth_unit_m <= 65535 (16-bit depth)";
  }
  return "";
}

DepthMap ComputeStereoDepth(const StereoRectification& rectification, const cv::Mat& left_image,
                            const cv::Mat& right_image, const StereoDepthOptions& options) {
  const StereoRectification& r = rectification;
  cv::Mat left_rect, right_rect;
  cv::remap(left_image, left_rect, r.map_left_x, r.map_left_y, cv::INTER_LINEAR,
            cv::BORDER_CONSTANT, cv::Scalar(0));
  cv::remap(right_image, right_rect, r.map_right_x, r.map_right_y, cv::INTER_LINEAR,
            cv::BORDER_CONSTANT, cv::Scalar(0));

  const SgbmOptions& s = options.sgbm;
  const int mode = s.mode == "hh" ? cv::StereoSGBM::MODE_HH
                   : s.mode == "3way" ? cv::StereoSGBM::MODE_SGBM_3WAY
                                      : cv::StereoSGBM::MODE_SGBM;
  const int area = s.block_size * s.block_size;
  cv::Ptr<cv::StereoSGBM> sgbm = cv::StereoSGBM::create(
      s.min_disparity, s.num_disparities, s.block_size, s.p1_per_pixel * area,
      s.p2_per_pixel * area, s.disp12_max_diff, s.pre_filter_cap, s.uniqueness_ratio,
      s.speckle_window_size, s.speckle_range, mode);
  cv::Mat disparity_16;  // CV_16S, 16 x disparity
  sgbm->compute(left_rect, right_rect, disparity_16);

  DepthMap depth;
  depth.fx = depth.fy = r.f;
  depth.cx = r.cx;
  depth.cy = r.cy;
  depth.q_C_D = Eigen::Quaterniond(r.R_L_D);
  depth.depth_m = cv::Mat::zeros(r.height, r.width, CV_32FC1);
  const double f_times_b = r.f * r.baseline_m;
  for (int v = 0; v < r.height; ++v) {
    const int16_t* d = disparity_16.ptr<int16_t>(v);
    const float* lx = r.map_left_x.ptr<float>(v);
    const float* rx = r.map_right_x.ptr<float>(v);
    float* z = depth.depth_m.ptr<float>(v);
    for (int u = 0; u < r.width; ++u) {
      // Pixels that map outside either camera were filled with black: no depth there.
      if (lx[u] < 0.0f || d[u] <= 0) continue;
      const int u_right = u - (d[u] + 8) / 16;
      if (u_right < 0 || rx[u_right] < 0.0f) continue;
      const double depth_m = f_times_b / (d[u] / 16.0);
      if (depth_m >= options.min_depth_m && depth_m <= options.max_depth_m) {
        z[u] = static_cast<float>(depth_m);
      }
    }
  }
  return depth;
}

cv::Mat LoadGrayImage(const mapstore::VIMap& map, const mapstore::VertexId& vertex, int camera) {
  const std::string where = "vertex " + vertex.Hex() + " camera " + std::to_string(camera);
  const mapstore::Vertex& v = map.vertex(vertex);
  if (camera < 0 || camera >= static_cast<int>(v.frames.size()) ||
      !v.frames[camera].image_resource_id.IsValid()) {
    throw InputError(where + ": image_resource_id: expected an image, found none");
  }
  const mapstore::ResourceId& id = v.frames[camera].image_resource_id;
  const std::shared_ptr<const std::string> bytes =
      map.resources().Load(mapstore::ResourceType::kImage, id);
  const cv::Mat image = cv::imdecode(std::vector<uint8_t>(bytes->begin(), bytes->end()),
                                     cv::IMREAD_GRAYSCALE);
  if (image.empty()) {
    throw InputError(where + " image resource " + id.Hex() + ": expected a PNG or JPEG image");
  }
  return image;
}

std::string StereoDenseSummary::BriefReport() const {
  std::vector<double> ms = milliseconds_per_depth_map;
  std::sort(ms.begin(), ms.end());
  std::ostringstream s;
  s << depth_maps << " depth maps from " << pairs_in_rig << " stereo pair(s) over " << vertices
    << " vertices (" << std::fixed << std::setprecision(1) << 100.0 * valid_pixel_share
    << " % of pixels with depth";
  if (!ms.empty()) s << ", " << std::setprecision(1) << ms[ms.size() / 2] << " ms median per map";
  s << ")";
  if (skipped_no_images > 0) s << "; " << skipped_no_images << " pairs without images skipped";
  if (skipped_existing > 0) s << "; " << skipped_existing << " existing depth maps kept";
  return s.str();
}

std::string StereoDenseSummary::FullReport() const { return BriefReport() + "\n"; }

StereoDenseSummary StereoDenseReconstruction(mapstore::VIMap* map,
                                             const std::vector<mapstore::MissionId>& missions,
                                             const StereoDepthOptions& options,
                                             ProgressObserver* progress) {
  ThrowIfInvalid(options.Validate(), "stereo depth options");
  const std::vector<mapstore::MissionId> selected = missions.empty() ? map->mission_ids() : missions;
  StereoDenseSummary summary;

  // Checks first (the map is not touched when they fail): every mission has a pair, and some
  // vertex has images of both cameras of one.
  struct Work {
    mapstore::VertexId vertex;
    StereoPair pair;
    const mapstore::Mission* mission = nullptr;
  };
  std::vector<Work> work;
  std::map<mapstore::MissionId, std::vector<StereoPair>> pairs_of;
  for (const mapstore::MissionId& mid : selected) {
    const mapstore::Mission& mission = map->mission(mid);
    const std::vector<StereoPair> pairs = FindStereoPairs(mission.rig, options.pairs);
    if (pairs.empty()) {
      throw InputError("mission " + mid.Hex() + " (" + mission.name +
                       "): no camera pair of its rig can be rectified for stereo: " +
                       ExplainNoStereoPair(mission.rig, options.pairs));
    }
    summary.pairs_in_rig = std::max(summary.pairs_in_rig, static_cast<int>(pairs.size()));
    pairs_of[mid] = pairs;
    for (const mapstore::VertexId& vid : map->vertex_ids(mid)) {
      ++summary.vertices;
      const mapstore::Vertex& v = map->vertex(vid);
      for (const StereoPair& p : pairs) {
        const int n_frames = static_cast<int>(v.frames.size());
        if (p.right >= n_frames || !v.frames[p.left].image_resource_id.IsValid() ||
            !v.frames[p.right].image_resource_id.IsValid()) {
          ++summary.skipped_no_images;
          continue;
        }
        if (!options.overwrite && v.frames[p.left].depth_resource_id.IsValid()) {
          ++summary.skipped_existing;
          continue;
        }
        work.push_back({vid, p, &mission});
      }
    }
  }
  if (work.empty() && summary.skipped_existing == 0) {
    throw InputError("no vertex of the selected missions has images of both cameras of a stereo "
                     "pair (attach them with attach_images --dataset DIR, or build the map "
                     "with the map builder's keep_images option)");
  }

  // Rectification per (mission, pair): the maps are computed once.
  std::map<std::pair<mapstore::MissionId, int>, StereoRectification> rectifications;
  BeginProgress(progress, "stereo depth", work.size());
  double valid_share_sum = 0.0;
  for (std::size_t i = 0; i < work.size(); ++i) {
    const Work& w = work[i];
    const auto key = std::make_pair(w.mission->id, w.pair.left);
    auto it = rectifications.find(key);
    if (it == rectifications.end()) {
      const SensorRig& rig = w.mission->rig;
      it = rectifications
               .emplace(key, ComputeStereoRectification(rig.cameras[w.pair.left].camera,
                                                        rig.cameras[w.pair.right].camera,
                                                        w.pair.T_L_R, options.focal_scale))
               .first;
    }
    const cv::Mat left = LoadGrayImage(*map, w.vertex, w.pair.left);
    const cv::Mat right = LoadGrayImage(*map, w.vertex, w.pair.right);
    const auto start = std::chrono::steady_clock::now();
    const DepthMap depth = ComputeStereoDepth(it->second, left, right, options);
    summary.milliseconds_per_depth_map.push_back(
        std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - start).count());
    valid_share_sum += static_cast<double>(depth.ValidPixels()) / (depth.width() * depth.height());
    std::string bytes = EncodeDepthMap(depth, options.depth_unit_m);
    const mapstore::ResourceId id = DerivedResourceId(w.vertex, w.pair.left, "depth", bytes);
    map->resources().Add(mapstore::ResourceType::kDepthMap, id, kDepthMapExtension, std::move(bytes));
    map->vertex(w.vertex).frames[w.pair.left].depth_resource_id = id;
    ++summary.depth_maps;
    ReportProgress(progress, i + 1);
  }
  if (summary.depth_maps > 0) summary.valid_pixel_share = valid_share_sum / summary.depth_maps;
  return summary;
}

}  // namespace vilma::mapping
