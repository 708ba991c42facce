#include "vilma/mapping/dense/tum_depth_import.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>

#include "vilma/core/error.h"
#include "vilma/mapping/dense/depth_map.h"

namespace vilma::mapping {
namespace {

struct DepthEntry {
  int64_t t_ns = 0;
  std::string path;
};

std::vector<DepthEntry> ReadDepthList(const std::string& dataset) {
  const std::string list = (std::filesystem::path(dataset) / "depth.txt").string();
  std::ifstream in(list);
  if (!in) throw InputError(list + ": expected the TUM depth list (timestamp filename per line)");
  std::vector<DepthEntry> entries;
  std::string line;
  for (int number = 1; std::getline(in, line); ++number) {
    if (line.empty() || line[0] == '#' || line.find_first_not_of(" \t\r") == std::string::npos) continue;
    std::istringstream words(line);
    double t_s = 0.0;
    std::string file;
    if (!(words >> t_s >> file) || !std::isfinite(t_s) || t_s < 0.0) {
      throw InputError(list + ":" + std::to_string(number) +
                       ": expected 'timestamp[s] filename', found '" + line + "'");
    }
    entries.push_back({static_cast<int64_t>(std::llround(t_s * 1e9)),
                       (std::filesystem::path(dataset) / file).string()});
  }
  if (entries.empty()) throw InputError(list + ": expected at least one depth image, found none");
  std::stable_sort(entries.begin(), entries.end(),
                   [](const DepthEntry& a, const DepthEntry& b) { return a.t_ns < b.t_ns; });
  return entries;
}

}  // namespace

std::string TumDepthImportOptions::Validate() const {
  if (dataset.empty()) return "dataset: a TUM RGB-D folder (depth.txt, depth/)";
  if (camera < 0) return "camera: >= 0";
  if (!(depth_scale_factor > 0.0)) return "depth_scale_factor: > 0";
  if (!(max_time_difference_s >= 0.0)) return "max_time_difference_s: >= 0";
  if (!(depth_unit_m > 0.0)) return "depth_unit_m: > 0";
  return "";
}

std::string TumDepthImportSummary::BriefReport() const {
  std::ostringstream s;
  s << attached << " of " << vertices << " vertices got a depth map (" << depth_images
    << " depth images listed";
  if (no_image_in_time > 0) s << ", " << no_image_in_time << " vertices without one in time";
  if (skipped_existing > 0) s << ", " << skipped_existing << " existing depth maps kept";
  s << ")";
  return s.str();
}

std::string TumDepthImportSummary::FullReport() const { return BriefReport() + "\n"; }

TumDepthImportSummary ImportTumDepth(mapstore::VIMap* map,
                                     const std::vector<mapstore::MissionId>& missions,
                                     const TumDepthImportOptions& options,
                                     ProgressObserver* progress) {
  ThrowIfInvalid(options.Validate(), "TUM depth import options");
  const std::vector<DepthEntry> entries = ReadDepthList(options.dataset);
  TumDepthImportSummary summary;
  summary.depth_images = static_cast<int>(entries.size());
  const std::vector<mapstore::MissionId> selected = missions.empty() ? map->mission_ids() : missions;
  const int64_t max_dt_ns = static_cast<int64_t>(std::llround(options.max_time_difference_s * 1e9));

  struct Match {
    mapstore::VertexId vertex;
    const mapstore::Mission* mission;
    std::size_t entry;
  };
  std::vector<Match> matches;
  for (const mapstore::MissionId& mid : selected) {
    const mapstore::Mission& mission = map->mission(mid);
    if (options.camera >= static_cast<int>(mission.rig.cameras.size())) {
      throw InputError("mission " + mid.Hex() + ": camera: expected a camera index below " +
                       std::to_string(mission.rig.cameras.size()) + ", found " +
                       std::to_string(options.camera));
    }
    for (const mapstore::VertexId& vid : map->vertex_ids(mid)) {
      ++summary.vertices;
      const mapstore::Vertex& v = map->vertex(vid);
      const auto it = std::lower_bound(entries.begin(), entries.end(), v.t_ns,
                                       [](const DepthEntry& e, int64_t t) { return e.t_ns < t; });
      std::size_t best = entries.size();
      int64_t best_dt = max_dt_ns + 1;
      for (auto c = it == entries.begin() ? it : it - 1; c != entries.end() && c <= it; ++c) {
        const int64_t dt = std::llabs(c->t_ns - v.t_ns);
        if (dt < best_dt) {
          best_dt = dt;
          best = static_cast<std::size_t>(c - entries.begin());
        }
      }
      if (best == entries.size()) {
        ++summary.no_image_in_time;
      } else if (!options.overwrite && options.camera < static_cast<int>(v.frames.size()) &&
                 v.frames[options.camera].depth_resource_id.IsValid()) {
        ++summary.skipped_existing;
      } else if (options.camera < static_cast<int>(v.frames.size())) {
        matches.push_back({vid, &mission, best});
      }
    }
  }
  if (matches.empty() && summary.skipped_existing == 0) {
    throw InputError(options.dataset + ": expected depth images within " +
                     std::to_string(options.max_time_difference_s) +
                     " s of the map's vertex times, found none (" + std::to_string(entries.size()) +
                     " images listed)");
  }

  // Decode everything before the map is touched: a bad image leaves the map unchanged.
  struct Result {
    mapstore::VertexId vertex;
    mapstore::ResourceId id;
    std::string bytes;
  };
  std::vector<Result> results;
  BeginProgress(progress, "TUM depth import", matches.size());
  for (std::size_t i = 0; i < matches.size(); ++i) {
    const Match& m = matches[i];
    const std::string& path = entries[m.entry].path;
    const cv::Mat raw = cv::imread(path, cv::IMREAD_UNCHANGED);
    const Camera& camera = m.mission->rig.cameras[options.camera].camera;
    if (raw.empty() || raw.type() != CV_16UC1) {
      throw InputError(path + ": expected a 16-bit one-channel PNG depth image");
    }
    if (raw.cols != camera.width() || raw.rows != camera.height()) {
      throw InputError(path + ": size: expected " + std::to_string(camera.width()) + "x" +
                       std::to_string(camera.height()) + " (camera " +
                       std::to_string(options.camera) + " of the rig), found " +
                       std::to_string(raw.cols) + "x" + std::to_string(raw.rows));
    }
    cv::Mat depth_m;
    raw.convertTo(depth_m, CV_32FC1, 1.0 / options.depth_scale_factor);
    DepthMap depth;
    if (camera.distortion_model() == DistortionModel::kNone) {
      depth.depth_m = depth_m;
      depth.fx = camera.fx();
      depth.fy = camera.fy();
      depth.cx = camera.cx();
      depth.cy = camera.cy();
    } else {
      // Nearest neighbour: depth must not be blended across depth edges.
      const Camera pinhole = camera.UndistortedPinhole(0.0);
      cv::Mat map_x, map_y;
      camera.ComputeUndistortionMaps(pinhole, &map_x, &map_y);
      cv::remap(depth_m, depth.depth_m, map_x, map_y, cv::INTER_NEAREST, cv::BORDER_CONSTANT,
                cv::Scalar(0));
      depth.fx = pinhole.fx();
      depth.fy = pinhole.fy();
      depth.cx = pinhole.cx();
      depth.cy = pinhole.cy();
    }
    std::string bytes = EncodeDepthMap(depth, options.depth_unit_m);
    const mapstore::ResourceId id = DerivedResourceId(m.vertex, options.camera, "depth", bytes);
    results.push_back({m.vertex, id, std::move(bytes)});
    ReportProgress(progress, i + 1);
  }
  for (Result& r : results) {
    map->resources().Add(mapstore::ResourceType::kDepthMap, r.id, kDepthMapExtension, std::move(r.bytes));
    map->vertex(r.vertex).frames[options.camera].depth_resource_id = r.id;
    ++summary.attached;
  }
  return summary;
}

}  // namespace vilma::mapping
