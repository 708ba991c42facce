// export_for_pmvs: the written folder read back as PMVS2 / CMVS would read it. Landmarks
// re-projected through the written txt/ matrices land on the observations' keypoints
// undistorted with the camera model; the written images show the pattern a pinhole with that
// matrix sees; bundle.rd.out (Bundler's convention, parsed here) and vis.dat agree with both;
// bad input fails with a clear message and leaves no folder.
#include "vilma/mapping/export/pmvs_export.h"

#include <sys/stat.h>
#include <unistd.h>

#include <algorithm>
#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>
#include <map>
#include <set>
#include <sstream>

#include "mapping_export/data_export_test_util.h"
#include "vilma/core/error.h"
#include "vilma/mapping/export/map_plot.h"

namespace vilma::mapping {
namespace {

namespace fs = std::filesystem;
using testing::MakeProjectedMap;
using testing::ProjectedMap;
using testing::ProjectedMapOptions;
using testing::ReadLines;
using testing::ReadText;
using testing::ScratchFolder;
using Matrix34d = Eigen::Matrix<double, 3, 4>;

std::string Name(std::size_t index, const char* extension) {
  char name[32];
  std::snprintf(name, sizeof(name), "%08zu.%s", index, extension);
  return name;
}

Matrix34d ReadContour(const std::string& path) {
  std::istringstream s(ReadText(path));
  std::string header;
  REQUIRE(static_cast<bool>(s >> header));
  REQUIRE(header == "CONTOUR");
  Matrix34d P;
  for (int r = 0; r < 3; ++r) {
    for (int c = 0; c < 4; ++c) REQUIRE(static_cast<bool>(s >> P(r, c)));
  }
  std::string rest;
  REQUIRE_FALSE(static_cast<bool>(s >> rest));
  return P;
}

struct BundleCamera {
  double f = 0, k1 = 0, k2 = 0;
  Eigen::Matrix3d R;
  Eigen::Vector3d t;
};
struct BundleView {
  int image = 0, key = 0;
  double x = 0, y = 0;
};
struct BundlePoint {
  Eigen::Vector3d X;
  int rgb[3];
  std::vector<BundleView> views;
};
struct Bundle {
  std::vector<BundleCamera> cameras;
  std::vector<BundlePoint> points;
};

// Bundler v0.3 as Bundle2PMVS / CMVS read it.
Bundle ReadBundle(const std::string& path) {
  std::istringstream s(ReadText(path));
  std::string header;
  REQUIRE(static_cast<bool>(std::getline(s, header)));
  REQUIRE(header == "# Bundle file v0.3");
  std::size_t cameras = 0, points = 0;
  REQUIRE(static_cast<bool>(s >> cameras >> points));
  Bundle b;
  b.cameras.resize(cameras);
  for (BundleCamera& c : b.cameras) {
    REQUIRE(static_cast<bool>(s >> c.f >> c.k1 >> c.k2));
    for (int r = 0; r < 3; ++r)
      REQUIRE(static_cast<bool>(s >> c.R(r, 0) >> c.R(r, 1) >> c.R(r, 2)));
    REQUIRE(static_cast<bool>(s >> c.t.x() >> c.t.y() >> c.t.z()));
  }
  b.points.resize(points);
  for (BundlePoint& p : b.points) {
    int n = 0;
    REQUIRE(static_cast<bool>(s >> p.X.x() >> p.X.y() >> p.X.z() >> p.rgb[0] >> p.rgb[1] >>
                              p.rgb[2] >> n));
    p.views.resize(n);
    for (BundleView& v : p.views) REQUIRE(static_cast<bool>(s >> v.image >> v.key >> v.x >> v.y));
  }
  std::string rest;
  REQUIRE_FALSE(static_cast<bool>(s >> rest));
  return b;
}

// Bundler's projection (its manual): P = R X + t, p = -P / P.z, p' = f r(p) p.
Eigen::Vector2d BundlerProject(const BundleCamera& c, const Eigen::Vector3d& X) {
  const Eigen::Vector3d P = c.R * X + c.t;
  REQUIRE(P.z() < 0.0);  // in front: the camera looks down -z
  const Eigen::Vector2d p = -P.head<2>() / P.z();
  const double r2 = p.squaredNorm();
  return c.f * (1.0 + c.k1 * r2 + c.k2 * r2 * r2) * p;
}

std::vector<std::vector<int>> ReadVis(const std::string& path, std::size_t images) {
  std::istringstream s(ReadText(path));
  std::string header;
  std::size_t n = 0;
  REQUIRE(static_cast<bool>(s >> header >> n));
  REQUIRE(header == "VISDATA");
  REQUIRE(n == images);
  std::vector<std::vector<int>> vis(n);
  for (std::size_t i = 0; i < n; ++i) {
    std::size_t index = 0, k = 0;
    REQUIRE(static_cast<bool>(s >> index >> k));
    REQUIRE(index == i);
    vis[i].resize(k);
    for (int& j : vis[i]) REQUIRE(static_cast<bool>(s >> j));
  }
  return vis;
}

// The exported images in their order: (vertex, camera) of every frame with an image.
std::vector<std::pair<mapstore::VertexId, uint32_t>> ExportedFrames(const ProjectedMap& m) {
  std::vector<std::pair<mapstore::VertexId, uint32_t>> frames;
  for (const auto& mission : m.missions) {
    for (const auto& vertex : VerticesInTimeOrder(m.map, mission)) {
      for (uint32_t c = 0; c < m.map.vertex(vertex).frames.size(); ++c) {
        if (m.map.vertex(vertex).frames[c].image_resource_id.IsValid()) {
          frames.push_back({vertex, c});
        }
      }
    }
  }
  return frames;
}

ProjectedMap ImageMap(DistortionModel model) {
  ProjectedMapOptions o;
  o.images = true;
  o.vertices_per_mission = 4;
  o.model = model;
  return MakeProjectedMap(o);
}

TEST_CASE("pmvs export: landmarks re-project through the written P onto undistorted keypoints",
          "[pmvs]") {
  const DistortionModel model = GENERATE(DistortionModel::kRadTan, DistortionModel::kEquidistant);
  const ProjectedMap m = ImageMap(model);
  const std::string dir = ScratchFolder(std::string("pmvs_") + ToString(model)) + "/pmvs";
  PmvsExportOptions options;
  options.out = dir;
  options.min_covisible_landmarks = 3;
  const PmvsExportSummary summary = ExportPmvs(m.map, options);
  INFO(summary.BriefReport());
  const auto frames = ExportedFrames(m);
  REQUIRE(summary.images == m.frames);
  REQUIRE(frames.size() == m.frames);
  REQUIRE(summary.frames_without_image == 0);
  REQUIRE(summary.observations_dropped == 0);
  REQUIRE(summary.points > 10);
  REQUIRE(fs::is_directory(dir + "/models"));
  REQUIRE(fs::is_empty(dir + "/models"));
  REQUIRE_FALSE(fs::exists(dir + ".partial"));

  // Every observation of an exported point: p_G through the written P lands on the keypoint
  // undistorted with the map's camera model to the pinhole that P's K describes.
  std::vector<Matrix34d> P(m.frames);
  for (std::size_t i = 0; i < m.frames; ++i) P[i] = ReadContour(dir + "/txt/" + Name(i, "txt"));
  std::map<std::pair<mapstore::VertexId, uint32_t>, std::size_t> index_of;
  for (std::size_t i = 0; i < frames.size(); ++i) index_of[frames[i]] = i;
  const Bundle bundle = ReadBundle(dir + "/bundle.rd.out");
  REQUIRE(bundle.cameras.size() == m.frames);
  REQUIRE(bundle.points.size() == summary.points);
  double worst_p = 0.0, worst_bundle = 0.0;
  std::size_t checked = 0, views = 0;
  std::map<std::pair<int, int>, int> shared;
  for (const BundlePoint& point : bundle.points) {
    REQUIRE(point.views.size() >= 2);
    views += point.views.size();
    for (const BundleView& v : point.views) {
      const auto& [vertex_id, camera] = frames.at(v.image);
      const mapstore::Mission& mission = m.map.mission(m.map.vertex(vertex_id).mission_id);
      const Camera& source = mission.rig.cameras[camera].camera;
      const Eigen::Vector2d uv = m.map.vertex(vertex_id).frames[camera].keypoints.at(v.key).uv;
      // The pinhole of P: K = [f 0 cx; 0 f cy; 0 0 1] with f = (fx + fy) / 2, centred.
      const double f = 0.5 * (source.fx() + source.fy());
      const double cx = 0.5 * (source.width() - 1), cy = 0.5 * (source.height() - 1);
      Eigen::Vector3d bearing;
      REQUIRE(source.Unproject(uv, &bearing));
      const Eigen::Vector2d undistorted(f * bearing.x() / bearing.z() + cx,
                                        f * bearing.y() / bearing.z() + cy);
      const Eigen::Vector3d x = P[v.image] * point.X.homogeneous();
      REQUIRE(x.z() > 0.0);
      worst_p = std::max(worst_p, (x.head<2>() / x.z() - undistorted).norm());
      // bundle.rd.out: the same keypoint (centre origin, y up), and Bundler's projection.
      REQUIRE(v.x == Approx(undistorted.x() - cx).margin(1e-6));
      REQUIRE(v.y == Approx(cy - undistorted.y()).margin(1e-6));
      const BundleCamera& c = bundle.cameras[v.image];
      REQUIRE(c.f == Approx(f));
      REQUIRE(c.k1 == 0.0);
      REQUIRE(c.k2 == 0.0);
      worst_bundle =
          std::max(worst_bundle, (BundlerProject(c, point.X) - Eigen::Vector2d(v.x, v.y)).norm());
      ++checked;
    }
    for (const BundleView& a : point.views) {
      for (const BundleView& b : point.views) {
        if (a.image != b.image) ++shared[{a.image, b.image}];
      }
    }
  }
  INFO("worst P re-projection " << worst_p << " px, Bundler " << worst_bundle << " px over "
                                << checked << " observations");
  REQUIRE(worst_p < 0.5);
  REQUIRE(worst_p < 1e-4);  // noise-free map: the undistortion's convergence only
  REQUIRE(worst_bundle < 1e-4);
  REQUIRE(views == summary.observations);
  REQUIRE(summary.max_reprojection_error_px < 1e-4);

  // Points are the good landmarks with two or more observations.
  std::size_t good_points = 0;
  for (const auto& mission : m.missions) {
    for (const auto& id : m.map.landmark_ids(mission)) {
      const auto& l = m.map.landmark(id);
      good_points += l.quality == mapstore::LandmarkQuality::kGood && l.observations.size() >= 2;
    }
  }
  REQUIRE(summary.points == good_points);

  // vis.dat: exactly the pairs sharing >= 3 points, symmetric.
  const auto vis = ReadVis(dir + "/vis.dat", m.frames);
  std::size_t pairs = 0;
  for (std::size_t i = 0; i < vis.size(); ++i) {
    std::set<int> expected;
    for (const auto& [ij, count] : shared) {
      if (ij.first == static_cast<int>(i) && count >= 3) expected.insert(ij.second);
    }
    REQUIRE(std::set<int>(vis[i].begin(), vis[i].end()) == expected);
    for (int j : vis[i]) {
      REQUIRE(std::count(vis[j].begin(), vis[j].end(), static_cast<int>(i)) == 1);
      pairs += j > static_cast<int>(i);
    }
  }
  REQUIRE(pairs == summary.vis_pairs);
  REQUIRE(pairs > 0);

  // option-0000: all images are targets, vis.dat used.
  const std::vector<std::string> option = ReadLines(dir + "/option-0000");
  REQUIRE(std::count(option.begin(), option.end(), "timages -1 0 " + std::to_string(m.frames)) ==
          1);
  REQUIRE(std::count(option.begin(), option.end(), "oimages 0") == 1);
  REQUIRE(std::count(option.begin(), option.end(), "useVisData 1") == 1);
  REQUIRE(std::count(option.begin(), option.end(), "CPU 2") == 1);
}

TEST_CASE("pmvs export: the written images show what the pinhole of P sees", "[pmvs]") {
  const ProjectedMap m = ImageMap(DistortionModel::kRadTan);
  const std::string dir = ScratchFolder("pmvs_images") + "/pmvs/";  // trailing slash
  PmvsExportOptions options;
  options.out = dir;
  const PmvsExportSummary summary = ExportPmvs(m.map, options);
  REQUIRE(summary.folder == fs::path(dir).parent_path().string());
  const Bundle bundle = ReadBundle(dir + "bundle.rd.out");
  for (std::size_t i : {std::size_t{0}, m.frames - 1}) {
    const Matrix34d P = ReadContour(dir + "txt/" + Name(i, "txt"));
    const cv::Mat image = cv::imread(dir + "visualize/" + Name(i, "jpg"), cv::IMREAD_UNCHANGED);
    REQUIRE(image.type() == CV_8UC3);  // PMVS2 reads colour images only
    REQUIRE(image.cols == 160);
    REQUIRE(image.rows == 120);
    // K from P = K [R | t]: the left 3x3 block is K R, K upper triangular (RQ via the rows).
    const Eigen::Matrix3d KR = P.leftCols<3>();
    const Eigen::Matrix3d KKt = KR * KR.transpose();  // = K K^T
    const double cx = KKt(0, 2), cy = KKt(1, 2);
    const double fy = std::sqrt(KKt(1, 1) - cy * cy);
    const double fx = std::sqrt(KKt(0, 0) - cx * cx);
    REQUIRE(cx == Approx(79.5));
    REQUIRE(cy == Approx(59.5));
    REQUIRE(fx == Approx(119.0));
    REQUIRE(fy == Approx(119.0));
    // Every inner pixel shows the pattern of its pinhole ray (JPEG and bilinear resampling).
    double sum = 0.0, worst = 0.0;
    int count = 0;
    for (int v = 3; v < image.rows - 3; ++v) {
      for (int u = 3; u < image.cols - 3; ++u) {
        const cv::Vec3b bgr = image.at<cv::Vec3b>(v, u);
        const double d = std::abs(bgr[1] - testing::RayPattern((u - cx) / fx, (v - cy) / fy));
        sum += d;
        worst = std::max(worst, d);
        ++count;
      }
    }
    INFO("image " << i << ": mean " << sum / count << " max " << worst);
    REQUIRE(sum / count < 1.0);  // measured 0.33
    REQUIRE(worst < 8.0);        // measured 1.7
  }
  // Point colours: grey, the image's value at the first view's keypoint.
  const BundlePoint& point = bundle.points.front();
  REQUIRE(point.rgb[0] == point.rgb[1]);
  REQUIRE(point.rgb[1] == point.rgb[2]);
  const BundleView& v = point.views.front();
  const cv::Mat image = cv::imread(dir + "visualize/" + Name(v.image, "jpg"), cv::IMREAD_UNCHANGED);
  const int u = static_cast<int>(std::lround(v.x + 79.5));
  const int row = static_cast<int>(std::lround(59.5 - v.y));
  REQUIRE(std::abs(point.rgb[0] - image.at<cv::Vec3b>(row, u)[1]) <= 12);  // JPEG loss
}

TEST_CASE("pmvs export: missions, frames without image, min_observations", "[pmvs]") {
  ProjectedMap m = ImageMap(DistortionModel::kRadTan);
  // Camera 1 of mission 0 keeps no images.
  for (const auto& vertex : m.map.vertex_ids(m.missions[0])) {
    m.map.vertex(vertex).frames[1].image_resource_id = mapstore::ResourceId();
  }
  PmvsExportOptions options;
  options.out = ScratchFolder("pmvs_some") + "/pmvs";
  const PmvsExportSummary all = ExportPmvs(m.map, options);
  REQUIRE(all.images == m.frames - 4);
  REQUIRE(all.frames_without_image == 4);
  options.out = ScratchFolder("pmvs_mission") + "/pmvs";
  options.missions = {m.missions[1]};
  options.landmarks = "good,unknown,bad";
  options.min_observations = 5;
  const PmvsExportSummary one = ExportPmvs(m.map, options);
  REQUIRE(one.images == 8);
  REQUIRE(one.frames_without_image == 0);
  REQUIRE(one.landmarks_skipped_quality == 0);
  const Bundle bundle = ReadBundle(options.out + "/bundle.rd.out");
  REQUIRE(bundle.points.size() == one.points);
  for (const BundlePoint& p : bundle.points) REQUIRE(p.views.size() >= 5);
  REQUIRE(ReadLines(options.out + "/vis.dat").size() == 2 + 8);
}

TEST_CASE("pmvs export: bad input fails clearly and leaves no folder", "[pmvs]") {
  const std::string root = ScratchFolder("pmvs_bad");
  PmvsExportOptions options;
  SECTION("no images in the map") {
    const ProjectedMap m = MakeProjectedMap({});
    options.out = root + "/pmvs";
    REQUIRE_THROWS_WITH(ExportPmvs(m.map, options),
                        Catch::Contains("expected camera frames with image resources") &&
                            Catch::Contains("32 frames without image"));
    REQUIRE_FALSE(fs::exists(root + "/pmvs"));
  }
  const ProjectedMap m = ImageMap(DistortionModel::kRadTan);
  SECTION("invalid options") {
    REQUIRE_THROWS_WITH(ExportPmvs(m.map, options), Catch::Contains("out: expected"));
    options.out = root + "/pmvs";
    options.min_observations = 1;
    REQUIRE_THROWS_WITH(ExportPmvs(m.map, options), Catch::Contains("min_observations"));
    options.min_observations = 2;
    options.jpeg_quality = 0;
    REQUIRE_THROWS_WITH(ExportPmvs(m.map, options), Catch::Contains("jpeg_quality"));
    options.jpeg_quality = 95;
    options.landmarks = "great";
    REQUIRE_THROWS_WITH(ExportPmvs(m.map, options), Catch::Contains("landmarks: expected"));
  }
  SECTION("an existing non-empty folder, a stale .partial, a file") {
    options.out = root + "/pmvs";
    fs::create_directories(options.out);
    std::ofstream(options.out + "/keep.txt") << "mine";
    REQUIRE_THROWS_WITH(ExportPmvs(m.map, options),
                        Catch::Contains(options.out) && Catch::Contains("new or empty folder"));
    REQUIRE(ReadText(options.out + "/keep.txt") == "mine");
    fs::remove(options.out + "/keep.txt");
    fs::create_directories(options.out + ".partial");
    REQUIRE_THROWS_WITH(ExportPmvs(m.map, options), Catch::Contains("pmvs.partial"));
    fs::remove(options.out + ".partial");
    REQUIRE(ExportPmvs(m.map, options).images == m.frames);  // an empty folder is fine
    std::ofstream(root + "/file") << "x";
    options.out = root + "/file";
    REQUIRE_THROWS_WITH(ExportPmvs(m.map, options), Catch::Contains("found a file"));
  }
  SECTION("an unwritable folder") {
    if (::geteuid() == 0) {
      WARN("running as root: permissions do not stop writes; checking a path under a file");
      std::ofstream(root + "/file") << "x";
      options.out = root + "/file/pmvs";
    } else {
      fs::create_directories(root + "/locked");
      fs::permissions(root + "/locked", fs::perms::owner_read | fs::perms::owner_exec);
      options.out = root + "/locked/pmvs";
    }
    REQUIRE_THROWS_AS(ExportPmvs(m.map, options), InputError);
    REQUIRE_THROWS_WITH(ExportPmvs(m.map, options), Catch::Contains("pmvs.partial"));
    REQUIRE_FALSE(fs::exists(options.out));
    if (fs::exists(root + "/locked")) fs::permissions(root + "/locked", fs::perms::owner_all);
  }
  SECTION("cancelled: nothing left") {
    options.out = root + "/pmvs";
    testing::CancelAfter cancel(3);
    REQUIRE_THROWS_AS(ExportPmvs(m.map, options, &cancel), Cancelled);
    REQUIRE_FALSE(fs::exists(options.out));
    REQUIRE_FALSE(fs::exists(options.out + ".partial"));
  }
}

}  // namespace
}  // namespace vilma::mapping
