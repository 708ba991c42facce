// export_colmap: COLMAP 3.8 (`colmap model_analyzer`) reads the model and counts what the map
// holds; points3D re-projected through the written cameras and images (COLMAP's camera models
// implemented here from COLMAP's definitions, independent of vilma's Camera) land on their
// POINTS2D; undistorted images show what a pinhole camera sees.
#include "vilma/mapping/export/colmap_export.h"

#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>
#include <map>
#include <sstream>

#include "mapping_export/colmap_analyzer.h"
#include "mapping_export/data_export_test_util.h"
#include "vilma/core/error.h"
#include "test_skip.h"

namespace vilma::mapping {
namespace {

namespace fs = std::filesystem;
using testing::MakeProjectedMap;
using testing::ProjectedMap;
using testing::ProjectedMapOptions;
using testing::ReadLines;
using testing::ScratchFolder;

struct CmCamera {
  std::string model;
  int width = 0, height = 0;
  std::vector<double> params;
};
struct CmImage {
  double q[4], t[3];
  int camera = 0;
  std::string name;
  std::vector<Eigen::Vector2d> xy;
  std::vector<long> point3d;
};
struct CmPoint {
  Eigen::Vector3d X;
  int rgb[3];
  double error = 0.0;
  std::vector<std::pair<int, int>> track;
};
struct CmModel {
  std::map<int, CmCamera> cameras;
  std::map<int, CmImage> images;
  std::map<long, CmPoint> points;
};

std::vector<std::string> DataLines(const std::string& path, bool keep_empty) {
  std::vector<std::string> lines;
  for (const std::string& l : ReadLines(path)) {
    if (!l.empty() && l[0] == '#') continue;
    if (l.empty() && !keep_empty) continue;
    lines.push_back(l);
  }
  return lines;
}

CmModel ReadModel(const std::string& dir) {
  CmModel model;
  for (const std::string& line : DataLines(dir + "/cameras.txt", false)) {
    std::istringstream s(line);
    int id;
    CmCamera c;
    REQUIRE(static_cast<bool>(s >> id >> c.model >> c.width >> c.height));
    for (double p; s >> p;) c.params.push_back(p);
    model.cameras[id] = c;
  }
  const std::vector<std::string> lines = DataLines(dir + "/images.txt", true);
  REQUIRE(lines.size() % 2 == 0);
  for (std::size_t i = 0; i < lines.size(); i += 2) {
    std::istringstream s(lines[i]);
    int id;
    CmImage image;
    REQUIRE(static_cast<bool>(s >> id >> image.q[0] >> image.q[1] >> image.q[2] >> image.q[3] >>
                              image.t[0] >> image.t[1] >> image.t[2] >> image.camera >>
                              image.name));
    std::istringstream p(lines[i + 1]);
    double x, y;
    long point;
    while (p >> x >> y >> point) {
      image.xy.emplace_back(x, y);
      image.point3d.push_back(point);
    }
    model.images[id] = image;
  }
  for (const std::string& line : DataLines(dir + "/points3D.txt", false)) {
    std::istringstream s(line);
    long id;
    CmPoint point;
    REQUIRE(static_cast<bool>(s >> id >> point.X.x() >> point.X.y() >> point.X.z() >>
                              point.rgb[0] >> point.rgb[1] >> point.rgb[2] >> point.error));
    int image, index;
    while (s >> image >> index) point.track.push_back({image, index});
    model.points[id] = point;
  }
  return model;
}

// COLMAP's world-to-image projection (src/base/camera_models.h semantics): rotation from the
// unit quaternion (w, x, y, z), normalized coordinates, distortion, then f and c.
Eigen::Vector2d ColmapProject(const CmCamera& c, const CmImage& image, const Eigen::Vector3d& X) {
  const double w = image.q[0], x = image.q[1], y = image.q[2], z = image.q[3];
  Eigen::Matrix3d R;
  R << 1 - 2 * y * y - 2 * z * z, 2 * x * y - 2 * w * z, 2 * x * z + 2 * w * y,
      2 * x * y + 2 * w * z, 1 - 2 * x * x - 2 * z * z, 2 * y * z - 2 * w * x,
      2 * x * z - 2 * w * y, 2 * y * z + 2 * w * x, 1 - 2 * x * x - 2 * y * y;
  const Eigen::Vector3d Xc = R * X + Eigen::Vector3d(image.t[0], image.t[1], image.t[2]);
  REQUIRE(Xc.z() > 0);
  double u = Xc.x() / Xc.z(), v = Xc.y() / Xc.z();
  const std::vector<double>& p = c.params;
  if (c.model == "OPENCV") {
    const double k1 = p[4], k2 = p[5], p1 = p[6], p2 = p[7];
    const double u2 = u * u, v2 = v * v, uv = u * v, r2 = u2 + v2;
    const double radial = k1 * r2 + k2 * r2 * r2;
    const double du = u * radial + 2 * p1 * uv + p2 * (r2 + 2 * u2);
    const double dv = v * radial + 2 * p2 * uv + p1 * (r2 + 2 * v2);
    u += du;
    v += dv;
  } else if (c.model == "OPENCV_FISHEYE") {
    const double r = std::sqrt(u * u + v * v);
    if (r > 1e-12) {
      const double theta = std::atan(r), t2 = theta * theta;
      const double thetad =
          theta * (1 + p[4] * t2 + p[5] * t2 * t2 + p[6] * t2 * t2 * t2 + p[7] * t2 * t2 * t2 * t2);
      u *= thetad / r;
      v *= thetad / r;
    }
  } else {
    REQUIRE(c.model == "PINHOLE");
  }
  return Eigen::Vector2d(p[0] * u + p[2], p[1] * v + p[3]);
}

// Checks the model against itself: every track element's POINTS2D names the point and the
// point re-projects onto it within `tolerance_px`; every POINTS2D with a point id is in that
// point's track. Returns the number of observations.
std::size_t CheckModel(const CmModel& model, double tolerance_px) {
  std::size_t observations = 0, named = 0;
  double worst = 0.0;
  for (const auto& [id, point] : model.points) {
    REQUIRE(point.track.size() >= 2);
    for (const auto& [image_id, index] : point.track) {
      const CmImage& image = model.images.at(image_id);
      REQUIRE(index < static_cast<int>(image.xy.size()));
      REQUIRE(image.point3d[index] == id);
      const Eigen::Vector2d xy = ColmapProject(model.cameras.at(image.camera), image, point.X);
      worst = std::max(worst, (xy - image.xy[index]).norm());
      ++observations;
    }
    REQUIRE(point.error < tolerance_px);
  }
  for (const auto& [id, image] : model.images) {
    for (long p : image.point3d) named += p != -1;
  }
  REQUIRE(named == observations);
  INFO("worst re-projection " << worst << " px");
  REQUIRE(worst < tolerance_px);
  return observations;
}

std::size_t GoodTrackObservations(const ProjectedMap& m, std::size_t* points) {
  std::size_t observations = 0;
  *points = 0;
  for (const auto& mission : m.missions) {
    for (const auto& id : m.map.landmark_ids(mission)) {
      const auto& l = m.map.landmark(id);
      if (l.quality != mapstore::LandmarkQuality::kGood || l.observations.size() < 2) continue;
      ++*points;
      observations += l.observations.size();
    }
  }
  return observations;
}

TEST_CASE("colmap export: OPENCV model re-projects onto POINTS2D, COLMAP reads the counts",
          "[colmap_export]") {
  const ProjectedMap m = MakeProjectedMap({});
  const std::string dir = ScratchFolder("colmap_opencv") + "/model";
  ColmapExportOptions options;
  options.out = dir;
  const ColmapExportSummary summary = ExportColmap(m.map, options);
  std::size_t points = 0;
  const std::size_t observations = GoodTrackObservations(m, &points);
  REQUIRE(summary.cameras == 4);
  REQUIRE(summary.images == m.frames);
  REQUIRE(summary.points == points);
  REQUIRE(summary.observations == observations);
  REQUIRE(summary.keypoints == m.keypoints);
  REQUIRE(summary.image_files == 0);  // the map has no images
  REQUIRE(summary.max_reprojection_error_px < 1e-6);
  const CmModel model = ReadModel(dir);
  REQUIRE(model.cameras.at(1).model == "OPENCV");
  REQUIRE(model.cameras.at(1).params[2] == Approx(79.5 + 0.5));  // cx in COLMAP's convention
  REQUIRE(model.images.size() == m.frames);
  REQUIRE(model.points.size() == points);
  REQUIRE(CheckModel(model, 1e-6) == observations);
  // Image names: <vertex id>_cam<k>.png of the first vertex in time order.
  const auto first = m.map.vertex_ids(m.missions[0])[0];
  REQUIRE(model.images.at(1).name == first.Hex() + "_cam0.png");
  REQUIRE(model.images.at(2).name == first.Hex() + "_cam1.png");

  const std::string colmap = testing::FindColmap();
  if (colmap.empty()) {
    VILMA_SKIP("the model_analyzer check: colmap is not installed (Debian package colmap)");
  }
  const std::map<std::string, double> counts = testing::ModelAnalyzer(colmap, dir);
  REQUIRE(counts.at("Cameras") == 4);
  REQUIRE(counts.at("Images") == m.frames);
  REQUIRE(counts.at("Registered images") == m.frames);
  REQUIRE(counts.at("Points") == points);
  REQUIRE(counts.at("Observations") == observations);
  REQUIRE(counts.at("Mean reprojection error") < 1e-6);
}

TEST_CASE("colmap export: equidistant cameras as OPENCV_FISHEYE", "[colmap_export]") {
  ProjectedMapOptions o;
  o.model = DistortionModel::kEquidistant;
  const ProjectedMap m = MakeProjectedMap(o);
  const std::string dir = ScratchFolder("colmap_fisheye");
  ColmapExportOptions options;
  options.out = dir;
  options.landmarks = "good,unknown,bad";
  const ColmapExportSummary summary = ExportColmap(m.map, options);
  const CmModel model = ReadModel(dir);
  REQUIRE(model.cameras.at(3).model == "OPENCV_FISHEYE");
  REQUIRE(model.cameras.at(3).params.size() == 8);
  REQUIRE(summary.landmarks_skipped_quality == 0);
  REQUIRE(CheckModel(model, 1e-6) == summary.observations);
  REQUIRE(summary.points > 0);
}

TEST_CASE("colmap export: undistorted PINHOLE with images shows the pinhole's view",
          "[colmap_export]") {
  ProjectedMapOptions o;
  o.images = true;
  o.vertices_per_mission = 3;
  const ProjectedMap m = MakeProjectedMap(o);
  const std::string dir = ScratchFolder("colmap_pinhole");
  ColmapExportOptions options;
  options.out = dir;
  options.camera_model = "pinhole";
  const ColmapExportSummary summary = ExportColmap(m.map, options);
  REQUIRE(summary.image_files == m.frames);
  const CmModel model = ReadModel(dir);
  // Undistorted keypoints re-project through the PINHOLE cameras (undistortion is iterative:
  // the keypoints are exact to its convergence threshold).
  REQUIRE(CheckModel(model, 1e-4) == summary.observations);
  const CmCamera& camera = model.cameras.at(1);
  REQUIRE(camera.model == "PINHOLE");
  // The undistorted image at every inner pixel shows the pattern of that pinhole pixel's ray.
  const cv::Mat image =
      cv::imread(dir + "/images/" + model.images.at(1).name, cv::IMREAD_UNCHANGED);
  REQUIRE(image.cols == camera.width);
  REQUIRE(image.rows == camera.height);
  double sum = 0.0, worst = 0.0;
  int count = 0;
  for (int v = 2; v < camera.height - 2; ++v) {
    for (int u = 2; u < camera.width - 2; ++u) {
      // COLMAP pixel centre (u + 0.5, v + 0.5) -> normalized coordinates.
      const double x = (u + 0.5 - camera.params[2]) / camera.params[0];
      const double y = (v + 0.5 - camera.params[3]) / camera.params[1];
      const double d = std::abs(image.at<uint8_t>(v, u) - testing::RayPattern(x, y));
      sum += d;
      worst = std::max(worst, d);
      ++count;
    }
  }
  INFO("mean " << sum / count << " max " << worst);
  REQUIRE(sum / count < 1.5);
  REQUIRE(worst < 12.0);
  // Point colours come from the image at the first observation.
  const CmPoint& point = model.points.begin()->second;
  const auto& [image_id, index] = point.track[0];
  if (model.images.at(image_id).name == model.images.at(1).name) {
    const Eigen::Vector2d xy = model.images.at(1).xy[index];
    REQUIRE(point.rgb[0] == image.at<uint8_t>(static_cast<int>(std::lround(xy.y() - 0.5)),
                                              static_cast<int>(std::lround(xy.x() - 0.5))));
  }
  REQUIRE(point.rgb[0] == point.rgb[1]);  // grey images
}

TEST_CASE("colmap export: OPENCV images are the resources' bytes", "[colmap_export]") {
  ProjectedMapOptions o;
  o.images = true;
  o.vertices_per_mission = 2;
  const ProjectedMap m = MakeProjectedMap(o);
  const std::string dir = ScratchFolder("colmap_images");
  ColmapExportOptions options;
  options.out = dir;
  options.missions = {m.missions[1]};
  const ColmapExportSummary summary = ExportColmap(m.map, options);
  REQUIRE(summary.cameras == 2);
  REQUIRE(summary.images == 4);
  REQUIRE(summary.image_files == 4);
  const auto vertex = m.map.vertex_ids(m.missions[1])[1];
  const auto& frame = m.map.vertex(vertex).frames[1];
  const auto bytes =
      m.map.resources().Load(mapstore::ResourceType::kImage, frame.image_resource_id);
  REQUIRE(testing::ReadText(dir + "/images/" + vertex.Hex() + "_cam1.png") == *bytes);
  // Cancelled while writing images: no model text file.
  const std::string cancelled = ScratchFolder("colmap_cancel") + "/model";
  options.out = cancelled;
  testing::CancelAfter cancel(2);
  REQUIRE_THROWS_AS(ExportColmap(m.map, options, &cancel), Cancelled);
  REQUIRE_FALSE(fs::exists(cancelled + "/points3D.txt"));
  REQUIRE_FALSE(fs::exists(cancelled + "/cameras.txt"));
  options.images = false;
  const std::string dir2 = ScratchFolder("colmap_no_images");
  options.out = dir2;
  REQUIRE(ExportColmap(m.map, options).image_files == 0);
  REQUIRE_FALSE(fs::exists(dir2 + "/images"));
}

TEST_CASE("colmap export: bad input", "[colmap_export]") {
  ProjectedMap m = MakeProjectedMap({});
  const std::string dir = ScratchFolder("colmap_bad");
  ColmapExportOptions options;
  REQUIRE_THROWS_WITH(ExportColmap(m.map, options), Catch::Contains("out: expected"));
  options.out = dir + "/model";
  options.camera_model = "fisheye";
  REQUIRE_THROWS_WITH(ExportColmap(m.map, options),
                      Catch::Contains("camera_model: expected auto or pinhole"));
  options.camera_model = "auto";
  options.landmarks = "great";
  REQUIRE_THROWS_WITH(ExportColmap(m.map, options), Catch::Contains("landmarks: expected"));
  options.landmarks = "good";
  options.min_track_length = 0;
  REQUIRE_THROWS_WITH(ExportColmap(m.map, options), Catch::Contains("min_track_length"));
  options.min_track_length = 2;
  m.map.mission(m.missions[1]).rig.cameras.clear();
  REQUIRE_THROWS_WITH(ExportColmap(m.map, options),
                      Catch::Contains("expected a recorded sensor rig"));
  REQUIRE_FALSE(fs::exists(dir + "/model"));
  std::ofstream(dir + "/file") << "x";
  options.out = dir + "/file/model";
  options.missions = {m.missions[0]};
  REQUIRE_THROWS_AS(ExportColmap(m.map, options), InputError);
}

}  // namespace
}  // namespace vilma::mapping
