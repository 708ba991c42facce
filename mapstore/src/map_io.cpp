#include "vilma/mapstore/map_io.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <sstream>
#include <stdexcept>

#include "file_util.h"
#include "vi_map.pb.h"
#include "vilma/core/asl_dataset.h"
#include "vilma/core/error.h"
#include "vilma/core/yaml_io.h"
#include "vilma/mapstore/checksum.h"

namespace fs = std::filesystem;

namespace vilma {
namespace mapstore {
namespace {

constexpr char kManifestName[] = "manifest.yaml";
constexpr char kFormatName[] = "vilma-vi-map";

// ---------------------------------------------------------------- model -> protobuf

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

template <typename Derived>
void AddValues(const Eigen::MatrixBase<Derived>& m, google::protobuf::RepeatedField<double>* out) {
  // Row-major order for matrices (documented in the schema).
  out->Reserve(out->size() + static_cast<int>(m.size()));
  for (int r = 0; r < m.rows(); ++r) {
    for (int c = 0; c < m.cols(); ++c) out->Add(m(r, c));
  }
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
    case EdgeType::kImu: return pb::EDGE_IMU;
    case EdgeType::kLoopClosure: return pb::EDGE_LOOP_CLOSURE;
    case EdgeType::kOdometry: return pb::EDGE_ODOMETRY;
    case EdgeType::kPosePrior: return pb::EDGE_POSE_PRIOR;
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

class Reader {
 public:
  explicit Reader(std::string file) : file_(std::move(file)) {}
  [[noreturn]] void Fail(const std::string& field, const std::string& expectation) const {
    throw InputError(FormatInputError(file_, field, expectation));
  }
  const std::string& file() const { return file_; }

  Id ReadId(const pb::Id& id) const {
    Id out;
    out.hi = id.hi();
    out.lo = id.lo();
    return out;
  }

  Transformation ReadPose(const pb::Pose& p, const std::string& field) const {
    const Eigen::Quaterniond q(p.qw(), p.qx(), p.qy(), p.qz());
    const Eigen::Vector3d t(p.px(), p.py(), p.pz());
    if (!q.coeffs().allFinite() || !t.allFinite()) Fail(field, "expected finite values");
    if (std::abs(q.squaredNorm() - 1.0) > 1e-9) {
      Fail(field, "expected a unit quaternion (w, x, y, z), found norm " +
                      std::to_string(q.norm()));
    }
    // Stored quaternions were normalized when created: keep their bits (bit-exact round trip).
    return Transformation::FromUnitQuaternion(q, t);
  }

  template <int R, int C>
  Eigen::Matrix<double, R, C> ReadMatrix(const google::protobuf::RepeatedField<double>& values,
                                         const std::string& field) const {
    if (values.size() != R * C) {
      Fail(field, "expected " + std::to_string(R * C) + " values, found " +
                      std::to_string(values.size()));
    }
    Eigen::Matrix<double, R, C> m;
    for (int r = 0; r < R; ++r) {
      for (int c = 0; c < C; ++c) m(r, c) = values.Get(r * C + c);
    }
    return m;
  }

 private:
  std::string file_;
};

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
  }
  f.descriptors.assign(p.descriptors().begin(), p.descriptors().end());
  f.track_ids.assign(p.track_ids().begin(), p.track_ids().end());
  f.landmark_ids.resize(n);
  for (int i = 0; i < n; ++i) {
    f.landmark_ids[i].hi = p.landmark_ids(2 * i);
    f.landmark_ids[i].lo = p.landmark_ids(2 * i + 1);
  }
  f.image_resource_id = in.ReadId(p.image_resource_id());
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
    case pb::EDGE_IMU: e.type = EdgeType::kImu; break;
    case pb::EDGE_LOOP_CLOSURE: e.type = EdgeType::kLoopClosure; break;
    case pb::EDGE_ODOMETRY: e.type = EdgeType::kOdometry; break;
    case pb::EDGE_POSE_PRIOR: e.type = EdgeType::kPosePrior; break;
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
    s.omega_I = Eigen::Vector3d(p.imu_omega_i(3 * i), p.imu_omega_i(3 * i + 1),
                                p.imu_omega_i(3 * i + 2));
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
    case pb::QUALITY_UNKNOWN: l.quality = LandmarkQuality::kUnknown; break;
    case pb::QUALITY_BAD: l.quality = LandmarkQuality::kBad; break;
    case pb::QUALITY_GOOD: l.quality = LandmarkQuality::kGood; break;
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

// ---------------------------------------------------------------- manifest

struct FileEntry {
  std::string path;  // relative to the map folder
  uint64_t size = 0;
  uint32_t crc32 = 0;
};

struct MissionManifest {
  MissionId id;
  FileEntry mission_file;
  std::vector<FileEntry> vertex_chunks, edge_chunks, landmark_chunks;
};

struct Manifest {
  uint32_t format_version = kMapFormatVersion;
  uint64_t generation = 0;
  std::vector<MissionManifest> missions;
  std::vector<ResourceInfo> resources;
};

std::string FileEntryYaml(const FileEntry& f) {
  return "{path: " + f.path + ", size: " + std::to_string(f.size) + ", crc32: \"" +
         Crc32Hex(f.crc32) + "\"}";
}

std::string ManifestToYaml(const Manifest& m) {
  std::ostringstream out;
  out << "# vilma VI-map manifest (docs/vi-map.md). Written last by every save.\n";
  out << "format: " << kFormatName << "\n";
  out << "format_version: " << m.format_version << "\n";
  out << "generation: " << m.generation << "\n";
  out << "missions:" << (m.missions.empty() ? " []" : "") << "\n";
  auto list = [&](const char* key, const std::vector<FileEntry>& files) {
    out << "    " << key << ":" << (files.empty() ? " []" : "") << "\n";
    for (const FileEntry& f : files) out << "      - " << FileEntryYaml(f) << "\n";
  };
  for (const MissionManifest& mm : m.missions) {
    out << "  - id: \"" << mm.id.Hex() << "\"\n";
    out << "    mission_file: " << FileEntryYaml(mm.mission_file) << "\n";
    list("vertex_chunks", mm.vertex_chunks);
    list("edge_chunks", mm.edge_chunks);
    list("landmark_chunks", mm.landmark_chunks);
  }
  out << "resources:" << (m.resources.empty() ? " []" : "") << "\n";
  for (const ResourceInfo& r : m.resources) {
    out << "  - {type: " << ResourceTypeName(r.type) << ", id: \"" << r.id.Hex()
        << "\", extension: " << r.extension << ", size: " << r.size_bytes << ", crc32: \""
        << Crc32Hex(r.crc32) << "\"}\n";
  }
  return out.str();
}

uint32_t ParseCrcHex(const YamlNode& node, const std::string& key) {
  const std::string s = node.Get<std::string>(key);
  if (s.size() != 10 || s.compare(0, 2, "0x") != 0 ||
      s.find_first_not_of("0123456789abcdef", 2) != std::string::npos) {
    node.Fail(key, "expected \"0x\" and 8 lowercase hex digits, found \"" + s + "\"");
  }
  return static_cast<uint32_t>(std::stoul(s.substr(2), nullptr, 16));
}

uint64_t ParseSize(const YamlNode& node, const std::string& key) {
  const int64_t size = node.Get<int64_t>(key);
  if (size < 0) node.Fail(key, "expected a size >= 0");
  return static_cast<uint64_t>(size);
}

Id ParseIdHex(const YamlNode& node, const std::string& key) {
  Id id;
  const std::string s = node.Get<std::string>(key);
  if (!Id::FromHex(s, &id) || !id.IsValid()) {
    node.Fail(key, "expected a non-zero id of 32 hex digits, found \"" + s + "\"");
  }
  return id;
}

FileEntry ParseFileEntry(const YamlNode& node) {
  FileEntry f;
  f.path = node.Get<std::string>("path");
  // Relative paths inside the map folder only.
  if (f.path.empty() || f.path[0] == '/' || f.path.find("..") != std::string::npos) {
    node.Fail("path", "expected a relative path inside the map folder, found \"" + f.path + "\"");
  }
  f.size = ParseSize(node, "size");
  f.crc32 = ParseCrcHex(node, "crc32");
  node.CheckNoUnknownKeys();
  return f;
}

Manifest ParseManifest(const std::string& path) {
  const YamlNode root = YamlNode::LoadFile(path);
  if (!root.IsMap()) root.Fail("", "expected a YAML map (a vilma map manifest)");
  const std::string format = root.Get<std::string>("format");
  if (format != kFormatName) {
    root.Fail("format", std::string("expected \"") + kFormatName + "\", found \"" + format + "\"");
  }
  Manifest m;
  const int64_t version = root.Get<int64_t>("format_version");
  // The version is checked before anything else so that a newer map gives this message and
  // not a confusing one about a field this reader does not know.
  if (version > static_cast<int64_t>(kMapFormatVersion)) {
    root.Fail("format_version",
              "expected a version from 1 to " + std::to_string(kMapFormatVersion) +
                  " (the newest this vilma reads), found " + std::to_string(version) +
                  ": the map was written by a newer vilma; update vilma to load it");
  }
  if (version < 1) {
    root.Fail("format_version", "expected a version from 1 to " +
                                    std::to_string(kMapFormatVersion) + ", found " +
                                    std::to_string(version));
  }
  m.format_version = static_cast<uint32_t>(version);
  const int64_t generation = root.Get<int64_t>("generation");
  if (generation < 1) root.Fail("generation", "expected a generation >= 1");
  m.generation = static_cast<uint64_t>(generation);
  for (const YamlNode& mn : root.Child("missions").Elements()) {
    MissionManifest mm;
    mm.id = ParseIdHex(mn, "id");
    mm.mission_file = ParseFileEntry(mn.Child("mission_file"));
    for (const YamlNode& f : mn.Child("vertex_chunks").Elements()) {
      mm.vertex_chunks.push_back(ParseFileEntry(f));
    }
    for (const YamlNode& f : mn.Child("edge_chunks").Elements()) {
      mm.edge_chunks.push_back(ParseFileEntry(f));
    }
    for (const YamlNode& f : mn.Child("landmark_chunks").Elements()) {
      mm.landmark_chunks.push_back(ParseFileEntry(f));
    }
    mn.CheckNoUnknownKeys();
    m.missions.push_back(std::move(mm));
  }
  for (const YamlNode& rn : root.Child("resources").Elements()) {
    ResourceInfo r;
    const std::string type = rn.Get<std::string>("type");
    if (!ParseResourceType(type, &r.type)) {
      rn.Fail("type", "expected image, depth_map, point_cloud or mesh, found \"" + type + "\"");
    }
    r.id = ParseIdHex(rn, "id");
    r.extension = rn.Get<std::string>("extension");
    if (r.extension.empty() || r.extension.find_first_of("/.") != std::string::npos) {
      rn.Fail("extension", "expected a plain file suffix such as png");
    }
    r.size_bytes = ParseSize(rn, "size");
    r.crc32 = ParseCrcHex(rn, "crc32");
    rn.CheckNoUnknownKeys();
    m.resources.push_back(r);
  }
  root.CheckNoUnknownKeys();
  return m;
}

// ---------------------------------------------------------------- saving

std::string GenerationDirName(uint64_t generation) {
  char buf[32];
  std::snprintf(buf, sizeof(buf), "g%06llu", static_cast<unsigned long long>(generation));
  return buf;
}

std::string ChunkName(const char* kind, std::size_t index) {
  char buf[64];
  std::snprintf(buf, sizeof(buf), "%s_%06zu.pb", kind, index);
  return buf;
}

class Writer {
 public:
  Writer(std::string folder, MapSaveSummary* summary)
      : folder_(std::move(folder)), summary_(summary) {}

