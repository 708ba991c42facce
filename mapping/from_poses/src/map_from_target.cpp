#include "vilma/mapping/from_poses/map_from_target.h"

#include <opencv2/calib3d.hpp>
#include <opencv2/core/eigen.hpp>

#include <algorithm>
#include <cmath>
#include <iomanip>
#include <map>
#include <sstream>
#include <stdexcept>

#include "vilma/core/error.h"
#include "vilma/mapping/from_poses/map_from_poses.h"

namespace vilma::mapping {
namespace {

double Median(std::vector<double> v) {
  if (v.empty()) return 0.0;
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(v.size() / 2), v.end());
  return v[v.size() / 2];
}

ImuSample SampleAt(const std::vector<ImuSample>& imu, int64_t t_ns) {
  const auto it = std::lower_bound(imu.begin(), imu.end(), t_ns,
                                   [](const ImuSample& s, int64_t t) { return s.t_ns < t; });
  if (it == imu.end()) return imu.back();
  if (it->t_ns == t_ns || it == imu.begin()) return *it;
  return InterpolateImu(*(it - 1), *it, t_ns);
}

struct VertexDraft {
  int64_t t_ns = 0;          // IMU clock
  int64_t stamp_ns = 0;      // the first camera's image stamp
  Transformation T_T_I;
  std::vector<const TargetImage*> images;  // per rig camera (nullptr: none at this stamp)
};

}  // namespace

std::string MapFromTargetOptions::Validate() const {
  if (min_corners < 4) return "min_corners: expected >= 4 (PnP)";
  if (!(max_pnp_rmse_px > 0)) return "max_pnp_rmse_px: expected > 0";
  if (every_nth_image < 1) return "every_nth_image: expected >= 1";
  if (!(max_duration_s >= 0)) return "max_duration_s: expected >= 0 (0: all)";
  if (!(perturb_extrinsics_m >= 0)) return "perturb_extrinsics_m: expected >= 0";
  if (!(perturb_extrinsics_deg >= 0 && perturb_extrinsics_deg < 180)) {
    return "perturb_extrinsics_deg: expected in [0, 180)";
  }
  if (mission_name.empty()) return "mission_name: expected a name";
  return "";
}

std::string MapFromTargetSummary::BriefReport() const {
  std::ostringstream out;
  out << "ltr: " << vertices << " vertices from " << images << " images ("
      << skipped_few_corners + skipped_pnp + skipped_outside_imu << " skipped), " << landmarks
      << " held landmarks, " << observations << " observations, " << imu_edges
      << " IMU edges, PnP RMSE median " << pnp_rmse_median_px << " px";
  return out.str();
}

std::string MapFromTargetSummary::FullReport() const {
  std::ostringstream out;
  out << "images (first camera)  " << images << " (skipped: " << skipped_few_corners
      << " with too few corners, " << skipped_pnp << " by PnP, "
      << skipped_outside_imu << " outside the IMU's time span)\n"
      << "vertices               " << vertices << "\n"
      << "landmarks (held)       " << landmarks << ", observations " << observations << "\n"
      << "IMU edges              " << imu_edges << "\n"
      << "PnP RMSE median        " << pnp_rmse_median_px << " px\n"
      << "target tilt to gravity " << gravity_tilt_deg << " deg\n";
  return out.str();
}

bool SolveTargetPnp(const Camera& camera, const std::vector<Eigen::Vector2d>& uv,
                    const std::vector<Eigen::Vector3d>& p_T, Transformation* T_T_C,
                    double* rmse_px) {
  if (uv.size() != p_T.size() || uv.size() < 4) return false;
  std::vector<cv::Point2d> normalized;
  std::vector<cv::Point3d> object;
  for (std::size_t i = 0; i < uv.size(); ++i) {
    Eigen::Vector3d bearing;
    if (!camera.Unproject(uv[i], &bearing) || bearing.z() <= 0) return false;
    normalized.emplace_back(bearing.x() / bearing.z(), bearing.y() / bearing.z());
    object.emplace_back(p_T[i].x(), p_T[i].y(), p_T[i].z());
  }
  const cv::Mat K = cv::Mat::eye(3, 3, CV_64F);
  cv::Mat rvec, tvec;
  // IPPE needs a planar target (z = 0 here); other targets start from EPnP.
  bool planar = true;
  for (const Eigen::Vector3d& p : p_T) planar = planar && std::abs(p.z()) < 1e-9;
  if (!cv::solvePnP(object, normalized, K, cv::noArray(), rvec, tvec, false,
                    planar ? cv::SOLVEPNP_IPPE : cv::SOLVEPNP_EPNP)) {
    return false;
  }
  cv::solvePnPRefineLM(object, normalized, K, cv::noArray(), rvec, tvec);
  cv::Mat R;
  cv::Rodrigues(rvec, R);
  Eigen::Matrix3d R_C_T;
  Eigen::Vector3d t_C_T;
  cv::cv2eigen(R, R_C_T);
  cv::cv2eigen(tvec, t_C_T);
  if (!R_C_T.allFinite() || !t_C_T.allFinite()) return false;
  const Transformation T_C_T(R_C_T, t_C_T);
  double sum = 0.0;
  for (std::size_t i = 0; i < uv.size(); ++i) {
    Eigen::Vector2d projected;
    if (camera.Project(T_C_T * p_T[i], &projected) == Camera::ProjectionResult::kBehindCamera) {
      return false;
    }
    sum += (projected - uv[i]).squaredNorm();
  }
  *T_T_C = T_C_T.inverse();
  *rmse_px = std::sqrt(sum / static_cast<double>(uv.size()));
  return true;
}

