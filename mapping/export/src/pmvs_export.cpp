#include "vilma/mapping/export/pmvs_export.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>
#include <sstream>
#include <system_error>
#include <unordered_map>

#include "export_files.h"
#include "export_images.h"
#include "vilma/core/atomic_file.h"
#include "vilma/core/error.h"
#include "vilma/mapping/export/map_plot.h"

namespace vilma::mapping {

using export_files::Exact;
using export_images::ImageUndistorter;
using mapstore::IdHash;
using mapstore::LandmarkId;
using mapstore::MissionId;
using mapstore::VertexId;
using mapstore::VIMap;

namespace {

namespace fs = std::filesystem;

using Matrix34d = Eigen::Matrix<double, 3, 4>;

struct PmvsImage {
  VertexId vertex;
  std::size_t undistorter = 0;  // index into the (mission, rig camera) undistorters
  Transformation T_C_G;         // world (G) to camera
  mapstore::ResourceId resource;
};

struct PmvsView {
  std::size_t image = 0;
  uint32_t keypoint = 0;
  Eigen::Vector2d uv;  // undistorted keypoint, vilma pixels
};

struct PmvsPoint {
  Eigen::Vector3d p_G;
  std::array<uint8_t, 3> rgb{{128, 128, 128}};  // grey until read from an image
  std::vector<PmvsView> views;
};

// The pinhole the images are undistorted to: f = (fx + fy) / 2, principal point at the image
// centre ((w - 1) / 2, (h - 1) / 2 with (0, 0) the centre of the top-left pixel), which is
// Bundler's camera model without distortion.
Camera PmvsPinhole(const Camera& camera) {
  const double f = 0.5 * (camera.fx() + camera.fy());
  return Camera(camera.width(), camera.height(),
                Eigen::Vector4d(f, f, 0.5 * (camera.width() - 1), 0.5 * (camera.height() - 1)),
                DistortionModel::kNone, Eigen::VectorXd());
}

// P = K [R_C_G | t_C_G]: homogeneous p_G to homogeneous pixels of the undistorted image.
Matrix34d ProjectionMatrix(const Camera& pinhole, const Transformation& T_C_G) {
  Matrix34d P;
  P.leftCols<3>() = pinhole.K() * T_C_G.rotationMatrix();
  P.col(3) = pinhole.K() * T_C_G.translation();
  return P;
}

std::string IndexName(std::size_t index, const std::string& extension) {
  char name[32];
  std::snprintf(name, sizeof(name), "%08zu.%s", index, extension.c_str());
  return name;
}

std::string ContourText(const Matrix34d& P) {
  std::string t = "CONTOUR\n";
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 4; ++c) t += (c > 0 ? " " : "") + Exact(P(r, c));
    t += "\n";
  }
  return t;
}

// Bundler v0.3 (Bundler's user manual, "Output format"): cameras, then points with view lists.
std::string BundleText(const std::vector<PmvsImage>& images,
                       const std::vector<ImageUndistorter>& undistorters,
                       const std::vector<PmvsPoint>& points) {
  std::ostringstream s;
  s << "# Bundle file v0.3\n" << images.size() << " " << points.size() << "\n";
  // Bundler's camera frame: x right, y up, looking down -z.
  const Eigen::Matrix3d flip = Eigen::Vector3d(1.0, -1.0, -1.0).asDiagonal();
  for (const PmvsImage& image : images) {
    const Eigen::Matrix3d R = flip * image.T_C_G.rotationMatrix();
    const Eigen::Vector3d t = flip * image.T_C_G.translation();
    s << Exact(undistorters[image.undistorter].target().fx()) << " 0 0\n";
    for (int r = 0; r < 3; ++r) {
      s << Exact(R(r, 0)) << " " << Exact(R(r, 1)) << " " << Exact(R(r, 2)) << "\n";
    }
    s << Exact(t.x()) << " " << Exact(t.y()) << " " << Exact(t.z()) << "\n";
  }
  for (const PmvsPoint& point : points) {
    s << Exact(point.p_G.x()) << " " << Exact(point.p_G.y()) << " " << Exact(point.p_G.z()) << "\n"
      << int{point.rgb[0]} << " " << int{point.rgb[1]} << " " << int{point.rgb[2]} << "\n"
      << point.views.size();
    for (const PmvsView& view : point.views) {
      // Bundler's key positions: origin at the image centre, y up.
      const Camera& pinhole = undistorters[images[view.image].undistorter].target();
      s << " " << view.image << " " << view.keypoint << " " << Exact(view.uv.x() - pinhole.cx())
        << " " << Exact(pinhole.cy() - view.uv.y());
    }
    s << "\n";
  }
  return s.str();
}