  FileEntry Write(const std::string& relative_path, const google::protobuf::Message& message) {
    std::string bytes;
    if (!message.SerializeToString(&bytes)) {
      throw std::invalid_argument("SaveMap: cannot serialize " + relative_path);
    }
    return WriteBytes(relative_path, bytes);
  }

  FileEntry WriteBytes(const std::string& relative_path, const std::string& bytes) {
    FileEntry f;
    f.path = relative_path;
    f.size = bytes.size();
    f.crc32 = Crc32(bytes);
    WriteFileAtomically((fs::path(folder_) / relative_path).string(), bytes);
    ++summary_->files_written;
    summary_->bytes_written += bytes.size();
    return f;
  }

 private:
  std::string folder_;
  MapSaveSummary* summary_;
};

template <typename Chunk, typename Element, typename Fill>
std::vector<FileEntry> WriteChunks(Writer* writer, const std::string& dir, const char* kind,
                                   const MissionId& mission_id,
                                   const std::vector<Element>& ids, uint32_t per_chunk,
                                   Fill fill) {
  std::vector<FileEntry> files;
  for (std::size_t begin = 0, index = 0; begin < ids.size(); begin += per_chunk, ++index) {
    Chunk chunk;
    chunk.set_format_version(kMapFormatVersion);
    ToProto(mission_id, chunk.mutable_mission_id());
    chunk.set_chunk_index(static_cast<uint32_t>(index));
    const std::size_t end = std::min<std::size_t>(ids.size(), begin + per_chunk);
    for (std::size_t i = begin; i < end; ++i) fill(ids[i], &chunk);
    files.push_back(writer->Write(dir + "/" + ChunkName(kind, index), chunk));
  }
  return files;
}

void CreateDirectories(const fs::path& dir) {
  std::error_code ec;
  fs::create_directories(dir, ec);
  if (ec) throw InputError(FormatInputError(dir.string(), "", "expected a writable folder (" + ec.message() + ")"));
}

// ---------------------------------------------------------------- loading

// Reads a data file listed in the manifest and checks its size and checksum.
std::string ReadListedFile(const std::string& folder, const FileEntry& entry,
                           const std::string& manifest_path, bool verify_checksum) {
  const std::string path = (fs::path(folder) / entry.path).string();
  std::string bytes;
  if (!ReadWholeFile(path, &bytes)) {
    throw InputError(FormatInputError(
        path, "", "expected the data file listed in " + manifest_path + " (missing chunk)"));
  }
  if (bytes.size() != entry.size) {
    throw InputError(FormatInputError(
        path, "size",
        "expected " + std::to_string(entry.size) + " bytes as listed in " + manifest_path +
            ", found " + std::to_string(bytes.size()) +
            (bytes.size() < entry.size ? " (truncated file)" : " (file grew)")));
  }
  if (verify_checksum) {
    const uint32_t crc = Crc32(bytes);
    if (crc != entry.crc32) {
      throw InputError(FormatInputError(
          path, "crc32",
          "expected " + Crc32Hex(entry.crc32) + " as listed in " + manifest_path +
              ", computed " + Crc32Hex(crc) + " (checksum mismatch: corrupted file)"));
    }
  }
  return bytes;
}

template <typename Message>
Message ParseListed(const std::string& bytes, const Reader& in, const char* type_name,
                    const MissionId& mission_id) {
  Message message;
  if (!message.ParseFromString(bytes)) {
    in.Fail("", std::string("expected a valid ") + type_name + " protobuf message");
  }
  if (message.format_version() != kMapFormatVersion) {
    in.Fail("format_version", "expected " + std::to_string(kMapFormatVersion) +
                                  " (the manifest's), found " +
                                  std::to_string(message.format_version()));
  }
  (void)mission_id;
  return message;
}

template <typename Fn>
void AddOrFail(const Reader& in, const std::string& field, Fn fn) {
  try {
    fn();
  } catch (const std::invalid_argument& e) {
    // VIMap rejects duplicate ids and dangling store vertices with invalid_argument.
    in.Fail(field, std::string("expected a consistent element: ") + e.what());
  }
}

}  // namespace

std::string MapSaveOptions::Validate() const {
  if (vertices_per_chunk == 0) return "vertices_per_chunk: expected > 0";
  if (edges_per_chunk == 0) return "edges_per_chunk: expected > 0";
  if (landmarks_per_chunk == 0) return "landmarks_per_chunk: expected > 0";
  return "";
}

std::string MapLoadOptions::Validate() const {
  const std::string problem = resource_cache.Validate();
  return problem.empty() ? "" : "resource_cache." + problem;
}

MapSaveSummary SaveMap(const VIMap& map, const std::string& folder,
                       const MapSaveOptions& options) {
  const std::string problem = options.Validate();
  if (!problem.empty()) throw std::invalid_argument("MapSaveOptions: " + problem);
  const fs::path root(folder);
  CreateDirectories(root);
  const std::string manifest_path = (root / kManifestName).string();

  // The new generation follows the one the current manifest lists; a generation folder left
  // by a crashed save (not listed) is cleared and reused.
  Manifest manifest;
  manifest.generation = 1;
  if (fs::exists(manifest_path)) {
    try {
      manifest.generation = ParseManifest(manifest_path).generation + 1;
    } catch (const InputError&) {
      // Unreadable previous manifest: nothing of it can be kept safe anyway; pick a
      // generation above every folder present.
      std::error_code ec;
      for (const auto& mission_dir : fs::directory_iterator(root / "missions", ec)) {
        for (const auto& gen : fs::directory_iterator(mission_dir.path(), ec)) {
          const std::string name = gen.path().filename().string();
          if (name.size() == 7 && name[0] == 'g' &&
              name.find_first_not_of("0123456789", 1) == std::string::npos) {
            manifest.generation =
                std::max<uint64_t>(manifest.generation, std::stoull(name.substr(1)) + 1);
          }
        }
      }
    }
  }

  MapSaveSummary summary;
  summary.generation = manifest.generation;
  Writer writer(folder, &summary);
  const std::string generation_dir = GenerationDirName(manifest.generation);

  for (const MissionId& mission_id : map.mission_ids()) {
    MissionManifest mm;
    mm.id = mission_id;
    const std::string dir = "missions/" + mission_id.Hex() + "/" + generation_dir;
    std::error_code ec;
    fs::remove_all(root / dir, ec);
    CreateDirectories(root / dir);

    pb::MissionFile mission_file;
    mission_file.set_format_version(kMapFormatVersion);
    ToProto(map.mission(mission_id), mission_file.mutable_mission());
    mm.mission_file = writer.Write(dir + "/mission.pb", mission_file);

    mm.vertex_chunks = WriteChunks<pb::VertexChunk>(
        &writer, dir, "vertices", mission_id, map.vertex_ids(mission_id),
        options.vertices_per_chunk, [&](const VertexId& id, pb::VertexChunk* chunk) {
          ToProto(map.vertex(id), chunk->add_vertices());
        });
    mm.edge_chunks = WriteChunks<pb::EdgeChunk>(
        &writer, dir, "edges", mission_id, map.edge_ids(mission_id), options.edges_per_chunk,
        [&](const EdgeId& id, pb::EdgeChunk* chunk) { ToProto(map.edge(id), chunk->add_edges()); });
    mm.landmark_chunks = WriteChunks<pb::LandmarkChunk>(
        &writer, dir, "landmarks", mission_id, map.landmark_ids(mission_id),
        options.landmarks_per_chunk, [&](const LandmarkId& id, pb::LandmarkChunk* chunk) {
          ToProto(map.landmark(id), chunk->add_landmarks());
        });
    manifest.missions.push_back(std::move(mm));
  }

  // Resources are immutable per id and written in place (atomically): a resource that is
  // already in this folder and not pending is not rewritten.
  const ResourceStore& resources = map.resources();
  const bool same_folder =
      !resources.folder().empty() && fs::exists(resources.folder()) &&
      fs::equivalent(fs::path(resources.folder()), root);
  for (const ResourceInfo& info : resources.List()) {
    const fs::path target = root / info.RelativePath();
    std::shared_ptr<const std::string> bytes;
    if (same_folder && fs::exists(target)) {
      // Pending (replaced) resources must still be written; others are already here.
      bytes = resources.Load(info.type, info.id);
      if (fs::file_size(target) == bytes->size()) {
        std::string on_disk;
        if (ReadWholeFile(target.string(), &on_disk) && on_disk == *bytes) {
          manifest.resources.push_back(info);
          continue;
        }
      }
    } else {
      bytes = resources.Load(info.type, info.id);
    }
    CreateDirectories(target.parent_path());
    writer.WriteBytes(info.RelativePath(), *bytes);
    manifest.resources.push_back(info);
  }

  if (options.stop_before_manifest) return summary;
  // The commit point: the manifest's atomic rename switches readers to the new generation.
  WriteFileAtomically(manifest_path, ManifestToYaml(manifest));
  ++summary.files_written;

  // Cleanup of what the new manifest no longer lists: older generations and removed missions.
  std::error_code ec;
  for (const auto& mission_dir : fs::directory_iterator(root / "missions", ec)) {
    Id id;
    const bool listed =
        Id::FromHex(mission_dir.path().filename().string(), &id) && map.HasMission(id);
    if (!listed) {
      fs::remove_all(mission_dir.path(), ec);
      continue;
    }
    for (const auto& gen : fs::directory_iterator(mission_dir.path(), ec)) {
      if (gen.path().filename().string() != generation_dir) fs::remove_all(gen.path(), ec);
    }
  }
  return summary;
}

VIMap LoadMap(const std::string& folder, const MapLoadOptions& options) {
  const std::string problem = options.Validate();
  if (!problem.empty()) throw std::invalid_argument("MapLoadOptions: " + problem);
  const fs::path root(folder);
  const std::string manifest_path = (root / kManifestName).string();
  if (!fs::is_directory(root)) {
    throw InputError(FormatInputError(folder, "", "expected a map folder"));
  }
  if (!fs::exists(manifest_path)) {
    throw InputError(FormatInputError(manifest_path, "",
                                      "expected a map manifest (is this a vilma map folder?)"));
  }
  const Manifest manifest = ParseManifest(manifest_path);

  VIMap map;
  map.resources().SetCacheOptions(options.resource_cache);
  // Pass 1: missions and vertices of every mission (edges and landmarks may refer to vertices
  // of other missions). Pass 2: edges. Pass 3: landmarks.
  for (const MissionManifest& mm : manifest.missions) {
    const std::string path = (root / mm.mission_file.path).string();
    const Reader in(path);
    const auto file = ParseListed<pb::MissionFile>(
        ReadListedFile(folder, mm.mission_file, manifest_path, options.verify_checksums), in,
        "MissionFile", mm.id);
    Mission mission = FromProto(file.mission(), in, "mission");
    if (mission.id != mm.id) {
      in.Fail("mission.id", "expected " + mm.id.Hex() + " (the manifest's), found " +
                                mission.id.Hex());
    }
    AddOrFail(in, "mission.id", [&] { map.AddMission(mission); });
  }
  auto for_each_chunk = [&](auto chunk_tag, const char* type_name,
                            const std::vector<FileEntry> MissionManifest::*files, auto handle) {
    using Chunk = decltype(chunk_tag);
    for (const MissionManifest& mm : manifest.missions) {
      const std::vector<FileEntry>& list = mm.*files;
      for (std::size_t index = 0; index < list.size(); ++index) {
        const Reader in((root / list[index].path).string());
        const Chunk chunk = ParseListed<Chunk>(
            ReadListedFile(folder, list[index], manifest_path, options.verify_checksums), in,
            type_name, mm.id);
        if (in.ReadId(chunk.mission_id()) != mm.id || chunk.chunk_index() != index) {
          in.Fail("chunk_index", "expected chunk " + std::to_string(index) + " of mission " +
                                     mm.id.Hex() + ", found chunk " +
                                     std::to_string(chunk.chunk_index()) + " of mission " +
                                     in.ReadId(chunk.mission_id()).Hex());
        }
        handle(chunk, in, mm.id);
      }
    }
  };
  for_each_chunk(pb::VertexChunk(), "VertexChunk", &MissionManifest::vertex_chunks,
                 [&](const pb::VertexChunk& chunk, const Reader& in, const MissionId& mission_id) {
                   for (int i = 0; i < chunk.vertices_size(); ++i) {
                     const std::string field = "vertices[" + std::to_string(i) + "]";
                     Vertex v = FromProto(chunk.vertices(i), in, field);
                     if (v.mission_id != mission_id) {
                       in.Fail(field + ".mission_id", "expected " + mission_id.Hex() +
                                                          ", found " + v.mission_id.Hex());
                     }
                     AddOrFail(in, field + ".id", [&] { map.AddVertex(std::move(v)); });
                   }
                 });
  for_each_chunk(pb::EdgeChunk(), "EdgeChunk", &MissionManifest::edge_chunks,
                 [&](const pb::EdgeChunk& chunk, const Reader& in, const MissionId&) {
                   for (int i = 0; i < chunk.edges_size(); ++i) {
                     const std::string field = "edges[" + std::to_string(i) + "]";
                     Edge e = FromProto(chunk.edges(i), in, field);
                     AddOrFail(in, field, [&] { map.AddEdge(std::move(e)); });
                   }
                 });
  for_each_chunk(pb::LandmarkChunk(), "LandmarkChunk", &MissionManifest::landmark_chunks,
                 [&](const pb::LandmarkChunk& chunk, const Reader& in, const MissionId&) {
                   for (int i = 0; i < chunk.landmarks_size(); ++i) {
                     const std::string field = "landmarks[" + std::to_string(i) + "]";
                     Landmark l = FromProto(chunk.landmarks(i), in, field);
                     AddOrFail(in, field, [&] { map.AddLandmark(std::move(l)); });
                   }
                 });

  for (const ResourceInfo& info : manifest.resources) map.resources().Register(info);
  map.resources().set_folder(folder);
  return map;
}

// ---------------------------------------------------------------- mission stream

std::string SerializeMissionDelta(const MissionDelta& delta) {
  pb::MissionDelta message;
  message.set_format_version(kMapFormatVersion);
  ToProto(delta.mission, message.mutable_mission());
  for (const Vertex& v : delta.vertices) ToProto(v, message.add_vertices());
  for (const Edge& e : delta.edges) ToProto(e, message.add_edges());
  for (const Landmark& l : delta.landmarks) ToProto(l, message.add_landmarks());
  std::string bytes;
  if (!message.SerializeToString(&bytes)) {
    throw std::invalid_argument("SerializeMissionDelta: cannot serialize");
  }
  return bytes;
}

MissionDelta ParseMissionDelta(const std::string& bytes, const std::string& source_name) {
  const Reader in(source_name);
  pb::MissionDelta message;
  if (!message.ParseFromString(bytes)) in.Fail("", "expected a valid MissionDelta protobuf message");
  if (message.format_version() < 1 || message.format_version() > kMapFormatVersion) {
    in.Fail("format_version", "expected a version from 1 to " +
                                  std::to_string(kMapFormatVersion) + ", found " +
                                  std::to_string(message.format_version()));
  }
  MissionDelta delta;
  delta.mission = FromProto(message.mission(), in, "mission");
  for (int i = 0; i < message.vertices_size(); ++i) {
    delta.vertices.push_back(FromProto(message.vertices(i), in, "vertices[" + std::to_string(i) + "]"));
  }
  for (int i = 0; i < message.edges_size(); ++i) {
    delta.edges.push_back(FromProto(message.edges(i), in, "edges[" + std::to_string(i) + "]"));
  }
  for (int i = 0; i < message.landmarks_size(); ++i) {
    delta.landmarks.push_back(
        FromProto(message.landmarks(i), in, "landmarks[" + std::to_string(i) + "]"));
  }
  return delta;
}

void ApplyMissionDelta(const MissionDelta& delta, VIMap* map) {
  map->UpsertMission(delta.mission);
  for (const Vertex& v : delta.vertices) map->UpsertVertex(v);
  for (const Edge& e : delta.edges) map->UpsertEdge(e);
  for (const Landmark& l : delta.landmarks) map->UpsertLandmark(l);
}

}  // namespace mapstore
}  // namespace vilma
