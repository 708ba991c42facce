#include "vilma/mapping/export/colmap_export.h"

#include <cmath>
#include <filesystem>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <unordered_map>

#include "export_files.h"
#include "export_images.h"
#include "vilma/core/asl_dataset.h"
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

// COLMAP's pixel origin is the top-left corner of the top-left pixel, vilma's its centre.
constexpr double kColmapPixelOffset = 0.5;

struct ColmapCamera {
  std::string model;
  int width = 0, height = 0;
  std::vector<double> params;  // in COLMAP's pixel convention
  // The map's camera (source) to the camera the exported keypoints belong to (target, vilma
  // pixels): the same camera unless undistorted.
  ImageUndistorter undistorter;
  bool undistort = false;
};

struct ColmapImage {
  VertexId vertex;
  uint32_t camera = 0;  // rig camera index
  std::size_t colmap_camera = 0;
  Transformation T_C_G;  // world (G) to camera
  std::string name;
  std::vector<Eigen::Vector2d> uv;  // exported keypoints, vilma pixels
  std::vector<bool> usable;         // false: not undistortable (left out of tracks)
  std::vector<int64_t> point3d;     // COLMAP POINT3D_ID or -1
  mapstore::ResourceId image_resource;
  bool has_image = false;  // the map holds the image resource
};

struct ColmapPoint {
  Eigen::Vector3d p_G;
  std::array<uint8_t, 3> rgb;
  bool rgb_from_image = false;
  double error_px = 0.0;
  std::vector<std::pair<std::size_t, uint32_t>> track;  // (image index, keypoint)
};

ColmapCamera MakeCamera(const Camera& camera, bool undistort, double alpha,
                        const std::string& where) {
  ColmapCamera c;
  c.undistort = undistort;
  c.width = camera.width();
  c.height = camera.height();
  c.undistorter = ImageUndistorter(camera, undistort ? camera.UndistortedPinhole(alpha) : camera);
  const Camera& e = c.undistorter.target();
  c.params = {e.fx(), e.fy(), e.cx() + kColmapPixelOffset, e.cy() + kColmapPixelOffset};
  switch (e.distortion_model()) {
    case DistortionModel::kNone:
      c.model = "PINHOLE";
      break;
    case DistortionModel::kRadTan:  // k1 k2 p1 p2: OpenCV's and COLMAP's OPENCV order
      c.model = "OPENCV";
      break;
    case DistortionModel::kEquidistant:  // theta_d = theta (1 + k1 theta^2 + ... + k4 theta^8)
      c.model = "OPENCV_FISHEYE";
      break;
    default:
      throw InputError(FormatInputError(where, "distortion_model",
                                        "expected none, radtan or equidistant for COLMAP"));
  }
  for (int k = 0; k < e.distortion_coefficients().size(); ++k) {
    c.params.push_back(e.distortion_coefficients()[k]);
  }
  return c;
}

std::string CamerasText(const std::vector<ColmapCamera>& cameras) {
  std::string t =
      "# Camera list with one line of data per camera:\n"
      "#   CAMERA_ID, MODEL, WIDTH, HEIGHT, PARAMS[]\n"
      "# Number of cameras: " +
      std::to_string(cameras.size()) +
      "\n"
      "# vilma export_colmap: one camera per (mission, rig camera); pixel centre of the top-left "
      "pixel at (0.5, 0.5)\n";
  for (std::size_t i = 0; i < cameras.size(); ++i) {
    t += std::to_string(i + 1) + " " + cameras[i].model + " " + std::to_string(cameras[i].width) +
         " " + std::to_string(cameras[i].height);
    for (double p : cameras[i].params) t += " " + Exact(p);
    t += "\n";
  }
  return t;
}