mapstore::VIMap BuildMapFromTarget(const std::string& folder, const SensorRig& rig,
                                   const MapFromTargetOptions& options,
                                   MapFromTargetSummary* summary) {
  const std::string problem = options.Validate();
  if (!problem.empty()) throw std::invalid_argument("MapFromTargetOptions: " + problem);
  const std::string rig_problem = rig.Validate();
  if (!rig_problem.empty()) throw InputError(FormatInputError("rig", "", rig_problem));
  if (rig.cameras.empty()) throw InputError(FormatInputError("rig", "cameras", "a camera"));
  MapFromTargetSummary local;
  MapFromTargetSummary& s = summary != nullptr ? *summary : local;
  s = MapFromTargetSummary();

  const std::vector<ImuSample> imu = ReadTargetImu(folder + "/imu0.csv");
  std::vector<std::vector<TargetImage>> cameras;
  for (const CameraConfig& c : rig.cameras) cameras.push_back(ReadTargetCamera(folder + "/" + c.name));

  // The rig, its extrinsics perturbed as a whole (the experiment's starting point).
  SensorRig map_rig = rig;
  const Transformation perturbation = PerturbationForVertex(
      options.seed, 0, options.perturb_extrinsics_m, options.perturb_extrinsics_deg);
  for (CameraConfig& c : map_rig.cameras) c.T_I_C = perturbation * c.T_I_C;

  // 1. Vertices from the first camera's images with a good PnP.
  std::vector<VertexDraft> drafts;
  std::vector<double> pnp_rmse;
  const std::vector<TargetImage>& first = cameras[0];
  s.images = static_cast<int>(first.size());
  for (std::size_t i = 0; i < first.size(); i += static_cast<std::size_t>(options.every_nth_image)) {
    const TargetImage& image = first[i];
    if (options.max_duration_s > 0 &&
        1e-9 * static_cast<double>(image.t_ns - first.front().t_ns) > options.max_duration_s) {
      break;
    }
    const int64_t t_imu = image.t_ns + options.camera_time_shift_ns + map_rig.cameras[0].time_offset_ns;
    if (t_imu < imu.front().t_ns || t_imu > imu.back().t_ns) {
      ++s.skipped_outside_imu;
      continue;
    }
    if (static_cast<int>(image.corners.size()) < options.min_corners) {
      ++s.skipped_few_corners;
      continue;
    }
    std::vector<Eigen::Vector2d> uv;
    std::vector<Eigen::Vector3d> p_T;
    for (const TargetCorner& c : image.corners) {
      uv.push_back(c.uv);
      p_T.push_back(c.p_T);
    }
    Transformation T_T_C;
    double rmse = 0.0;
    if (!SolveTargetPnp(map_rig.cameras[0].camera, uv, p_T, &T_T_C, &rmse) ||
        rmse > options.max_pnp_rmse_px) {
      ++s.skipped_pnp;
      continue;
    }
    pnp_rmse.push_back(rmse);
    VertexDraft d;
    d.stamp_ns = image.t_ns;
    d.t_ns = t_imu;
    d.T_T_I = T_T_C * map_rig.cameras[0].T_I_C.inverse();
    d.images.assign(cameras.size(), nullptr);
    for (std::size_t c = 0; c < cameras.size(); ++c) {
      const auto it = std::lower_bound(
          cameras[c].begin(), cameras[c].end(), image.t_ns,
          [](const TargetImage& a, int64_t t) { return a.t_ns < t; });
      if (it != cameras[c].end() && it->t_ns == image.t_ns) d.images[c] = &*it;
    }
    drafts.push_back(d);
  }
  if (drafts.size() < 2) {
    throw InputError(FormatInputError(folder + "/" + rig.cameras[0].name, "",
                                      "at least two images with " +
                                          std::to_string(options.min_corners) +
                                          " corners and a PnP fit (found " +
                                          std::to_string(drafts.size()) + ")"));
  }
  s.pnp_rmse_median_px = Median(pnp_rmse);

  // 2. Gravity: up in T is the mean specific force rotated into T.
  Eigen::Vector3d up_T = Eigen::Vector3d::Zero();
  for (const VertexDraft& d : drafts) up_T += d.T_T_I.rotation() * SampleAt(imu, d.t_ns).a_I;
  if (up_T.norm() < 1e-6) {
    throw InputError(FormatInputError(folder + "/imu0.csv", "ax, ay, az",
                                      "a specific force with gravity in it (mean is zero)"));
  }
  up_T.normalize();
  const Eigen::Quaterniond q_T_M = Eigen::Quaterniond::FromTwoVectors(Eigen::Vector3d::UnitZ(), up_T);
  const Transformation T_G_M(q_T_M, Eigen::Vector3d::Zero());
  s.gravity_tilt_deg = std::acos(std::clamp(up_T.z(), -1.0, 1.0)) * 180.0 / M_PI;

  // The map.
  mapstore::VIMap map;
  const uint64_t content_seed = mapstore::SeedFromFileContent(folder + "/imu0.csv") ^ options.seed;
  mapstore::IdGenerator mission_ids(content_seed == 0 ? 1 : content_seed);
  mapstore::Mission mission;
  mission.id = mission_ids.Next();
  mission.name = options.mission_name;
  mission.rig = map_rig;
  mission.baseframe_known = false;
  mission.T_G_M = T_G_M;
  mission.complete = true;
  mapstore::IdGenerator ids = mapstore::IdGenerator::ForMission(mission.id);
  std::vector<mapstore::VertexId> vertex_ids;
  for (std::size_t i = 0; i < drafts.size(); ++i) vertex_ids.push_back(ids.Next());
  mission.root_vertex_id = vertex_ids.front();
  map.AddMission(mission);

  // 3. Vertices.
  const Transformation T_M_G = T_G_M.inverse();
  for (std::size_t i = 0; i < drafts.size(); ++i) {
    const VertexDraft& d = drafts[i];
    mapstore::Vertex v;
    v.id = vertex_ids[i];
    v.mission_id = mission.id;
    v.t_ns = d.t_ns;
    v.T_M_I = T_M_G * d.T_T_I;
    const std::size_t a = i == 0 ? i : i - 1, b = i + 1 == drafts.size() ? i : i + 1;
    const double dt = 1e-9 * static_cast<double>(drafts[b].t_ns - drafts[a].t_ns);
    if (dt > 0 && dt < 0.2) {
      v.v_M = T_M_G.rotation() * (drafts[b].T_T_I.translation() - drafts[a].T_T_I.translation()) / dt;
    }
    v.frames.resize(cameras.size());
    for (std::size_t c = 0; c < cameras.size(); ++c) {
      mapstore::VisualFrame& frame = v.frames[c];
      frame.descriptor_type = "TARGET";
      frame.descriptor_size_bytes = 0;
      if (d.images[c] != nullptr) {
        for (const TargetCorner& corner : d.images[c]->corners) {
          mapstore::Keypoint k;
          k.uv = corner.uv;
          frame.keypoints.push_back(k);
        }
      }
      frame.track_ids.assign(frame.keypoints.size(), -1);
      frame.landmark_ids.assign(frame.keypoints.size(), mapstore::LandmarkId());
    }
    map.AddVertex(std::move(v));
  }

  // 4. Landmarks: one per physical corner, stored in the first vertex that sees it.
  std::map<int64_t, mapstore::LandmarkId> landmark_of;
  for (std::size_t i = 0; i < drafts.size(); ++i) {
    for (std::size_t c = 0; c < cameras.size(); ++c) {
      const TargetImage* image = drafts[i].images[c];
      if (image == nullptr) continue;
      for (std::size_t k = 0; k < image->corners.size(); ++k) {
        const TargetCorner& corner = image->corners[k];
        auto it = landmark_of.find(corner.key());
        if (it == landmark_of.end()) {
          mapstore::Landmark l;
          l.id = ids.Next();
          l.store_vertex_id = vertex_ids[i];
          l.p_I = map.T_G_I(vertex_ids[i]).inverse() * corner.p_T;
          l.quality = mapstore::LandmarkQuality::kGood;
          it = landmark_of.emplace(corner.key(), l.id).first;
          map.AddLandmark(l);
          ++s.landmarks;
        }
        map.AddObservation(it->second, {vertex_ids[i], static_cast<uint32_t>(c),
                                        static_cast<uint32_t>(k)});
        map.vertex(vertex_ids[i]).frames[c].track_ids[k] = corner.key();
        ++s.observations;
      }
    }
  }

  // 5. IMU edges.
  for (std::size_t i = 0; i + 1 < drafts.size(); ++i) {
    const int64_t t_from = drafts[i].t_ns, t_to = drafts[i + 1].t_ns;
    mapstore::Edge edge;
    edge.id = ids.Next();
    edge.type = mapstore::EdgeType::kImu;
    edge.from = vertex_ids[i];
    edge.to = vertex_ids[i + 1];
    edge.imu_samples.push_back(SampleAt(imu, t_from));
    auto it = std::upper_bound(imu.begin(), imu.end(), t_from,
                               [](int64_t t, const ImuSample& sample) { return t < sample.t_ns; });
    for (; it != imu.end() && it->t_ns < t_to; ++it) edge.imu_samples.push_back(*it);
    edge.imu_samples.push_back(SampleAt(imu, t_to));
    map.AddEdge(std::move(edge));
    ++s.imu_edges;
  }
  s.vertices = static_cast<int>(drafts.size());
  return map;
}