// vis.dat (PMVS2 documentation): for every image the images it shares at least `min_shared`
// points with. Counts the pairs into `summary`.
std::string VisText(std::size_t num_images, const std::vector<PmvsPoint>& points, int min_shared,
                    PmvsExportSummary* summary) {
  std::vector<std::map<std::size_t, int>> shared(num_images);
  for (const PmvsPoint& point : points) {
    for (const PmvsView& a : point.views) {
      for (const PmvsView& b : point.views) {
        if (a.image != b.image) ++shared[a.image][b.image];
      }
    }
  }
  std::string t = "VISDATA\n" + std::to_string(num_images) + "\n";
  for (std::size_t i = 0; i < num_images; ++i) {
    std::vector<std::size_t> neighbours;
    for (const auto& [j, count] : shared[i]) {
      if (count >= min_shared) neighbours.push_back(j);  // map order: ascending
    }
    t += std::to_string(i) + " " + std::to_string(neighbours.size());
    for (std::size_t j : neighbours) {
      t += " " + std::to_string(j);
      summary->vis_pairs += j > i;
    }
    t += "\n";
    summary->images_without_neighbours += neighbours.empty();
  }
  return t;
}

// PMVS2's option file (PMVS2 documentation, "Options"); every image is a target image.
std::string OptionText(std::size_t num_images, int threads) {
  return "level 1\ncsize 2\nthreshold 0.7\nwsize 7\nminImageNum 3\nCPU " + std::to_string(threads) +
         "\nsetEdge 0\nuseBound 0\nuseVisData 1\nsequence -1\ntimages -1 0 " +
         std::to_string(num_images) + "\noimages 0\n";
}

// An 8-bit, 3-channel (BGR) copy of a decoded picture for JPEG: PMVS2 reads colour images only.
cv::Mat ToBgr8(const cv::Mat& picture) {
  cv::Mat eight = picture;
  if (picture.depth() == CV_16U) picture.convertTo(eight, CV_8U, 1.0 / 256.0);
  cv::Mat bgr;
  if (eight.channels() == 1) {
    cv::cvtColor(eight, bgr, cv::COLOR_GRAY2BGR);
  } else if (eight.channels() == 4) {
    cv::cvtColor(eight, bgr, cv::COLOR_BGRA2BGR);
  } else {
    bgr = eight;
  }
  return bgr;
}

// `out` must name a folder to make: absent, or an empty folder. Returns the path without a
// trailing '/'.
fs::path CheckOutputFolder(const std::string& out) {
  fs::path path(out);
  while (path.has_relative_path() && path.filename().empty()) path = path.parent_path();
  std::error_code error;
  if (fs::exists(path, error)) {
    if (!fs::is_directory(path, error)) {
      throw InputError(FormatInputError("--out", path.string(),
                                        "expected a folder to make, found a file of that name"));
    }
    if (!fs::is_empty(path, error) || error) {
      throw InputError(FormatInputError(
          "--out", path.string(),
          "expected a new or empty folder, found one with files (remove it or choose another)"));
    }
  }
  const fs::path partial = path.string() + ".partial";
  if (fs::exists(partial, error)) {
    throw InputError(FormatInputError(
        "--out", partial.string(),
        "expected no such folder (left by an interrupted export_for_pmvs? remove it)"));
  }
  return path;
}

}  // namespace

std::string PmvsExportOptions::Validate() const {
  if (out.empty()) return "out: expected the folder to write the PMVS2 input into";
  std::array<bool, 3> keep;
  const std::string qualities = ParseLandmarkQualities(landmarks, &keep);
  if (!qualities.empty()) return "landmarks: expected " + qualities;
  if (min_observations < 2) return "min_observations: expected an integer >= 2";
  if (min_covisible_landmarks < 1) return "min_covisible_landmarks: expected an integer >= 1";
  if (jpeg_quality < 1 || jpeg_quality > 100) return "jpeg_quality: expected 1 .. 100";
  if (threads < 1) return "threads: expected an integer >= 1";
  return "";
}

std::string PmvsExportSummary::BriefReport() const {
  const std::string full = FullReport();
  return full.substr(0, full.find('\n'));
}