std::string ImagesText(const std::vector<ColmapImage>& images, std::size_t observations) {
  const double mean = images.empty() ? 0.0 : static_cast<double>(observations) / images.size();
  std::string t =
      "# Image list with two lines of data per image:\n"
      "#   IMAGE_ID, QW, QX, QY, QZ, TX, TY, TZ, CAMERA_ID, NAME\n"
      "#   POINTS2D[] as (X, Y, POINT3D_ID)\n"
      "# Number of images: " +
      std::to_string(images.size()) + ", mean observations per image: " + Exact(mean) +
      "\n"
      "# vilma export_colmap: pose T_C_G (world = frame G to camera), NAME <vertex id>_cam<k>.png, "
      "POINT2D_IDX = keypoint index\n";
  for (std::size_t i = 0; i < images.size(); ++i) {
    const ColmapImage& image = images[i];
    const Eigen::Quaterniond& q = image.T_C_G.rotation();
    const Eigen::Vector3d& p = image.T_C_G.translation();
    t += std::to_string(i + 1);
    for (double v : {q.w(), q.x(), q.y(), q.z(), p.x(), p.y(), p.z()}) t += " " + Exact(v);
    t += " " + std::to_string(image.colmap_camera + 1) + " " + image.name + "\n";
    for (std::size_t k = 0; k < image.uv.size(); ++k) {
      if (k > 0) t += " ";
      t += Exact(image.uv[k].x() + kColmapPixelOffset) + " " +
           Exact(image.uv[k].y() + kColmapPixelOffset) + " " + std::to_string(image.point3d[k]);
    }
    t += "\n";
  }
  return t;
}

std::string PointsText(const std::vector<ColmapPoint>& points, std::size_t observations) {
  const double mean = points.empty() ? 0.0 : static_cast<double>(observations) / points.size();
  std::string t =
      "# 3D point list with one line of data per point:\n"
      "#   POINT3D_ID, X, Y, Z, R, G, B, ERROR, TRACK[] as (IMAGE_ID, POINT2D_IDX)\n"
      "# Number of points: " +
      std::to_string(points.size()) + ", mean track length: " + Exact(mean) +
      "\n"
      "# vilma export_colmap: landmarks p_G [m] in frame G, ERROR mean reprojection error [px]\n";
  for (std::size_t i = 0; i < points.size(); ++i) {
    const ColmapPoint& point = points[i];
    t += std::to_string(i + 1) + " " + Exact(point.p_G.x()) + " " + Exact(point.p_G.y()) + " " +
         Exact(point.p_G.z()) + " " + std::to_string(point.rgb[0]) + " " +
         std::to_string(point.rgb[1]) + " " + std::to_string(point.rgb[2]) + " " +
         Exact(point.error_px);
    for (const auto& [image, keypoint] : point.track) {
      t += " " + std::to_string(image + 1) + " " + std::to_string(keypoint);
    }
    t += "\n";
  }
  return t;
}

// The image resource as the exported image: PNG bytes to write, and the decoded picture (BGR or
// grey) for point colours. Throws InputError naming the resource when it cannot be used.
std::string ExportImageBytes(const VIMap& map, const ColmapImage& image, ColmapCamera* camera,
                             cv::Mat* decoded) {
  const export_images::DecodedImage resource =
      export_images::DecodeImageResource(map, image.image_resource, camera->width, camera->height);
  cv::Mat picture = resource.picture;
  if (camera->undistort) picture = camera->undistorter.Image(picture);
  *decoded = picture;
  if (!camera->undistort && (resource.extension == "png" || resource.extension == "PNG")) {
    return *resource.bytes;
  }
  std::vector<uchar> png;
  if (!cv::imencode(".png", picture, png)) {
    throw InputError(FormatInputError(resource.where, "", "expected an image PNG can hold"));
  }
  return std::string(png.begin(), png.end());
}

}  // namespace

std::string ColmapExportOptions::Validate() const {
  if (out.empty()) return "out: expected the folder to write the COLMAP model into";
  if (camera_model != "auto" && camera_model != "pinhole") {
    return "camera_model: expected auto or pinhole, found '" + camera_model + "'";
  }
  if (!(undistort_alpha >= 0.0 && undistort_alpha <= 1.0)) {
    return "undistort_alpha: expected a number in [0, 1]";
  }
  std::array<bool, 3> keep;
  const std::string qualities = ParseLandmarkQualities(landmarks, &keep);
  if (!qualities.empty()) return "landmarks: expected " + qualities;
  if (min_track_length < 1) return "min_track_length: expected an integer >= 1";
  return "";
}

std::string ColmapExportSummary::BriefReport() const {
  const std::string full = FullReport();
  return full.substr(0, full.find('\n'));
}

