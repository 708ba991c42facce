#include "vilma/mapping/from_poses/map_from_poses.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <map>
#include <random>
#include <sstream>

#include "pair_matching.h"
#include "vilma/core/asl_dataset.h"
#include "vilma/core/error.h"
#include "vilma/core/imu.h"
#include "vilma/localizer/keyframe_features.h"
#include "vilma/mapping/triangulation.h"
#include "vilma/mapstore/id.h"

namespace vilma::mapping {

using internal::DescriptorMatch;

localizer::KeyframeFeatureOptions MapFromPosesOptions::DefaultFeatures() {
  localizer::KeyframeFeatureOptions f;
  // Wide baselines between keyframes: more keypoints, on three pyramid levels, with
  // scale-adapted descriptors, so that views from other distances still match.
  f.detector.num_levels = 3;
  f.detector.max_keypoints = 1000;
  f.detector.max_per_cell = 30;
  f.descriptor.scale_with_level = true;
  return f;
}

LandmarkQualityOptions MapFromPosesOptions::DefaultQuality() {
  LandmarkQualityOptions q;
  q.min_observers = 2;
  q.min_observation_angle_deg = 1.0;
  return q;
}

std::string MapFromPosesOptions::Validate() const {
  if (every_nth_frame < 1) return "every_nth_frame: expected >= 1";
  if (max_frames < 0) return "max_frames: expected >= 0 (0: all)";
  if (!(max_pose_gap_s > 0.0)) return "max_pose_gap_s: expected > 0";
  if (!(perturb_translation_m >= 0.0)) return "perturb_translation_m: expected >= 0";
  if (!(perturb_rotation_deg >= 0.0 && perturb_rotation_deg < 180.0)) {
    return "perturb_rotation_deg: expected 0 <= angle < 180";
  }
  if (max_hamming_distance < 0 || max_hamming_distance > 512) {
    return "max_hamming_distance: expected 0..512";
  }
  if (!(ratio > 0.0 && ratio <= 1.0)) return "ratio: expected 0 < ratio <= 1";
  if (!(pair_max_distance_m > 0.0)) return "pair_max_distance_m: expected > 0";
  if (!(pair_max_angle_deg > 0.0 && pair_max_angle_deg <= 180.0)) {
    return "pair_max_angle_deg: expected 0 < angle <= 180";
  }
  if (max_pairs_per_vertex < 0) return "max_pairs_per_vertex: expected >= 0";
  if (!(stereo_epipolar_px > 0.0)) return "stereo_epipolar_px: expected > 0";
  if (!(essential_threshold_px > 0.0)) return "essential_threshold_px: expected > 0";
  if (min_pair_inliers < 5) return "min_pair_inliers: expected >= 5";
  std::string e = features.Validate();
  if (!e.empty()) return "features." + e;
  e = triangulation.Validate();
  if (!e.empty()) return "triangulation." + e;
  e = landmark_quality.Validate();
  if (!e.empty()) return "landmark_quality." + e;
  return "";
}

std::string MapFromPosesSummary::BriefReport() const {
  std::ostringstream out;
  out << vertices << " vertices, " << landmarks << " landmarks (" << landmarks_good << " good), "
      << vertex_pairs_verified << "/" << vertex_pairs_tried << " vertex pairs verified, "
      << imu_edges << " IMU edges, " << seconds << " s";
  return out.str();
}

std::string MapFromPosesSummary::FullReport() const {
  std::ostringstream out;
  out << "frames in dataset      " << frames_in_dataset << "\n"
      << "vertices               " << vertices << " (skipped without a pose: "
      << frames_skipped_no_pose << ")\n"
      << "keypoints              " << keypoints << "\n"
      << "stereo matches         " << stereo_matches << "\n"
      << "vertex pairs           " << vertex_pairs_verified << " verified of " << vertex_pairs_tried
      << " tried, " << pair_matches << " matches\n"
      << "tracks                 " << tracks << " (inconsistent, dropped: " << tracks_inconsistent
      << ")\n"
      << "landmarks              " << landmarks << " (good " << landmarks_good
      << ", triangulation failed " << triangulation_failed << ")\n"
      << "IMU edges              " << imu_edges << " (" << imu_samples << " samples)\n"
      << "time                   " << seconds << " s\n";
  return out.str();
}

bool InterpolatePose(const Trajectory& trajectory, int64_t t_ns, int64_t max_gap_ns,
                     Transformation* T_W_B) {
  const auto& t = trajectory.t_ns;
  if (t.empty() || t_ns < t.front() || t_ns > t.back()) return false;
  const auto upper = std::lower_bound(t.begin(), t.end(), t_ns);
  const std::size_t i1 = static_cast<std::size_t>(upper - t.begin());
  if (t[i1] == t_ns) {
    *T_W_B = trajectory.T_W_B[i1];
    return true;
  }
  const std::size_t i0 = i1 - 1;
  if (std::min(t_ns - t[i0], t[i1] - t_ns) > max_gap_ns) return false;
  const double alpha = static_cast<double>(t_ns - t[i0]) / static_cast<double>(t[i1] - t[i0]);
  *T_W_B = Interpolate(trajectory.T_W_B[i0], trajectory.T_W_B[i1], alpha);
  return true;
}

Transformation PerturbationForVertex(uint64_t seed, std::size_t index, double translation_m,
                                     double rotation_deg) {
  std::mt19937_64 rng(seed * 0x9E3779B97F4A7C15ULL + index);
  std::normal_distribution<double> normal(0.0, 1.0);
  auto random_unit = [&] {
    Eigen::Vector3d v;
    do {
      // Drawn z, y, x: one statement per draw, because C++ leaves the order of a call's
      // arguments unspecified (clang and GCC differed); GCC's former order is kept so the
      // perturbations (and the figures measured with them) stay the same.
      v.z() = normal(rng);
      v.y() = normal(rng);
      v.x() = normal(rng);
    } while (v.norm() < 1e-9);
    return v.normalized();
  };
  const Eigen::Vector3d dp = random_unit() * translation_m;
  const Eigen::Vector3d axis = random_unit();
  const Eigen::Quaterniond dq(Eigen::AngleAxisd(rotation_deg * M_PI / 180.0, axis));
  return Transformation(dq, dp);
}

namespace {

struct ImageFeatures {
  bool present = false;
  localizer::KeyframeFeatures features;
  std::vector<Eigen::Vector3d> bearings_C;  // unit; zero where undistortion failed
};

struct VertexData {
  int64_t t_ns = 0;  // state time on the IMU clock
  Transformation T_M_I;
  Eigen::Vector3d v_M = Eigen::Vector3d::Zero();
  std::vector<ImageFeatures> images;  // per rig camera
};

// The dataset camera for a rig camera: by name, else by index.
int DatasetCamera(const AslDataset& dataset, const SensorRig& rig, std::size_t rig_camera) {
  for (std::size_t c = 0; c < dataset.cameras().size(); ++c) {
    if (dataset.cameras()[c].name == rig.cameras[rig_camera].name) return static_cast<int>(c);
  }
  return rig_camera < dataset.cameras().size() ? static_cast<int>(rig_camera) : -1;
}

ImuSample SampleAt(const std::vector<ImuSample>& imu, int64_t t_ns) {
  const auto it = std::lower_bound(imu.begin(), imu.end(), t_ns,
                                   [](const ImuSample& s, int64_t t) { return s.t_ns < t; });
  if (it == imu.end()) return imu.back();
  if (it->t_ns == t_ns || it == imu.begin()) return *it;
  return InterpolateImu(*(it - 1), *it, t_ns);
}

Eigen::Vector3d Velocity(const Trajectory& trajectory, int64_t t_ns) {
  // Central difference over +-50 ms of the given trajectory (0 where it is not dense there).
  constexpr int64_t kHalfStepNs = 50'000'000;
  Transformation before, after;
  if (!InterpolatePose(trajectory, t_ns - kHalfStepNs, kHalfStepNs, &before) ||
      !InterpolatePose(trajectory, t_ns + kHalfStepNs, kHalfStepNs, &after)) {
    return Eigen::Vector3d::Zero();
  }
  return (after.translation() - before.translation()) / (2e-9 * kHalfStepNs);
}

}  // namespace

mapstore::VIMap BuildMapFromPoses(const std::string& dataset_root, const SensorRig& rig,
                                  const Trajectory& T_W_I, const MapFromPosesOptions& options,
                                  MapFromPosesSummary* summary, ProgressObserver* progress) {
  const auto start = std::chrono::steady_clock::now();
  const std::string problem = options.Validate();
  if (!problem.empty()) throw std::invalid_argument("MapFromPosesOptions: " + problem);
  const std::string rig_problem = rig.Validate();
  if (!rig_problem.empty()) throw InputError(FormatInputError("rig", "", rig_problem));
  MapFromPosesSummary local_summary;
  MapFromPosesSummary& s = summary != nullptr ? *summary : local_summary;
  s = MapFromPosesSummary();

  const AslDataset dataset = AslDataset::Open(dataset_root);
  if (dataset.imu().size() < 2) {
    throw InputError(FormatInputError(dataset.mav0_dir() + "/imu0/data.csv", "",
                                      "IMU samples (the map's IMU edges need them)"));
  }
  const std::size_t num_cameras = rig.cameras.size();
  std::vector<int> dataset_camera(num_cameras);
  for (std::size_t c = 0; c < num_cameras; ++c) {
    dataset_camera[c] = DatasetCamera(dataset, rig, c);
    if (dataset_camera[c] < 0) {
      throw InputError(FormatInputError(dataset.mav0_dir(), rig.cameras[c].name,
                                        "a camera folder for every rig camera"));
    }
  }
  // Frame times from the first camera; the others' images at the same time stamp.
  const AslCamera& camera0 = dataset.cameras()[static_cast<std::size_t>(dataset_camera[0])];
  s.frames_in_dataset = static_cast<int>(camera0.frames.size());
  std::vector<std::map<int64_t, std::string>> images(num_cameras);
  for (std::size_t c = 0; c < num_cameras; ++c) {
    for (const CameraFrame& f : dataset.cameras()[static_cast<std::size_t>(dataset_camera[c])].frames) {
      images[c][f.t_ns] = f.image_path;
    }
  }

  // 1. Vertices.
  std::vector<VertexData> vertices;
  const int64_t max_gap_ns = static_cast<int64_t>(options.max_pose_gap_s * 1e9);
  for (std::size_t i = 0; i < camera0.frames.size();
       i += static_cast<std::size_t>(options.every_nth_frame)) {
    if (options.max_frames > 0 && static_cast<int>(vertices.size()) >= options.max_frames) break;
    const int64_t t_cam = camera0.frames[i].t_ns;
    const int64_t t_imu = t_cam + rig.cameras[0].time_offset_ns;
    Transformation T;
    if (!InterpolatePose(T_W_I, t_imu, max_gap_ns, &T)) {
      ++s.frames_skipped_no_pose;
      continue;
    }
    VertexData v;
    v.t_ns = t_imu;
    v.T_M_I = T * PerturbationForVertex(options.seed, vertices.size(),
                                        options.perturb_translation_m,
                                        options.perturb_rotation_deg);
    v.v_M = Velocity(T_W_I, t_imu);
    v.images.resize(num_cameras);
    vertices.push_back(std::move(v));
  }
  if (vertices.empty()) {
    throw InputError(FormatInputError(dataset.mav0_dir(), "",
                                      "frames within the trajectory's time span (no frame has a pose)"));
  }
  s.vertices = static_cast<int>(vertices.size());

  // 2. Features.
  const localizer::FeatureExtractor extractor(options.features);
  BeginProgress(progress, "features", vertices.size());
  for (std::size_t vi = 0; vi < vertices.size(); ++vi) {
    const int64_t t_cam0 = vertices[vi].t_ns - rig.cameras[0].time_offset_ns;
    for (std::size_t c = 0; c < num_cameras; ++c) {
      auto image = images[c].find(t_cam0);
      if (image == images[c].end()) continue;
      ImageFeatures& f = vertices[vi].images[c];
      f.present = true;
      f.features = extractor.Extract(AslDataset::LoadImage(image->second));
      f.bearings_C.resize(f.features.keypoints.size(), Eigen::Vector3d::Zero());
      for (std::size_t k = 0; k < f.features.keypoints.size(); ++k) {
        const cv::Point2f& pt = f.features.keypoints[k].pt;
        Eigen::Vector3d bearing;
        if (rig.cameras[c].camera.Unproject(Eigen::Vector2d(pt.x, pt.y), &bearing)) {
          f.bearings_C[k] = bearing.normalized();
        }
      }
      s.keypoints += f.features.size();
    }
    ReportProgress(progress, vi + 1);
  }

  // Node numbering: one node per keypoint of every image.
  std::vector<std::vector<int>> node_offset(vertices.size(), std::vector<int>(num_cameras, 0));
  int num_nodes = 0;
  for (std::size_t vi = 0; vi < vertices.size(); ++vi) {
    for (std::size_t c = 0; c < num_cameras; ++c) {
      node_offset[vi][c] = num_nodes;
      num_nodes += vertices[vi].images[c].features.size();
    }
  }
  internal::DisjointSets sets(static_cast<std::size_t>(num_nodes));
  auto focal = [&](std::size_t c) {
    return 0.5 * (rig.cameras[c].camera.fx() + rig.cameras[c].camera.fy());
  };

  // 3a. Stereo pairs within each vertex (known extrinsics).
  for (std::size_t vi = 0; vi < vertices.size(); ++vi) {
    for (std::size_t ca = 0; ca < num_cameras; ++ca) {
      for (std::size_t cb = ca + 1; cb < num_cameras; ++cb) {
        const ImageFeatures& a = vertices[vi].images[ca];
        const ImageFeatures& b = vertices[vi].images[cb];
        if (!a.present || !b.present) continue;
        const Transformation T_Ca_Cb = rig.cameras[ca].T_I_C.inverse() * rig.cameras[cb].T_I_C;
        const auto matches = internal::FilterEpipolar(
            internal::MatchDescriptors(a.features.descriptors, b.features.descriptors,
                                       options.max_hamming_distance, options.ratio),
            a.bearings_C, b.bearings_C, T_Ca_Cb,
            options.stereo_epipolar_px / std::min(focal(ca), focal(cb)));
        for (const DescriptorMatch& m : matches) {
          sets.Union(node_offset[vi][ca] + m.a, node_offset[vi][cb] + m.b);
        }
        s.stereo_matches += static_cast<int>(matches.size());
      }
    }
  }

  // 3b. Vertex pairs that may see the same scene, by the given poses.
  struct CameraView {
    Eigen::Vector3d centre_M, axis_M;
  };
  auto view = [&](std::size_t vi, std::size_t c) {
    const Transformation T_M_C = vertices[vi].T_M_I * rig.cameras[c].T_I_C;
    return CameraView{T_M_C.translation(), T_M_C.rotation() * Eigen::Vector3d::UnitZ()};
  };
  const double cos_max_angle = std::cos(options.pair_max_angle_deg * M_PI / 180.0);
  std::vector<std::pair<std::size_t, std::size_t>> pairs;
  for (std::size_t i = 0; i < vertices.size(); ++i) {
    std::vector<std::pair<double, std::size_t>> candidates;
    for (std::size_t j = 0; j < vertices.size(); ++j) {
      if (j == i) continue;
      double best = std::numeric_limits<double>::infinity();
      for (std::size_t ca = 0; ca < num_cameras; ++ca) {
        for (std::size_t cb = 0; cb < num_cameras; ++cb) {
          const CameraView a = view(i, ca), b = view(j, cb);
          const double d = (a.centre_M - b.centre_M).norm();
          if (d <= options.pair_max_distance_m && a.axis_M.dot(b.axis_M) >= cos_max_angle) {
            best = std::min(best, d);
          }
        }
      }
      if (std::isfinite(best)) candidates.emplace_back(best, j);
    }
    std::sort(candidates.begin(), candidates.end());
    if (static_cast<int>(candidates.size()) > options.max_pairs_per_vertex) {
      candidates.resize(static_cast<std::size_t>(options.max_pairs_per_vertex));
    }
    for (const auto& c : candidates) pairs.emplace_back(std::min(i, c.second), std::max(i, c.second));
  }
  std::sort(pairs.begin(), pairs.end());
  pairs.erase(std::unique(pairs.begin(), pairs.end()), pairs.end());
  BeginProgress(progress, "matching", pairs.size());
  std::size_t done = 0;
  for (const auto& [i, j] : pairs) {
    ++s.vertex_pairs_tried;
    bool verified = false;
    for (std::size_t ca = 0; ca < num_cameras; ++ca) {
      for (std::size_t cb = 0; cb < num_cameras; ++cb) {
        const ImageFeatures& a = vertices[i].images[ca];
        const ImageFeatures& b = vertices[j].images[cb];
        if (!a.present || !b.present) continue;
        const CameraView va = view(i, ca), vb = view(j, cb);
        if ((va.centre_M - vb.centre_M).norm() > options.pair_max_distance_m ||
            va.axis_M.dot(vb.axis_M) < cos_max_angle) {
          continue;
        }
        const auto matches =
            internal::MatchDescriptors(a.features.descriptors, b.features.descriptors,
                                       options.max_hamming_distance, options.ratio);
        if (static_cast<int>(matches.size()) < options.min_pair_inliers) continue;
        const uint64_t pair_seed =
            options.seed ^ (0x9E3779B97F4A7C15ULL * (i * 1315423911ULL + j * 2654435761ULL +
                                                      ca * 97 + cb * 89 + 1));
        const auto inliers = internal::FilterEssential(
            matches, a.bearings_C, b.bearings_C,
            options.essential_threshold_px / std::min(focal(ca), focal(cb)), pair_seed);
        if (static_cast<int>(inliers.size()) < options.min_pair_inliers) continue;
        verified = true;
        s.pair_matches += static_cast<int>(inliers.size());
        for (const DescriptorMatch& m : inliers) {
          sets.Union(node_offset[i][ca] + m.a, node_offset[j][cb] + m.b);
        }
      }
    }
    if (verified) ++s.vertex_pairs_verified;
    ReportProgress(progress, ++done);
  }

  // 4. Tracks: components, in node order (deterministic).
  struct Node {
    std::size_t vertex, camera;
    int keypoint;
  };
  std::map<int, std::vector<Node>> components;
  for (std::size_t vi = 0; vi < vertices.size(); ++vi) {
    for (std::size_t c = 0; c < num_cameras; ++c) {
      for (int k = 0; k < vertices[vi].images[c].features.size(); ++k) {
        const int root = sets.Find(node_offset[vi][c] + k);
        components[root].push_back({vi, c, k});
      }
    }
  }

  // The map.
  mapstore::VIMap map;
  const uint64_t content_seed =
      mapstore::SeedFromFileContent(dataset.mav0_dir() + "/imu0/data.csv") ^ options.seed;
  mapstore::IdGenerator mission_ids(content_seed == 0 ? 1 : content_seed);
  mapstore::Mission mission;
  mission.id = mission_ids.Next();
  mission.name = options.mission_name.empty()
                     ? std::filesystem::path(dataset_root).lexically_normal().filename().string()
                     : options.mission_name;
  mission.rig = rig;
  mission.complete = true;
  mapstore::IdGenerator ids = mapstore::IdGenerator::ForMission(mission.id);
  std::vector<mapstore::VertexId> vertex_ids;
  for (std::size_t vi = 0; vi < vertices.size(); ++vi) vertex_ids.push_back(ids.Next());
  mission.root_vertex_id = vertex_ids.front();
  map.AddMission(mission);
  for (std::size_t vi = 0; vi < vertices.size(); ++vi) {
    const VertexData& d = vertices[vi];
    mapstore::Vertex v;
    v.id = vertex_ids[vi];
    v.mission_id = mission.id;
    v.t_ns = d.t_ns;
    v.T_M_I = d.T_M_I;
    v.v_M = d.v_M;
    v.frames.resize(num_cameras);
    for (std::size_t c = 0; c < num_cameras; ++c) {
      const localizer::KeyframeFeatures& f = d.images[c].features;
      mapstore::VisualFrame& frame = v.frames[c];
      std::string type = f.descriptor_type;
      std::transform(type.begin(), type.end(), type.begin(), ::toupper);
      frame.descriptor_type = type;
      frame.descriptor_size_bytes = f.descriptors.empty() ? 64u : static_cast<uint32_t>(f.descriptors.cols);
      for (int k = 0; k < f.size(); ++k) {
        const cv::KeyPoint& kp = f.keypoints[static_cast<std::size_t>(k)];
        mapstore::Keypoint out;
        out.uv = Eigen::Vector2d(kp.pt.x, kp.pt.y);
        out.scale = kp.size;
        out.orientation = kp.angle * M_PI / 180.0;
        out.score = kp.response;
        frame.keypoints.push_back(out);
        const uint8_t* row = f.descriptors.ptr<uint8_t>(k);
        frame.descriptors.insert(frame.descriptors.end(), row, row + frame.descriptor_size_bytes);
      }
      frame.track_ids.assign(frame.keypoints.size(), -1);
      frame.landmark_ids.assign(frame.keypoints.size(), mapstore::LandmarkId());
    }
    map.AddVertex(std::move(v));
  }

  // 5. Landmarks.
  int64_t track_id = 0;
  for (auto& [root, nodes] : components) {
    if (nodes.size() < 2) continue;
    std::map<std::pair<std::size_t, std::size_t>, int> per_image;
    bool consistent = true;
    for (const Node& n : nodes) consistent = consistent && ++per_image[{n.vertex, n.camera}] == 1;
    if (!consistent) {
      ++s.tracks_inconsistent;
      continue;
    }
    ++s.tracks;
    std::vector<TriangulationObservation> observations;
    for (const Node& n : nodes) {
      TriangulationObservation o;
      o.T_M_C = vertices[n.vertex].T_M_I * rig.cameras[n.camera].T_I_C;
      o.camera = &rig.cameras[n.camera].camera;
      const cv::Point2f& pt = vertices[n.vertex].images[n.camera].features.keypoints[static_cast<std::size_t>(n.keypoint)].pt;
      o.uv = Eigen::Vector2d(pt.x, pt.y);
      observations.push_back(o);
    }
    const TriangulationResult result = Triangulate(observations, options.triangulation);
    const int64_t this_track = track_id++;
    for (const Node& n : nodes) {
      map.vertex(vertex_ids[n.vertex]).frames[n.camera].track_ids[static_cast<std::size_t>(n.keypoint)] = this_track;
    }
    if (!result.ok()) {
      ++s.triangulation_failed;
      continue;
    }
    const std::size_t store = nodes.front().vertex;  // components are in vertex order
    mapstore::Landmark landmark;
    landmark.id = ids.Next();
    landmark.store_vertex_id = vertex_ids[store];
    const Transformation T_I_M = vertices[store].T_M_I.inverse();
    landmark.p_I = T_I_M * result.p_M;
    const Eigen::Matrix3d R_I_M = T_I_M.rotation().toRotationMatrix();
    landmark.covariance = R_I_M * result.covariance_M * R_I_M.transpose();
    const LandmarkVerdict verdict =
        EvaluateLandmarkQuality(observations, result, options.landmark_quality);
    landmark.quality = verdict == LandmarkVerdict::kGood ? mapstore::LandmarkQuality::kGood
                                                        : mapstore::LandmarkQuality::kBad;
    const mapstore::LandmarkId landmark_id = landmark.id;
    map.AddLandmark(landmark);
    for (const Node& n : nodes) {
      map.AddObservation(landmark_id, {vertex_ids[n.vertex], static_cast<uint32_t>(n.camera),
                                       static_cast<uint32_t>(n.keypoint)});
    }
    ++s.landmarks;
    if (verdict == LandmarkVerdict::kGood) ++s.landmarks_good;
  }

  // 6. IMU edges.
  const std::vector<ImuSample>& imu = dataset.imu();
  for (std::size_t vi = 0; vi + 1 < vertices.size(); ++vi) {
    const int64_t t_from = vertices[vi].t_ns, t_to = vertices[vi + 1].t_ns;
    if (t_from < imu.front().t_ns || t_to > imu.back().t_ns) {
      throw InputError(FormatInputError(dataset.mav0_dir() + "/imu0/data.csv", "",
                                        "IMU samples covering every frame time (" +
                                            std::to_string(t_from) + " .. " +
                                            std::to_string(t_to) + " ns is not covered)"));
    }
    mapstore::Edge edge;
    edge.id = ids.Next();
    edge.type = mapstore::EdgeType::kImu;
    edge.from = vertex_ids[vi];
    edge.to = vertex_ids[vi + 1];
    edge.imu_samples.push_back(SampleAt(imu, t_from));
    auto it = std::upper_bound(imu.begin(), imu.end(), t_from,
                               [](int64_t t, const ImuSample& sample) { return t < sample.t_ns; });
    for (; it != imu.end() && it->t_ns < t_to; ++it) edge.imu_samples.push_back(*it);
    edge.imu_samples.push_back(SampleAt(imu, t_to));
    s.imu_samples += static_cast<int>(edge.imu_samples.size());
    ++s.imu_edges;
    map.AddEdge(std::move(edge));
  }
  s.seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start).count();
  return map;
}

}  // namespace vilma::mapping
