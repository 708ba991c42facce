// Shared by the data export tests (trajectory, calibration, CSV, PLY, COLMAP): scratch folders,
// file reading, and a noise-free map with a known camera whose keypoints are the exact
// projections of its landmarks (so that exports can be checked by re-projection).
//
// MakeProjectedMap: two anchored missions driving along +x past a cloud of landmarks:
//   I: x forward, y left, z up; C: z forward (= I's x), x right, y down.
//   cam0 at p_I_C = (0.1, 0.05, 0), cam1 at (0.1, -0.05, 0) yawed by -5 deg.
//   mission 0: T_G_M = identity; mission 1: T_G_M = yaw 10 deg, p = (0.5, -0.3, 0.1).
//   vertex k: p_M = (0.3 k, 0.2 sin k, 1), yaw 3 sin(0.7 k) deg, t = t0 + k * 0.1 s.
//   landmarks: seeded uniform in x [5, 12], y [-3, 3], z [-0.5, 2.5] m (G); stored in the first
//   vertex that sees one; observed by every (vertex, camera) where it projects inside the image
//   (cross-mission observations included); qualities: every 5th bad, every 7th (not bad)
//   unknown, else good. Two distractor keypoints without landmark per frame.
//   images (optional): PNG resources whose grey value is a smooth function of the pixel's ray
//   (RayPattern), so an undistorted image can be checked against the pattern rendered directly.
#pragma once

#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "vilma/core/progress.h"
#include "vilma/core/rig.h"
#include "vilma/mapstore/vi_map.h"

