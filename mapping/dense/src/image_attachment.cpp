#include "vilma/mapping/dense/image_attachment.h"

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <limits>
#include <sstream>
#include <stdexcept>

#include "vilma/core/asl_dataset.h"
#include "vilma/core/error.h"
#include "vilma/mapping/image_resources.h"

namespace vilma::mapping {
namespace {

using mapstore::MissionId;
using mapstore::ResourceId;
using mapstore::VertexId;

// One image to store.
struct Planned {
  VertexId vertex_id;
  uint32_t camera = 0;
  ResourceId resource_id;
  bool replaces = false;
  const std::string* image_path = nullptr;
  std::string png;
};

// The frame of `frames` (sorted by time) nearest to t_ns; nullptr if empty.
const CameraFrame* Nearest(const std::vector<CameraFrame>& frames, int64_t t_ns) {
  if (frames.empty()) return nullptr;
  const auto it = std::lower_bound(frames.begin(), frames.end(), t_ns,
                                   [](const CameraFrame& f, int64_t t) { return f.t_ns < t; });
  if (it == frames.end()) return &frames.back();
  if (it == frames.begin()) return &*it;
  const auto before = it - 1;
  return (t_ns - before->t_ns <= it->t_ns - t_ns) ? &*before : &*it;
}

std::string Seconds(int64_t t_ns) {
  std::ostringstream s;
  s << std::fixed << std::setprecision(3) << static_cast<double>(t_ns) * 1e-9;
  return s.str();
}

}  // namespace

std::string ImageAttachmentOptions::Validate() const {
  if (dataset.empty()) return "dataset: an ASL / EuRoC dataset folder";
  if (!std::isfinite(max_time_difference_s) || max_time_difference_s < 0.0) {
    return "max_time_difference_s: expected >= 0 [s]";
  }
  return "";
}

std::string ImageAttachmentSummary::BriefReport() const {
  std::ostringstream s;
  s << "attach_images: " << attached << " images attached";
  if (replaced > 0) s << ", " << replaced << " replaced";
  s << " (" << std::fixed << std::setprecision(1) << static_cast<double>(png_bytes) / 1e6
    << " MB PNG, largest time difference " << std::setprecision(3) << max_time_difference_s * 1e3
    << " ms); " << frames << " frames of " << vertices << " vertices in " << missions
    << " missions: " << missing << " without an image within the tolerance, " << skipped_existing
    << " already had one (kept)";
  return s.str();
}

std::string ImageAttachmentSummary::FullReport() const {
  std::string full = BriefReport() + "\n";
  for (const std::string& w : warnings) full += "  warning: " + w + "\n";
  return full;
}

ImageAttachmentSummary AttachImages(const ImageAttachmentOptions& options,
                                    const std::vector<MissionId>& missions, mapstore::VIMap* map,
                                    ProgressObserver* progress) {
  const std::string problem = options.Validate();
  if (!problem.empty()) throw std::invalid_argument("attach images: " + problem);
  const AslDataset dataset = AslDataset::Open(options.dataset);
  ImageAttachmentSummary summary;
  summary.warnings = dataset.warnings();
  if (dataset.cameras().empty()) {
    throw InputError(FormatInputError(options.dataset, "mav0/cam<i>", "camera folders"));
  }
  const std::vector<MissionId> selected = missions.empty() ? map->mission_ids() : missions;
  const int64_t tolerance_ns = std::llround(options.max_time_difference_s * 1e9);

  // 1. What to attach: every vertex camera with a dataset image within the tolerance.
  std::vector<Planned> planned;
  int64_t matched = 0;  // vertex cameras with an image in time (planned or already imaged)
  int64_t t_vertex_min = std::numeric_limits<int64_t>::max();
  int64_t t_vertex_max = std::numeric_limits<int64_t>::min();
  for (const MissionId& mission_id : selected) {
    const mapstore::Mission& mission = map->mission(mission_id);
    ++summary.missions;
    // Cameras: the rig's, or (no rig recorded) as many as the vertices have frames.
    std::size_t num_cameras = mission.rig.cameras.size();
    if (num_cameras == 0) {
      for (const VertexId& vid : map->vertex_ids(mission_id)) {
        num_cameras = std::max(num_cameras, map->vertex(vid).frames.size());
      }
    }
    if (dataset.cameras().size() < num_cameras) {
      throw InputError(FormatInputError(
          options.dataset, "mav0/cam<i>",
          std::to_string(num_cameras) + " cameras, as the rig of mission " + mission_id.Hex() +
              (mission.name.empty() ? "" : " (" + mission.name + ")") + " has; found " +
              std::to_string(dataset.cameras().size())));
    }
    if (dataset.cameras().size() > num_cameras) {
      std::string unused;
      for (std::size_t c = num_cameras; c < dataset.cameras().size(); ++c) {
        unused += (unused.empty() ? "" : ", ") + dataset.cameras()[c].name;
      }
      summary.warnings.push_back("mission " + mission_id.Hex().substr(0, 8) + " has " +
                                 std::to_string(num_cameras) + " camera(s): dataset " + unused +
                                 " not used");
    }
    for (const VertexId& vid : map->vertex_ids(mission_id)) {
      const mapstore::Vertex& v = map->vertex(vid);
      ++summary.vertices;
      t_vertex_min = std::min(t_vertex_min, v.t_ns);
      t_vertex_max = std::max(t_vertex_max, v.t_ns);
      const std::size_t cameras = std::min(num_cameras, v.frames.size());
      for (std::size_t c = 0; c < cameras; ++c) {
        ++summary.frames;
        const int64_t offset_ns =
            c < mission.rig.cameras.size() ? mission.rig.cameras[c].time_offset_ns : 0;
        const int64_t t_cam = v.t_ns - offset_ns;  // rig: t_imu = t_cam + offset
        const CameraFrame* nearest = Nearest(dataset.cameras()[c].frames, t_cam);
        if (nearest == nullptr || std::llabs(nearest->t_ns - t_cam) > tolerance_ns) {
          ++summary.missing;
          continue;
        }
        ++matched;
        const ResourceId& existing = v.frames[c].image_resource_id;
        if (existing.IsValid() && !options.overwrite) {
          ++summary.skipped_existing;
          continue;
        }
        Planned p;
        p.vertex_id = vid;
        p.camera = static_cast<uint32_t>(c);
        p.replaces = existing.IsValid();
        // Replacing keeps the frame's id (the old resource is then overwritten, not orphaned).
        p.resource_id = p.replaces ? existing : ImageResourceId(vid, p.camera);
        p.image_path = &nearest->image_path;
        summary.max_time_difference_s =
            std::max(summary.max_time_difference_s,
                     static_cast<double>(std::llabs(nearest->t_ns - t_cam)) * 1e-9);
        planned.push_back(std::move(p));
      }
    }
  }
  if (matched == 0) {
    const std::vector<CameraFrame>& frames0 = dataset.cameras()[0].frames;
    std::ostringstream tolerance;
    tolerance << options.max_time_difference_s;
    std::string why = "an image within " + tolerance.str() +
                      " s (max_time_difference_s) of a vertex of the selected missions (";
    if (summary.vertices == 0) {
      why += "they have no vertices)";
    } else {
      why += "vertices at " + Seconds(t_vertex_min) + " .. " + Seconds(t_vertex_max) + " s";
      why += frames0.empty() ? ", no cam0 images)"
                             : ", " + dataset.cameras()[0].name + " images at " +
                                   Seconds(frames0.front().t_ns) + " .. " +
                                   Seconds(frames0.back().t_ns) + " s)";
    }
    throw InputError(FormatInputError(options.dataset, "", why + "; the map is unchanged"));
  }

  // 2. Read and encode everything (the map is untouched until all succeeded).
  BeginProgress(progress, "reading and encoding images", planned.size());
  for (std::size_t i = 0; i < planned.size(); ++i) {
    Planned& p = planned[i];
    const cv::Mat image = AslDataset::LoadImage(*p.image_path, /*unchanged=*/true);
    try {
      p.png = EncodeImagePng(image);
    } catch (const std::invalid_argument& e) {
      throw InputError(FormatInputError(*p.image_path, "",
                                        std::string("an image PNG can hold (") + e.what() + ")"));
    }
    summary.png_bytes += static_cast<int64_t>(p.png.size());
    ReportProgress(progress, i + 1);
  }

  // 3. Assign (nothing here throws for valid ids).
  for (Planned& p : planned) {
    map->resources().Add(mapstore::ResourceType::kImage, p.resource_id, "png", std::move(p.png));
    map->vertex(p.vertex_id).frames[p.camera].image_resource_id = p.resource_id;
    ++(p.replaces ? summary.replaced : summary.attached);
  }
  return summary;
}

}  // namespace vilma::mapping