std::string TargetPnpComparison::BriefReport() const {
  std::ostringstream out;
  out << std::fixed << frames << " frames against PnP: position RMS " << std::setprecision(2)
      << 1000.0 * position_rms_m << " mm (max " << 1000.0 * position_max_m
      << "), rotation RMS " << std::setprecision(3) << rotation_rms_deg << " deg (max "
      << rotation_max_deg << "); PnP RMSE median " << pnp_rmse_median_px << " px";
  return out.str();
}

TargetPnpComparison CompareWithTargetPnp(const mapstore::VIMap& map,
                                         const mapstore::MissionId& mission, uint32_t camera,
                                         double time_offset_s, int min_corners) {
  const mapstore::Mission& m = map.mission(mission);
  if (camera >= m.rig.cameras.size()) {
    throw std::invalid_argument("camera " + std::to_string(camera) + ": the rig has " +
                                std::to_string(m.rig.cameras.size()) + " cameras");
  }
  const CameraConfig& config = m.rig.cameras[camera];
  // The gyroscope at each vertex (its IMU edges' samples at the vertex times).
  std::unordered_map<mapstore::VertexId, Eigen::Vector3d, mapstore::IdHash> omega_m_I;
  for (const mapstore::EdgeId& eid : map.edge_ids(mission)) {
    const mapstore::Edge& e = map.edge(eid);
    if (e.type != mapstore::EdgeType::kImu || e.imu_samples.empty()) continue;
    omega_m_I.emplace(e.from, e.imu_samples.front().omega_I);
    omega_m_I.emplace(e.to, e.imu_samples.back().omega_I);
  }
  TargetPnpComparison out;
  double sum_p = 0.0, sum_r = 0.0;
  std::vector<double> rmse;
  for (const mapstore::VertexId& vid : map.vertex_ids(mission)) {
    const mapstore::Vertex& v = map.vertex(vid);
    if (camera >= v.frames.size()) continue;
    const mapstore::VisualFrame& frame = v.frames[camera];
    std::vector<Eigen::Vector2d> uv;
    std::vector<Eigen::Vector3d> p_G;
    for (std::size_t k = 0; k < frame.size(); ++k) {
      if (!frame.landmark_ids[k].IsValid()) continue;
      uv.push_back(frame.keypoints[k].uv);
      p_G.push_back(map.LandmarkPosition_G(frame.landmark_ids[k]));
    }
    if (static_cast<int>(uv.size()) < min_corners) continue;
    Transformation T_G_C_pnp;
    double e = 0.0;
    if (!SolveTargetPnp(config.camera, uv, p_G, &T_G_C_pnp, &e)) continue;
    // The vertex pose carried over the time offset (time_offset_residual.h).
    const auto omega = omega_m_I.find(vid);
    const Eigen::Vector3d omega_I =
        omega == omega_m_I.end() ? Eigen::Vector3d::Zero() : Eigen::Vector3d(omega->second - v.gyro_bias);
    const Transformation T_M_I(v.T_M_I.rotation() * ExpSO3(omega_I * time_offset_s),
                               v.T_M_I.translation() + v.v_M * time_offset_s);
    const Transformation T_G_C = m.T_G_M * T_M_I * config.T_I_C;
    const double dp = (T_G_C.translation() - T_G_C_pnp.translation()).norm();
    const double dr = AngleBetween(T_G_C.rotation(), T_G_C_pnp.rotation()) * 180.0 / M_PI;
    sum_p += dp * dp;
    sum_r += dr * dr;
    out.position_max_m = std::max(out.position_max_m, dp);
    out.rotation_max_deg = std::max(out.rotation_max_deg, dr);
    rmse.push_back(e);
    ++out.frames;
  }
  if (out.frames > 0) {
    out.position_rms_m = std::sqrt(sum_p / out.frames);
    out.rotation_rms_deg = std::sqrt(sum_r / out.frames);
  }
  out.pnp_rmse_median_px = Median(rmse);
  return out;
}

}  // namespace vilma::mapping