std::string ColmapExportSummary::FullReport() const {
  std::ostringstream s;
  s << "colmap: " << cameras << " cameras, " << images << " images (" << image_files
    << " image files), " << points << " points, " << observations << " observations in " << folder
    << " (world = frame G)\n";
  s << "  reprojection error mean " << mean_reprojection_error_px << " px, max "
    << max_reprojection_error_px << " px; landmarks left out: " << landmarks_skipped_quality
    << " by quality, " << landmarks_skipped_track << " by track length; observations dropped "
    << observations_dropped << "\n  camera models:";
  for (const std::string& m : camera_models) s << " " << m;
  return s.str() + "\n";
}

ColmapExportSummary ExportColmap(const VIMap& map, const ColmapExportOptions& options,
                                 ProgressObserver* progress) {
  ThrowIfInvalid(options.Validate(), "export_colmap");
  std::array<bool, 3> keep_quality;
  ParseLandmarkQualities(options.landmarks, &keep_quality);
  const bool undistort = options.camera_model == "pinhole";
  const std::vector<MissionId> missions =
      export_files::MissionsToExport(map, options.missions, "mission");

  // Cameras and images.
  std::vector<ColmapCamera> cameras;
  std::vector<ColmapImage> images;
  std::unordered_map<VertexId, std::size_t, IdHash> first_image;  // vertex -> its camera 0
  ColmapExportSummary summary;
  for (std::size_t mi = 0; mi < missions.size(); ++mi) {
    const mapstore::Mission& mission = map.mission(missions[mi]);
    const std::string where = "mission " + mission.id.Hex();
    if (mission.rig.cameras.empty()) {
      throw InputError(
          FormatInputError(where, "rig", "expected a recorded sensor rig (no camera)"));
    }
    const std::size_t camera_base = cameras.size();
    for (std::size_t c = 0; c < mission.rig.cameras.size(); ++c) {
      cameras.push_back(MakeCamera(mission.rig.cameras[c].camera, undistort,
                                   options.undistort_alpha,
                                   where + ": rig.cameras[" + std::to_string(c) + "]"));
    }
    for (const VertexId& vertex_id : VerticesInTimeOrder(map, mission.id)) {
      const mapstore::Vertex& vertex = map.vertex(vertex_id);
      const Transformation T_G_I = map.T_G_I(vertex_id);
      first_image[vertex_id] = images.size();
      const std::size_t frames = std::min(vertex.frames.size(), mission.rig.cameras.size());
      for (std::size_t c = 0; c < frames; ++c) {
        const mapstore::VisualFrame& frame = vertex.frames[c];
        ColmapImage image;
        image.vertex = vertex_id;
        image.camera = static_cast<uint32_t>(c);
        image.colmap_camera = camera_base + c;
        image.T_C_G = (T_G_I * mission.rig.cameras[c].T_I_C).inverse();
        image.name = vertex_id.Hex() + "_cam" + std::to_string(c) + ".png";
        image.image_resource = frame.image_resource_id;
        image.has_image = export_images::HasImage(map, frame);
        image.point3d.assign(frame.size(), -1);
        image.usable.assign(frame.size(), true);
        image.uv.reserve(frame.size());
        const ColmapCamera& camera = cameras[image.colmap_camera];
        for (std::size_t k = 0; k < frame.size(); ++k) {
          Eigen::Vector2d uv = frame.keypoints[k].uv;
          // Undistorted keypoint: the pinhole's projection of the keypoint's ray (the measured
          // one is kept, unused, where there is none).
          Eigen::Vector2d pinhole_uv;
          if (undistort) {
            if (camera.undistorter.Keypoint(uv, &pinhole_uv)) {
              uv = pinhole_uv;
            } else {
              image.usable[k] = false;
            }
          }
          image.uv.push_back(uv);
        }
        summary.keypoints += frame.size();
        images.push_back(std::move(image));
      }
    }
  }

  // Points: exported landmarks with their tracks and reprojection errors.
  std::vector<ColmapPoint> points;
  double error_sum = 0.0;
  for (std::size_t mi = 0; mi < missions.size(); ++mi) {
    for (const LandmarkId& landmark_id : map.landmark_ids(missions[mi])) {
      const mapstore::Landmark& landmark = map.landmark(landmark_id);
      if (!keep_quality[static_cast<int>(landmark.quality)]) {
        ++summary.landmarks_skipped_quality;
        continue;
      }
      ColmapPoint point;
      point.p_G = map.LandmarkPosition_G(landmark_id);
      point.rgb = MissionColorRgb(mi);
      std::vector<double> errors;
      for (const mapstore::LandmarkObservation& o : landmark.observations) {
        const auto found = first_image.find(o.vertex_id);
        if (found == first_image.end()) continue;  // a vertex of a mission not exported
        const std::size_t index = found->second + o.camera;
        if (index >= images.size() || images[index].vertex != o.vertex_id ||
            o.keypoint >= images[index].uv.size()) {
          export_images::ThrowMissingKeypoint(landmark_id, o);
        }
        const ColmapImage& image = images[index];
        const Eigen::Vector3d p_C = image.T_C_G * point.p_G;
        Eigen::Vector2d projected;
        if (!image.usable[o.keypoint] || p_C.z() <= 0.0 ||
            cameras[image.colmap_camera].undistorter.target().Project(p_C, &projected) ==
                Camera::ProjectionResult::kNotFinite) {
          ++summary.observations_dropped;
          continue;
        }
        errors.push_back((projected - image.uv[o.keypoint]).norm());
        point.track.push_back({index, o.keypoint});
      }
      if (point.track.size() < static_cast<std::size_t>(options.min_track_length)) {
        ++summary.landmarks_skipped_track;
        continue;
      }
      for (double e : errors) {
        point.error_px += e / errors.size();
        error_sum += e;
        summary.max_reprojection_error_px = std::max(summary.max_reprojection_error_px, e);
      }
      const int64_t id = static_cast<int64_t>(points.size()) + 1;
      for (const auto& [image, keypoint] : point.track) images[image].point3d[keypoint] = id;
      summary.observations += point.track.size();
      points.push_back(std::move(point));
    }
  }

  export_files::CreateFolder(options.out, "out");
  // Image files (and point colours from them), then the model's text files.
  BeginProgress(progress, "colmap images", images.size());
  if (options.images) {
    const std::string image_folder = (fs::path(options.out) / "images").string();
    std::vector<std::vector<std::pair<std::size_t, uint32_t>>> points_in_image(images.size());
    for (std::size_t p = 0; p < points.size(); ++p) {
      for (const auto& [image, keypoint] : points[p].track) {
        points_in_image[image].push_back({p, keypoint});
      }
    }
    for (std::size_t i = 0; i < images.size(); ++i) {
      ReportProgress(progress, i);
      const ColmapImage& image = images[i];
      if (!image.has_image) continue;
      cv::Mat decoded;
      const std::string bytes =
          ExportImageBytes(map, image, &cameras[image.colmap_camera], &decoded);
      if (summary.image_files == 0) export_files::CreateFolder(image_folder, "out");
      WriteFileAtomically((fs::path(image_folder) / image.name).string(), bytes);
      ++summary.image_files;
      for (const auto& [p, keypoint] : points_in_image[i]) {
        if (points[p].rgb_from_image) continue;
        const int u = static_cast<int>(std::lround(image.uv[keypoint].x()));
        const int v = static_cast<int>(std::lround(image.uv[keypoint].y()));
        if (u < 0 || v < 0 || u >= decoded.cols || v >= decoded.rows) continue;
        points[p].rgb = export_images::PixelRgb(decoded, u, v);
        points[p].rgb_from_image = true;
      }
    }
  }
  ReportProgress(progress, images.size());
  WriteFileAtomically((fs::path(options.out) / "cameras.txt").string(), CamerasText(cameras));
  WriteFileAtomically((fs::path(options.out) / "images.txt").string(),
                      ImagesText(images, summary.observations));
  WriteFileAtomically((fs::path(options.out) / "points3D.txt").string(),
                      PointsText(points, summary.observations));

  summary.folder = options.out;
  summary.cameras = cameras.size();
  summary.images = images.size();
  summary.points = points.size();
  summary.mean_reprojection_error_px =
      summary.observations > 0 ? error_sum / summary.observations : 0.0;
  for (const ColmapCamera& c : cameras) summary.camera_models.push_back(c.model);
  return summary;
}

}  // namespace vilma::mapping