namespace vilma::mapping::testing {

// A fresh empty folder for one test under the build folder (left for inspection, replaced by
// the next run).
inline std::string ScratchFolder(const std::string& name) {
  const std::filesystem::path dir =
      std::filesystem::path(VILMA_BINARY_DIR) / "test-cache" / "export" / name;
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir.string();
}

inline std::string ReadText(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  REQUIRE(in.good());
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

inline std::vector<std::string> Split(const std::string& text, char separator) {
  std::vector<std::string> parts;
  std::string part;
  std::istringstream s(text);
  while (std::getline(s, part, separator)) parts.push_back(part);
  if (!text.empty() && text.back() == separator) parts.push_back("");
  return parts;
}

// Lines of a file without the trailing newline.
inline std::vector<std::string> ReadLines(const std::string& path) {
  std::vector<std::string> lines;
  std::istringstream s(ReadText(path));
  std::string line;
  while (std::getline(s, line)) lines.push_back(line);
  return lines;
}

// A progress observer that asks to cancel once `cancel_after` Advance calls were made (Ctrl-C
// in the console).
class CancelAfter : public ProgressObserver {
 public:
  explicit CancelAfter(int cancel_after) : cancel_after_(cancel_after) {}
  void Begin(const std::string&, std::size_t) override {}
  void Advance(std::size_t) override { ++advances_; }
  bool CancelRequested() const override { return advances_ >= cancel_after_; }
  int advances() const { return advances_; }

 private:
  int cancel_after_;
  int advances_ = 0;
};

// Whole-text decimal number (as Python's float() would accept), else false.
inline bool ParseNumber(const std::string& text, double* value) {
  if (text.empty()) return false;
  char* end = nullptr;
  *value = std::strtod(text.c_str(), &end);
  return end == text.c_str() + text.size();
}

// The grey value [0, 255] the test images show along the ray with normalized coordinates
// (x/z, y/z).
inline double RayPattern(double x, double y) {
  return 128.0 + 90.0 * std::sin(5.0 * x + 0.5) * std::cos(4.0 * y - 0.3);
}

// Renders the pattern into an image of `camera` (each pixel: its ray's pattern value).
inline cv::Mat RenderPattern(const Camera& camera) {
  cv::Mat image(camera.height(), camera.width(), CV_8UC1);
  for (int v = 0; v < camera.height(); ++v) {
    for (int u = 0; u < camera.width(); ++u) {
      Eigen::Vector3d bearing;
      REQUIRE(camera.Unproject(Eigen::Vector2d(u, v), &bearing));
      image.at<uint8_t>(v, u) = cv::saturate_cast<uint8_t>(
          std::lround(RayPattern(bearing.x() / bearing.z(), bearing.y() / bearing.z())));
    }
  }
  return image;
}

struct ProjectedMapOptions {
  DistortionModel model = DistortionModel::kRadTan;
  int vertices_per_mission = 8;
  int landmarks = 80;
  bool images = false;
  uint64_t seed = 5;
};

struct ProjectedMap {
  mapstore::VIMap map;
  std::vector<mapstore::MissionId> missions;
  std::size_t frames = 0;  // vertices x cameras
  std::size_t keypoints = 0;
  std::size_t observations = 0;  // of all landmarks
  std::size_t good = 0, bad = 0, unknown = 0;
  std::size_t good_observations = 0;
};

inline Camera ProjectedMapCamera(DistortionModel model) {
  Eigen::VectorXd k(NumDistortionCoefficients(model));
  if (model == DistortionModel::kRadTan) k << -0.2, 0.05, 1e-3, -5e-4;
  if (model == DistortionModel::kEquidistant) k << 0.02, -0.01, 0.003, -0.001;
  return Camera(160, 120, Eigen::Vector4d(120.0, 118.0, 79.5, 59.5), model, k);
}

inline ProjectedMap MakeProjectedMap(const ProjectedMapOptions& o) {
  using namespace mapstore;
  ProjectedMap out;
  const double kDeg = std::acos(-1.0) / 180.0;
  auto yaw = [](double rad) {
    return Eigen::Quaterniond(Eigen::AngleAxisd(rad, Eigen::Vector3d::UnitZ()));
  };
  Eigen::Matrix3d R_I_C;
  R_I_C.col(0) = Eigen::Vector3d(0, -1, 0);
  R_I_C.col(1) = Eigen::Vector3d(0, 0, -1);
  R_I_C.col(2) = Eigen::Vector3d(1, 0, 0);
  SensorRig rig;
  for (int c = 0; c < 2; ++c) {
    CameraConfig cam;
    cam.name = "cam" + std::to_string(c);
    cam.camera = ProjectedMapCamera(o.model);
    const Eigen::Matrix3d R =
        (c == 0 ? Eigen::Matrix3d::Identity() : yaw(-5 * kDeg).toRotationMatrix()) * R_I_C;
    cam.T_I_C = Transformation(R, Eigen::Vector3d(0.1, c == 0 ? 0.05 : -0.05, 0.0));
    rig.cameras.push_back(cam);
  }
  std::mt19937_64 rng(o.seed);
  std::uniform_real_distribution<double> ux(5, 12), uy(-3, 3), uz(-0.5, 2.5);
  std::vector<Eigen::Vector3d> p_G(o.landmarks);
  for (Eigen::Vector3d& p : p_G) {
    // z, y, x: the order GCC drew them in (tests/test_random.h).
    const double z = uz(rng);
    const double y = uy(rng);
    const double x = ux(rng);
    p = Eigen::Vector3d(x, y, z);
  }

  IdGenerator mission_ids(o.seed);
  std::vector<LandmarkId> landmark_ids(o.landmarks);
  std::vector<bool> added(o.landmarks, false);
  for (int mi = 0; mi < 2; ++mi) {
    Mission mission;
    mission.id = mission_ids.Next();
    mission.name = "run" + std::to_string(mi);
    mission.baseframe_known = true;
    mission.T_G_M = mi == 0 ? Transformation()
                            : Transformation(yaw(10 * kDeg), Eigen::Vector3d(0.5, -0.3, 0.1));
    mission.rig = rig;
    mission.complete = true;
    out.map.AddMission(mission);
    out.missions.push_back(mission.id);
    IdGenerator ids = IdGenerator::ForMission(mission.id);
    VertexId previous;
    for (int k = 0; k < o.vertices_per_mission; ++k) {
      Vertex v;
      v.id = ids.Next();
      v.mission_id = mission.id;
      v.t_ns = 1'500'000'000'000'000'000LL + mi * 60'000'000'000LL + k * 100'000'000LL;
      v.T_M_I = Transformation(yaw(3 * kDeg * std::sin(0.7 * k)),
                               Eigen::Vector3d(0.3 * k, 0.2 * std::sin(k), 1.0));
      v.v_M = Eigen::Vector3d(3.0, 0.2 * std::cos(k), 0.0);
      const Transformation T_G_I = mission.T_G_M * v.T_M_I;
      std::vector<std::pair<int, int>> seen;  // (camera, landmark) per keypoint
      for (int c = 0; c < 2; ++c) {
        const CameraConfig& cam = rig.cameras[c];
        const Transformation T_C_G = (T_G_I * cam.T_I_C).inverse();
        VisualFrame f;
        for (int l = 0; l < o.landmarks; ++l) {
          Eigen::Vector2d uv;
          const Eigen::Vector3d p_C = T_C_G * p_G[l];
          if (p_C.z() < 0.5 || cam.camera.Project(p_C, &uv) != Camera::ProjectionResult::kValid) {
            continue;
          }
          Keypoint kp;
          kp.uv = uv;
          kp.scale = 6.0;
          kp.score = 10.0 + l;
          f.keypoints.push_back(kp);
          f.track_ids.push_back(l);
          seen.push_back({c, l});
        }
        for (int d = 0; d < 2; ++d) {  // distractors
          Keypoint kp;
          kp.uv = Eigen::Vector2d(10.0 + 30.0 * d + k, 100.0 - 7.0 * d);
          f.keypoints.push_back(kp);
          f.track_ids.push_back(-1);
          seen.push_back({c, -1});
        }
        f.landmark_ids.assign(f.keypoints.size(), LandmarkId());
        f.descriptors.assign(f.keypoints.size() * f.descriptor_size_bytes, 0);
        for (std::size_t i = 0; i < f.descriptors.size(); ++i) {
          f.descriptors[i] = static_cast<uint8_t>((i * 37 + k * 11 + c * 5 + mi) & 0xff);
        }
        if (o.images) {
          f.image_resource_id = ids.Next();
          std::vector<uchar> png;
          REQUIRE(cv::imencode(".png", RenderPattern(cam.camera), png));
          out.map.resources().Add(ResourceType::kImage, f.image_resource_id, "png",
                                  std::string(png.begin(), png.end()));
        }
        out.keypoints += f.keypoints.size();
        v.frames.push_back(std::move(f));
        ++out.frames;
      }
      const VertexId vertex_id = v.id;
      out.map.AddVertex(std::move(v));
      if (k == 0) out.map.mission(mission.id).root_vertex_id = vertex_id;
      if (k > 0) {
        Edge e;
        e.id = ids.Next();
        e.type = EdgeType::kImu;
        e.from = previous;
        e.to = vertex_id;
        const int64_t t0 = out.map.vertex(previous).t_ns, t1 = out.map.vertex(vertex_id).t_ns;
        for (int s = 0; s <= 20; ++s) {
          ImuSample sample;
          sample.t_ns = t0 + (t1 - t0) * s / 20;
          sample.a_I = Eigen::Vector3d(0.1 * s, 0.0, 9.81);
          e.imu_samples.push_back(sample);
        }
        out.map.AddEdge(std::move(e));
      }
      previous = vertex_id;
      // Landmarks: created at their first observer, then observed.
      std::vector<uint32_t> next_index(2, 0);
      for (const auto& [c, l] : seen) {
        const uint32_t keypoint = next_index[c]++;
        if (l < 0) continue;
        if (!added[l]) {
          Landmark landmark;
          landmark.id = ids.Next();
          landmark.store_vertex_id = vertex_id;
          landmark.p_I = T_G_I.inverse() * p_G[l];
          landmark.quality = l % 5 == 0   ? LandmarkQuality::kBad
                             : l % 7 == 0 ? LandmarkQuality::kUnknown
                                          : LandmarkQuality::kGood;
          out.map.AddLandmark(landmark);
          landmark_ids[l] = landmark.id;
          added[l] = true;
          (landmark.quality == LandmarkQuality::kGood  ? out.good
           : landmark.quality == LandmarkQuality::kBad ? out.bad
                                                       : out.unknown)++;
        }
        out.map.AddObservation(landmark_ids[l], {vertex_id, static_cast<uint32_t>(c), keypoint});
        ++out.observations;
        if (out.map.landmark(landmark_ids[l]).quality == LandmarkQuality::kGood) {
          ++out.good_observations;
        }
      }
    }
  }
  return out;
}

}  // namespace vilma::mapping::testing
