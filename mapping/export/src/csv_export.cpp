#include "vilma/mapping/export/csv_export.h"

#include <algorithm>
#include <filesystem>
#include <sstream>
#include <unordered_set>

#include "export_files.h"
#include "vilma/core/asl_dataset.h"
#include "vilma/core/error.h"

namespace vilma::mapping {

using export_files::Exact;
using mapstore::EdgeType;
using mapstore::Id;
using mapstore::IdHash;
using mapstore::LandmarkId;
using mapstore::MissionId;
using mapstore::VertexId;
using mapstore::VIMap;

namespace {

// RFC 4180: a field with a comma, quote or line break is quoted, quotes doubled.
std::string Field(const std::string& text) {
  if (text.find_first_of(",\"\r\n") == std::string::npos) return text;
  std::string quoted = "\"";
  for (char c : text) {
    if (c == '"') quoted += '"';
    quoted += c;
  }
  return quoted + "\"";
}

std::string IdText(const Id& id) { return id.IsValid() ? id.Hex() : std::string(); }

// Appends ",x,y,z".
void AppendVector(const Eigen::Vector3d& v, std::string* row) {
  for (int k = 0; k < 3; ++k) *row += "," + Exact(v[k]);
}
// Appends ",px,py,pz,qw,qx,qy,qz".
void AppendPose(const Transformation& T, std::string* row) {
  AppendVector(T.translation(), row);
  const Eigen::Quaterniond& q = T.rotation();
  for (double c : {q.w(), q.x(), q.y(), q.z()}) *row += "," + Exact(c);
}

std::string PoseColumns(const std::string& name) {  // e.g. "G_I"
  return ",p_" + name + "_x,p_" + name + "_y,p_" + name + "_z,q_" + name + "_w,q_" + name +
         "_x,q_" + name + "_y,q_" + name + "_z";
}

const char* QualityName(mapstore::LandmarkQuality quality) {
  switch (quality) {
    case mapstore::LandmarkQuality::kGood:
      return "good";
    case mapstore::LandmarkQuality::kBad:
      return "bad";
    case mapstore::LandmarkQuality::kUnknown:
      return "unknown";
  }
  return "unknown";
}

const char kHex[] = "0123456789abcdef";

}  // namespace

std::string CsvExportOptions::Validate() const {
  if (out.empty()) return "out: expected the folder to write the CSV files into";
  return "";
}

std::string CsvExportSummary::BriefReport() const {
  const std::string full = FullReport();
  return full.substr(0, full.find('\n'));
}

std::string CsvExportSummary::FullReport() const {
  std::ostringstream s;
  s << "csv: " << rows.size() << " files, " << bytes / 1e6 << " MB in " << folder
    << " (poses and landmarks in G and M)\n";
  for (const auto& [name, count] : rows) s << "  " << name << " " << count << " rows\n";
  return s.str();
}

std::map<std::string, std::string> MakeCsvFiles(const VIMap& map, const CsvExportOptions& options,
                                                CsvExportSummary* summary,
                                                ProgressObserver* progress) {
  ThrowIfInvalid(options.Validate(), "csv_export");
  const std::vector<MissionId> missions =
      export_files::MissionsToExport(map, options.missions, "mission");
  std::unordered_set<Id, IdHash> vertex_set, landmark_set;
  std::size_t total_vertices = 0;
  for (const MissionId& m : missions) {
    for (const VertexId& v : map.vertex_ids(m)) vertex_set.insert(v);
    for (const LandmarkId& l : map.landmark_ids(m)) landmark_set.insert(l);
    total_vertices += map.vertex_ids(m).size();
  }
  std::map<std::string, std::string> files;
  std::map<std::string, std::size_t> rows;
  std::string& missions_csv = files["missions.csv"];
  std::string& vertices_csv = files["vertices.csv"];
  std::string& edges_csv = files["edges.csv"];
  std::string& landmarks_csv = files["landmarks.csv"];
  std::string& observations_csv = files["observations.csv"];
  std::string* keypoints_csv = options.keypoints ? &files["keypoints.csv"] : nullptr;
  std::string* descriptors_csv = options.descriptors ? &files["descriptors.csv"] : nullptr;
  std::string* imu_csv = options.imu ? &files["imu.csv"] : nullptr;

  missions_csv = "mission_id,name,baseframe_known,complete" + PoseColumns("G_M") +
                 ",root_vertex_id,cameras,vertices,edges,landmarks\n";
  vertices_csv = "vertex_id,mission_id,index,t_ns" + PoseColumns("G_I") + PoseColumns("M_I") +
                 ",v_M_x,v_M_y,v_M_z,b_g_x,b_g_y,b_g_z,b_a_x,b_a_y,b_a_z,keypoints,"
                 "keypoints_with_landmark\n";
  edges_csv =
      "edge_id,mission_id,type,from_vertex_id,to_vertex_id,imu_samples,imu_t_first_ns,"
      "imu_t_last_ns" +
      PoseColumns("A_B") + ",switch_variable,switch_variable_variance\n";
  landmarks_csv =
      "landmark_id,mission_id,store_vertex_id,p_G_x,p_G_y,p_G_z,p_M_x,p_M_y,p_M_z,"
      "quality,observations,cov_G_xx,cov_G_xy,cov_G_xz,cov_G_yy,cov_G_yz,cov_G_zz\n";
  observations_csv = "landmark_id,vertex_id,mission_id,camera,keypoint,u_px,v_px\n";
  if (keypoints_csv != nullptr) {
    *keypoints_csv =
        "vertex_id,camera,keypoint,u_px,v_px,scale_px,orientation_rad,score,"
        "track_id,landmark_id\n";
  }
  if (descriptors_csv != nullptr) {
    *descriptors_csv = "vertex_id,camera,keypoint,descriptor_type,descriptor_hex\n";
  }
  if (imu_csv != nullptr) {
    *imu_csv = "edge_id,t_ns,omega_I_x,omega_I_y,omega_I_z,a_I_x,a_I_y,a_I_z\n";
  }

  BeginProgress(progress, "csv", total_vertices);
  std::size_t done = 0;
  for (const MissionId& mission_id : missions) {
    const mapstore::Mission& mission = map.mission(mission_id);
    std::string row = mission_id.Hex() + "," + Field(mission.name) + "," +
                      (mission.baseframe_known ? "1" : "0") + "," + (mission.complete ? "1" : "0");
    AppendPose(mission.T_G_M, &row);
    row += "," + IdText(mission.root_vertex_id) + "," + std::to_string(mission.rig.cameras.size()) +
           "," + std::to_string(map.vertex_ids(mission_id).size()) + "," +
           std::to_string(map.edge_ids(mission_id).size()) + "," +
           std::to_string(map.landmark_ids(mission_id).size()) + "\n";
    missions_csv += row;
    ++rows["missions.csv"];

    // Vertices in time order; `index` is the position in that order (maplab's vertex index).
    std::vector<VertexId> ids = map.vertex_ids(mission_id);
    std::stable_sort(ids.begin(), ids.end(), [&map](const VertexId& a, const VertexId& b) {
      return map.vertex(a).t_ns < map.vertex(b).t_ns;
    });
    for (std::size_t index = 0; index < ids.size(); ++index) {
      const mapstore::Vertex& v = map.vertex(ids[index]);
      std::size_t keypoints = 0, with_landmark = 0;
      for (std::size_t c = 0; c < v.frames.size(); ++c) {
        const mapstore::VisualFrame& f = v.frames[c];
        keypoints += f.size();
        for (std::size_t k = 0; k < f.size(); ++k) {
          const bool exported =
              f.landmark_ids[k].IsValid() && landmark_set.count(f.landmark_ids[k]);
          with_landmark += f.landmark_ids[k].IsValid();
          const std::string key = v.id.Hex() + "," + std::to_string(c) + "," + std::to_string(k);
          if (keypoints_csv != nullptr) {
            const mapstore::Keypoint& kp = f.keypoints[k];
            *keypoints_csv += key + "," + Exact(kp.uv.x()) + "," + Exact(kp.uv.y()) + "," +
                              Exact(kp.scale) + "," + Exact(kp.orientation) + "," +
                              Exact(kp.score) + "," + std::to_string(f.track_ids[k]) + "," +
                              (exported ? f.landmark_ids[k].Hex() : std::string()) + "\n";
            ++rows["keypoints.csv"];
          }
          if (descriptors_csv != nullptr) {
            std::string hex(2 * f.descriptor_size_bytes, '0');
            const uint8_t* d = f.descriptor(k);
            for (uint32_t b = 0; b < f.descriptor_size_bytes; ++b) {
              hex[2 * b] = kHex[d[b] >> 4];
              hex[2 * b + 1] = kHex[d[b] & 15];
            }
            *descriptors_csv += key + "," + Field(f.descriptor_type) + "," + hex + "\n";
            ++rows["descriptors.csv"];
          }
        }
      }
      row = v.id.Hex() + "," + mission_id.Hex() + "," + std::to_string(index) + "," +
            std::to_string(v.t_ns);
      AppendPose(map.T_G_I(v.id), &row);
      AppendPose(v.T_M_I, &row);
      AppendVector(v.v_M, &row);
      AppendVector(v.gyro_bias, &row);
      AppendVector(v.accel_bias, &row);
      row += "," + std::to_string(keypoints) + "," + std::to_string(with_landmark) + "\n";
      vertices_csv += row;
      ++rows["vertices.csv"];
      ReportProgress(progress, ++done);
    }

    for (const mapstore::EdgeId& edge_id : map.edge_ids(mission_id)) {
      const mapstore::Edge& e = map.edge(edge_id);
      if (!vertex_set.count(e.from) || !vertex_set.count(e.to)) continue;  // into another mission
      row = e.id.Hex() + "," + mission_id.Hex() + "," + mapstore::EdgeTypeName(e.type) + "," +
            e.from.Hex() + "," + e.to.Hex() + "," + std::to_string(e.imu_samples.size()) + ",";
      if (!e.imu_samples.empty()) {
        row += std::to_string(e.imu_samples.front().t_ns) + "," +
               std::to_string(e.imu_samples.back().t_ns);
      } else {
        row += ",";
      }
      if (e.type == EdgeType::kImu) {
        row += ",,,,,,,,,";  // T_A_B and the switch variable do not apply
      } else {
        AppendPose(e.T_A_B, &row);
        if (e.type == EdgeType::kLoopClosure) {
          row += "," + Exact(e.switch_variable) + "," + Exact(e.switch_variable_variance);
        } else {
          row += ",,";
        }
      }
      edges_csv += row + "\n";
      ++rows["edges.csv"];
      if (imu_csv != nullptr) {
        for (const ImuSample& s : e.imu_samples) {
          row = e.id.Hex() + "," + std::to_string(s.t_ns);
          AppendVector(s.omega_I, &row);
          AppendVector(s.a_I, &row);
          *imu_csv += row + "\n";
          ++rows["imu.csv"];
        }
      }
    }

    for (const LandmarkId& landmark_id : map.landmark_ids(mission_id)) {
      const mapstore::Landmark& l = map.landmark(landmark_id);
      std::size_t observations = 0;
      for (const mapstore::LandmarkObservation& o : l.observations) {
        if (!vertex_set.count(o.vertex_id)) continue;
        const mapstore::Vertex& observer = map.vertex(o.vertex_id);
        const Eigen::Vector2d& uv = observer.frames.at(o.camera).keypoints.at(o.keypoint).uv;
        observations_csv += landmark_id.Hex() + "," + o.vertex_id.Hex() + "," +
                            observer.mission_id.Hex() + "," + std::to_string(o.camera) + "," +
                            std::to_string(o.keypoint) + "," + Exact(uv.x()) + "," + Exact(uv.y()) +
                            "\n";
        ++observations;
      }
      rows["observations.csv"] += observations;
      // Covariance of p_G: p_G = R_G_I p_I + p_G_I, so Sigma_G = R_G_I Sigma_I R_G_I^T.
      const Eigen::Matrix3d R_G_I = map.T_G_I(l.store_vertex_id).rotationMatrix();
      const Eigen::Matrix3d cov_G = R_G_I * l.covariance * R_G_I.transpose();
      row = landmark_id.Hex() + "," + mission_id.Hex() + "," + l.store_vertex_id.Hex();
      AppendVector(map.LandmarkPosition_G(landmark_id), &row);
      AppendVector(map.LandmarkPosition_M(landmark_id), &row);
      row += std::string(",") + QualityName(l.quality) + "," + std::to_string(observations);
      static constexpr int kUpper[6][2] = {{0, 0}, {0, 1}, {0, 2}, {1, 1}, {1, 2}, {2, 2}};
      for (const auto& rc : kUpper) row += "," + Exact(cov_G(rc[0], rc[1]));
      landmarks_csv += row + "\n";
      ++rows["landmarks.csv"];
    }
  }
  // Files without data rows keep their header and are listed with 0 rows.
  for (const auto& [name, text] : files) rows[name] += 0;
  if (summary != nullptr) {
    summary->rows = rows;
    summary->bytes = 0;
    for (const auto& [name, text] : files) summary->bytes += text.size();
  }
  return files;
}

CsvExportSummary ExportCsv(const VIMap& map, const CsvExportOptions& options,
                           ProgressObserver* progress) {
  CsvExportSummary summary;
  const std::map<std::string, std::string> files = MakeCsvFiles(map, options, &summary, progress);
  export_files::CreateFolder(options.out, "out");
  for (const auto& [name, text] : files) {
    WriteFileAtomically((std::filesystem::path(options.out) / name).string(), text);
  }
  summary.folder = options.out;
  return summary;
}

}  // namespace vilma::mapping
