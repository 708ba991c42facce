#include "proto_conversion.h"

#include <algorithm>
#include <cmath>
#include <string>

namespace vilma::mapstore::proto {

// ---------------------------------------------------------------- model -> protobuf

namespace {

template <typename Derived>
void AddValues(const Eigen::MatrixBase<Derived>& m, google::protobuf::RepeatedField<double>* out) {
  // Row-major order for matrices (documented in the schema).
  out->Reserve(out->size() + static_cast<int>(m.size()));
  for (int r = 0; r < m.rows(); ++r) {
    for (int c = 0; c < m.cols(); ++c) out->Add(m(r, c));
  }
}

}  // namespace

void ToProto(const Id& id, pb::Id* out) {
  out->set_hi(id.hi);
  out->set_lo(id.lo);
}

void ToProto(const Transformation& T, pb::Pose* out) {
  const Eigen::Quaterniond& q = T.rotation();
  out->set_qw(q.w());
  out->set_qx(q.x());
  out->set_qy(q.y());
  out->set_qz(q.z());
  out->set_px(T.translation().x());
  out->set_py(T.translation().y());
  out->set_pz(T.translation().z());
}

void ToProto(const Mission& m, pb::Mission* out) {
  ToProto(m.id, out->mutable_id());
  out->set_name(m.name);
  out->set_baseframe_known(m.baseframe_known);
  ToProto(m.T_G_M, out->mutable_t_g_m());
  AddValues(m.T_G_M_covariance, out->mutable_t_g_m_covariance());
  if (!m.rig.cameras.empty()) out->set_sensor_rig_yaml(SensorRigToYaml(m.rig));
  for (const CameraConfig& camera : m.rig.cameras) ToProto(camera.T_I_C, out->add_t_i_c());
  ToProto(m.root_vertex_id, out->mutable_root_vertex_id());
  out->set_complete(m.complete);
}

void ToProto(const VisualFrame& f, pb::VisualFrame* out) {
  const std::string problem = f.Validate();
  if (!problem.empty()) throw std::invalid_argument("VisualFrame: " + problem);
  const int n = static_cast<int>(f.keypoints.size());
  out->mutable_keypoints()->Reserve(2 * n);
  out->mutable_scales()->Reserve(n);
  out->mutable_orientations()->Reserve(n);
  out->mutable_scores()->Reserve(n);
  for (const Keypoint& k : f.keypoints) {
    out->add_keypoints(k.uv.x());
    out->add_keypoints(k.uv.y());
    out->add_scales(k.scale);
    out->add_orientations(k.orientation);
    out->add_scores(k.score);
  }
  // Sigmas only when one differs from the default: a frame of default keypoints is written
  // exactly as before the field existed (and costs no bytes).
  const bool default_sigmas = std::all_of(f.keypoints.begin(), f.keypoints.end(), [](const Keypoint& k) {
    return k.sigma_px == kDefaultKeypointSigmaPx;
  });
  if (!default_sigmas) {
    out->mutable_keypoint_sigmas_px()->Reserve(n);
    for (const Keypoint& k : f.keypoints) out->add_keypoint_sigmas_px(k.sigma_px);
  }
  out->set_descriptor_type(f.descriptor_type);
  out->set_descriptor_size_bytes(f.descriptor_size_bytes);
  out->set_descriptors(f.descriptors.data(), f.descriptors.size());
  out->mutable_track_ids()->Add(f.track_ids.begin(), f.track_ids.end());
  out->mutable_landmark_ids()->Reserve(2 * n);
  for (const LandmarkId& id : f.landmark_ids) {
    out->add_landmark_ids(id.hi);
    out->add_landmark_ids(id.lo);
  }
  if (f.image_resource_id.IsValid()) ToProto(f.image_resource_id, out->mutable_image_resource_id());
  if (f.depth_resource_id.IsValid()) ToProto(f.depth_resource_id, out->mutable_depth_resource_id());
}

void ToProto(const Vertex& v, pb::Vertex* out) {
  ToProto(v.id, out->mutable_id());
  ToProto(v.mission_id, out->mutable_mission_id());
  out->set_t_ns(v.t_ns);
  ToProto(v.T_M_I, out->mutable_t_m_i());
  AddValues(v.v_M, out->mutable_v_m());
  AddValues(v.accel_bias, out->mutable_accel_bias());
  AddValues(v.gyro_bias, out->mutable_gyro_bias());
  for (const VisualFrame& f : v.frames) ToProto(f, out->add_frames());
}

pb::EdgeType ToProto(EdgeType type) {
  switch (type) {
    case EdgeType::kImu:
      return pb::EDGE_IMU;
    case EdgeType::kLoopClosure:
      return pb::EDGE_LOOP_CLOSURE;
    case EdgeType::kOdometry:
      return pb::EDGE_ODOMETRY;
    case EdgeType::kPosePrior:
      return pb::EDGE_POSE_PRIOR;
  }
  return pb::EDGE_UNKNOWN;
}

void ToProto(const Edge& e, pb::Edge* out) {
  ToProto(e.id, out->mutable_id());
  out->set_type(ToProto(e.type));
  ToProto(e.from, out->mutable_from());
  ToProto(e.to, out->mutable_to());
  const int n = static_cast<int>(e.imu_samples.size());
  out->mutable_imu_t_ns()->Reserve(n);
  out->mutable_imu_omega_i()->Reserve(3 * n);
  out->mutable_imu_a_i()->Reserve(3 * n);
  for (const ImuSample& s : e.imu_samples) {
    out->add_imu_t_ns(s.t_ns);
    AddValues(s.omega_I, out->mutable_imu_omega_i());
    AddValues(s.a_I, out->mutable_imu_a_i());
  }
  ToProto(e.T_A_B, out->mutable_t_a_b());
  AddValues(e.covariance, out->mutable_covariance());
  out->set_switch_variable(e.switch_variable);
  out->set_switch_variable_variance(e.switch_variable_variance);
}

void ToProto(const Landmark& l, pb::Landmark* out) {
  ToProto(l.id, out->mutable_id());
  ToProto(l.store_vertex_id, out->mutable_store_vertex_id());
  AddValues(l.p_I, out->mutable_p_i());
  AddValues(l.covariance, out->mutable_covariance());
  out->set_quality(static_cast<pb::LandmarkQuality>(static_cast<int>(l.quality)));
  for (const LandmarkObservation& o : l.observations) {
    out->add_observation_vertex_ids(o.vertex_id.hi);
    out->add_observation_vertex_ids(o.vertex_id.lo);
    out->add_observation_cameras(o.camera);
    out->add_observation_keypoints(o.keypoint);
  }
}

// ---------------------------------------------------------------- protobuf -> model
// Every reader names the file and the field path of what it rejects.

Mission FromProto(const pb::Mission& p, const Reader& in, const std::string& field) {
  Mission m;
  m.id = in.ReadId(p.id());
  if (!m.id.IsValid()) in.Fail(field + ".id", "expected a valid (non-zero) id");
  m.name = p.name();
  m.baseframe_known = p.baseframe_known();
  m.T_G_M = in.ReadPose(p.t_g_m(), field + ".T_G_M");
  m.T_G_M_covariance = in.ReadMatrix<6, 6>(p.t_g_m_covariance(), field + ".T_G_M_covariance");
  if (!p.sensor_rig_yaml().empty()) {
    m.rig = ParseSensorRig(p.sensor_rig_yaml(), in.file() + ": " + field + ".sensor_rig_yaml");
  }
  if (static_cast<std::size_t>(p.t_i_c_size()) != m.rig.cameras.size()) {
    in.Fail(field + ".T_I_C", "expected one pose per rig camera (" +
                                  std::to_string(m.rig.cameras.size()) + "), found " +
                                  std::to_string(p.t_i_c_size()));
  }
  for (int c = 0; c < p.t_i_c_size(); ++c) {
    m.rig.cameras[c].T_I_C = in.ReadPose(p.t_i_c(c), field + ".T_I_C[" + std::to_string(c) + "]");
  }
  m.root_vertex_id = in.ReadId(p.root_vertex_id());
  m.complete = p.complete();
  return m;
}

VisualFrame FromProto(const pb::VisualFrame& p, const Reader& in, const std::string& field) {
  VisualFrame f;
  const int n = p.scales_size();
  auto expect_size = [&](int size, int expected, const std::string& name) {
    if (size != expected) {
      in.Fail(field + "." + name, "expected " + std::to_string(expected) +
                                      " values (one per keypoint), found " + std::to_string(size));
    }
  };
  expect_size(p.keypoints_size(), 2 * n, "keypoints");
  expect_size(p.orientations_size(), n, "orientations");
  expect_size(p.scores_size(), n, "scores");
  expect_size(p.track_ids_size(), n, "track_ids");
  expect_size(p.landmark_ids_size(), 2 * n, "landmark_ids");
  // Optional (added later): absent in older maps, whose keypoints get the default sigma.
  const bool has_sigmas = p.keypoint_sigmas_px_size() > 0;
  if (has_sigmas) expect_size(p.keypoint_sigmas_px_size(), n, "keypoint_sigmas_px");
  f.descriptor_type = p.descriptor_type();
  f.descriptor_size_bytes = p.descriptor_size_bytes();
  if (p.descriptors().size() != static_cast<std::size_t>(n) * f.descriptor_size_bytes) {
    in.Fail(field + ".descriptors",
            "expected " + std::to_string(static_cast<std::size_t>(n) * f.descriptor_size_bytes) +
                " bytes (keypoints x descriptor_size_bytes), found " +
                std::to_string(p.descriptors().size()));
  }
  f.keypoints.resize(n);
  for (int i = 0; i < n; ++i) {
    Keypoint& k = f.keypoints[i];
    k.uv = Eigen::Vector2d(p.keypoints(2 * i), p.keypoints(2 * i + 1));
    k.scale = p.scales(i);
    k.orientation = p.orientations(i);
    k.score = p.scores(i);
    if (has_sigmas) {
      k.sigma_px = p.keypoint_sigmas_px(i);
      if (!(std::isfinite(k.sigma_px) && k.sigma_px > 0.0)) {
        in.Fail(field + ".keypoint_sigmas_px[" + std::to_string(i) + "]",
                "expected a finite value > 0, found " + std::to_string(k.sigma_px));
      }
    }
  }
  f.descriptors.assign(p.descriptors().begin(), p.descriptors().end());
  f.track_ids.assign(p.track_ids().begin(), p.track_ids().end());
  f.landmark_ids.resize(n);
  for (int i = 0; i < n; ++i) {
    f.landmark_ids[i].hi = p.landmark_ids(2 * i);
    f.landmark_ids[i].lo = p.landmark_ids(2 * i + 1);
  }
  f.image_resource_id = in.ReadId(p.image_resource_id());
  f.depth_resource_id = in.ReadId(p.depth_resource_id());
  return f;
}

Vertex FromProto(const pb::Vertex& p, const Reader& in, const std::string& field) {
  Vertex v;
  v.id = in.ReadId(p.id());
  if (!v.id.IsValid()) in.Fail(field + ".id", "expected a valid (non-zero) id");
  v.mission_id = in.ReadId(p.mission_id());
  v.t_ns = p.t_ns();
  v.T_M_I = in.ReadPose(p.t_m_i(), field + ".T_M_I");
  v.v_M = in.ReadMatrix<3, 1>(p.v_m(), field + ".v_M");
  v.accel_bias = in.ReadMatrix<3, 1>(p.accel_bias(), field + ".accel_bias");
  v.gyro_bias = in.ReadMatrix<3, 1>(p.gyro_bias(), field + ".gyro_bias");
  v.frames.reserve(p.frames_size());
  for (int c = 0; c < p.frames_size(); ++c) {
    v.frames.push_back(FromProto(p.frames(c), in, field + ".frames[" + std::to_string(c) + "]"));
  }
  return v;
}

Edge FromProto(const pb::Edge& p, const Reader& in, const std::string& field) {
  Edge e;
  e.id = in.ReadId(p.id());
  if (!e.id.IsValid()) in.Fail(field + ".id", "expected a valid (non-zero) id");
  switch (p.type()) {
    case pb::EDGE_IMU:
      e.type = EdgeType::kImu;
      break;
    case pb::EDGE_LOOP_CLOSURE:
      e.type = EdgeType::kLoopClosure;
      break;
    case pb::EDGE_ODOMETRY:
      e.type = EdgeType::kOdometry;
      break;
    case pb::EDGE_POSE_PRIOR:
      e.type = EdgeType::kPosePrior;
      break;
    default:
      in.Fail(field + ".type", "expected imu, loop_closure, odometry or pose_prior, found " +
                                   std::to_string(static_cast<int>(p.type())));
  }
  e.from = in.ReadId(p.from());
  e.to = in.ReadId(p.to());
  const int n = p.imu_t_ns_size();
  if (p.imu_omega_i_size() != 3 * n || p.imu_a_i_size() != 3 * n) {
    in.Fail(field + ".imu_omega_I", "expected 3 values per IMU sample (" + std::to_string(n) +
                                        " samples) in imu_omega_I and imu_a_I");
  }
  e.imu_samples.resize(n);
  for (int i = 0; i < n; ++i) {
    ImuSample& s = e.imu_samples[i];
    s.t_ns = p.imu_t_ns(i);
    s.omega_I =
        Eigen::Vector3d(p.imu_omega_i(3 * i), p.imu_omega_i(3 * i + 1), p.imu_omega_i(3 * i + 2));
    s.a_I = Eigen::Vector3d(p.imu_a_i(3 * i), p.imu_a_i(3 * i + 1), p.imu_a_i(3 * i + 2));
  }
  e.T_A_B = in.ReadPose(p.t_a_b(), field + ".T_A_B");
  e.covariance = in.ReadMatrix<6, 6>(p.covariance(), field + ".covariance");
  e.switch_variable = p.switch_variable();
  e.switch_variable_variance = p.switch_variable_variance();
  return e;
}

Landmark FromProto(const pb::Landmark& p, const Reader& in, const std::string& field) {
  Landmark l;
  l.id = in.ReadId(p.id());
  if (!l.id.IsValid()) in.Fail(field + ".id", "expected a valid (non-zero) id");
  l.store_vertex_id = in.ReadId(p.store_vertex_id());
  l.p_I = in.ReadMatrix<3, 1>(p.p_i(), field + ".p_I");
  l.covariance = in.ReadMatrix<3, 3>(p.covariance(), field + ".covariance");
  switch (p.quality()) {
    case pb::QUALITY_UNKNOWN:
      l.quality = LandmarkQuality::kUnknown;
      break;
    case pb::QUALITY_BAD:
      l.quality = LandmarkQuality::kBad;
      break;
    case pb::QUALITY_GOOD:
      l.quality = LandmarkQuality::kGood;
      break;
    default:
      in.Fail(field + ".quality", "expected unknown, bad or good, found " +
                                      std::to_string(static_cast<int>(p.quality())));
  }
  const int n = p.observation_cameras_size();
  if (p.observation_keypoints_size() != n || p.observation_vertex_ids_size() != 2 * n) {
    in.Fail(field + ".observation_keypoints",
            "expected one vertex id, camera and keypoint per observation");
  }
  l.observations.resize(n);
  for (int i = 0; i < n; ++i) {
    l.observations[i].vertex_id.hi = p.observation_vertex_ids(2 * i);
    l.observations[i].vertex_id.lo = p.observation_vertex_ids(2 * i + 1);
    l.observations[i].camera = p.observation_cameras(i);
    l.observations[i].keypoint = p.observation_keypoints(i);
  }
  return l;
}

}  // namespace vilma::mapstore::proto