std::string PmvsExportSummary::FullReport() const {
  std::ostringstream s;
  s << "pmvs: " << images << " images (" << frames_without_image << " frames without image), "
    << points << " points, " << observations << " observations in " << folder
    << " (world = frame G)\n";
  s << "  reprojection error mean " << mean_reprojection_error_px << " px, max "
    << max_reprojection_error_px << " px; landmarks left out: " << landmarks_skipped_quality
    << " by quality, " << landmarks_skipped_track << " by observations; observations dropped "
    << observations_dropped << "\n";
  s << "  vis.dat: " << vis_pairs << " image pairs, " << images_without_neighbours
    << " images without neighbours\n";
  s << "  run: pmvs2 " << folder << "/ option-0000\n";
  return s.str();
}

PmvsExportSummary ExportPmvs(const VIMap& map, const PmvsExportOptions& options,
                             ProgressObserver* progress) {
  ThrowIfInvalid(options.Validate(), "export_for_pmvs");
  std::array<bool, 3> keep_quality;
  ParseLandmarkQualities(options.landmarks, &keep_quality);
  const std::vector<MissionId> missions =
      export_files::MissionsToExport(map, options.missions, "mission");
  PmvsExportSummary summary;

  // Images: the camera frames with an image resource, in mission, time, camera order.
  std::vector<ImageUndistorter> undistorters;  // per (mission, rig camera)
  std::vector<PmvsImage> images;
  // Per vertex and rig camera: the image index, or -1 without image.
  std::unordered_map<VertexId, std::vector<int64_t>, IdHash> image_of_frame;
  for (const MissionId& mission_id : missions) {
    const mapstore::Mission& mission = map.mission(mission_id);
    if (mission.rig.cameras.empty()) {
      throw InputError(FormatInputError("mission " + mission.id.Hex(), "rig",
                                        "expected a recorded sensor rig (no camera)"));
    }
    const std::size_t first_undistorter = undistorters.size();
    for (const CameraConfig& camera : mission.rig.cameras) {
      undistorters.emplace_back(camera.camera, PmvsPinhole(camera.camera));
    }
    for (const VertexId& vertex_id : VerticesInTimeOrder(map, mission.id)) {
      const mapstore::Vertex& vertex = map.vertex(vertex_id);
      const Transformation T_G_I = map.T_G_I(vertex_id);
      std::vector<int64_t>& frame_images = image_of_frame[vertex_id];
      const std::size_t frames = std::min(vertex.frames.size(), mission.rig.cameras.size());
      frame_images.assign(frames, -1);
      for (std::size_t c = 0; c < frames; ++c) {
        if (!export_images::HasImage(map, vertex.frames[c])) {
          ++summary.frames_without_image;
          continue;
        }
        frame_images[c] = static_cast<int64_t>(images.size());
        images.push_back({vertex_id, first_undistorter + c,
                          (T_G_I * mission.rig.cameras[c].T_I_C).inverse(),
                          vertex.frames[c].image_resource_id});
      }
    }
  }
  if (images.empty()) {
    throw InputError(FormatInputError(
        "map", "images",
        "expected camera frames with image resources in the exported missions, found none (" +
            std::to_string(summary.frames_without_image) + " frames without image)"));
  }

  // Points: landmarks seen from enough exported images, with their undistorted keypoints.
  std::vector<PmvsPoint> points;
  double error_sum = 0.0;
  for (const MissionId& mission_id : missions) {
    for (const LandmarkId& landmark_id : map.landmark_ids(mission_id)) {
      const mapstore::Landmark& landmark = map.landmark(landmark_id);
      if (!keep_quality[static_cast<int>(landmark.quality)]) {
        ++summary.landmarks_skipped_quality;
        continue;
      }
      PmvsPoint point;
      point.p_G = map.LandmarkPosition_G(landmark_id);
      std::vector<double> errors;
      for (const mapstore::LandmarkObservation& o : landmark.observations) {
        const auto found = image_of_frame.find(o.vertex_id);
        if (found == image_of_frame.end() || o.camera >= found->second.size() ||
            found->second[o.camera] < 0) {
          continue;  // a mission not exported, or a frame without image
        }
        const std::size_t index = static_cast<std::size_t>(found->second[o.camera]);
        const mapstore::VisualFrame& frame = map.vertex(o.vertex_id).frames[o.camera];
        if (o.keypoint >= frame.size()) export_images::ThrowMissingKeypoint(landmark_id, o);
        const PmvsImage& image = images[index];
        const ImageUndistorter& undistorter = undistorters[image.undistorter];
        const Eigen::Vector3d p_C = image.T_C_G * point.p_G;
        PmvsView view{index, o.keypoint, Eigen::Vector2d::Zero()};
        Eigen::Vector2d projected;
        const bool seen = std::any_of(point.views.begin(), point.views.end(),
                                      [&](const PmvsView& v) { return v.image == index; });
        if (seen || p_C.z() <= 0.0 ||
            !undistorter.Keypoint(frame.keypoints[o.keypoint].uv, &view.uv) ||
            undistorter.target().Project(p_C, &projected) == Camera::ProjectionResult::kNotFinite) {
          ++summary.observations_dropped;
          continue;
        }
        errors.push_back((projected - view.uv).norm());
        point.views.push_back(view);
      }
      if (point.views.size() < static_cast<std::size_t>(options.min_observations)) {
        ++summary.landmarks_skipped_track;
        continue;
      }
      for (double e : errors) {
        error_sum += e;
        summary.max_reprojection_error_px = std::max(summary.max_reprojection_error_px, e);
      }
      summary.observations += point.views.size();
      points.push_back(std::move(point));
    }
  }
  summary.points = points.size();
  summary.images = images.size();
  summary.mean_reprojection_error_px =
      summary.observations > 0 ? error_sum / summary.observations : 0.0;

  // Everything goes into <out>.partial, renamed to <out> once complete.
  const fs::path folder = CheckOutputFolder(options.out);
  const fs::path partial = folder.string() + ".partial";
  export_files::CreateFolder(partial.string(), "out");
  try {
    for (const char* sub : {"visualize", "txt", "models"}) {
      export_files::CreateFolder((partial / sub).string(), "out");
    }
    // Points take their colour from the image of their first view.
    std::vector<std::vector<std::size_t>> first_view_in(images.size());
    for (std::size_t p = 0; p < points.size(); ++p) {
      first_view_in[points[p].views[0].image].push_back(p);
    }
    BeginProgress(progress, "pmvs images", images.size());
    for (std::size_t i = 0; i < images.size(); ++i) {
      ReportProgress(progress, i);
      ImageUndistorter& undistorter = undistorters[images[i].undistorter];
      const export_images::DecodedImage resource = export_images::DecodeImageResource(
          map, images[i].resource, undistorter.source().width(), undistorter.source().height());
      const cv::Mat picture = ToBgr8(undistorter.Image(resource.picture));
      std::vector<uchar> jpeg;
      if (!cv::imencode(".jpg", picture, jpeg, {cv::IMWRITE_JPEG_QUALITY, options.jpeg_quality})) {
        throw InputError(FormatInputError(resource.where, "", "expected an image JPEG can hold"));
      }
      WriteFileAtomically((partial / "visualize" / IndexName(i, "jpg")).string(),
                          std::string(jpeg.begin(), jpeg.end()));
      WriteFileAtomically((partial / "txt" / IndexName(i, "txt")).string(),
                          ContourText(ProjectionMatrix(undistorter.target(), images[i].T_C_G)));
      for (std::size_t p : first_view_in[i]) {
        const Eigen::Vector2d& uv = points[p].views[0].uv;
        const int u = static_cast<int>(std::lround(uv.x()));
        const int v = static_cast<int>(std::lround(uv.y()));
        if (u >= 0 && v >= 0 && u < picture.cols && v < picture.rows) {
          points[p].rgb = export_images::PixelRgb(picture, u, v);
        }
      }
    }
    ReportProgress(progress, images.size());
    WriteFileAtomically((partial / "bundle.rd.out").string(),
                        BundleText(images, undistorters, points));
    WriteFileAtomically((partial / "vis.dat").string(),
                        VisText(images.size(), points, options.min_covisible_landmarks, &summary));
    WriteFileAtomically((partial / "option-0000").string(),
                        OptionText(images.size(), options.threads));
    std::error_code error;
    fs::rename(partial, folder, error);  // replaces an empty folder (POSIX rename)
    if (error) {
      throw InputError(
          FormatInputError("--out", folder.string(),
                           "expected a folder that can be made (" + error.message() + ")"));
    }
  } catch (...) {
    std::error_code ignored;
    fs::remove_all(partial, ignored);
    throw;
  }
  summary.folder = folder.string();
  return summary;
}

}  // namespace vilma::mapping
