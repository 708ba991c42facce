#include "vilma/mapping/inspection/map_statistics.h"

#include <cstdio>
#include <filesystem>
#include <sstream>
#include <stdexcept>
#include <unordered_set>

namespace vilma::mapping {

using mapstore::EdgeType;
using mapstore::LandmarkQuality;
using mapstore::VIMap;

namespace {

void Add(MissionStatistics* total, const MissionStatistics& m) {
  total->cameras = std::max(total->cameras, m.cameras);
  total->vertices += m.vertices;
  total->imu_edges += m.imu_edges;
  total->loop_closure_edges += m.loop_closure_edges;
  total->odometry_edges += m.odometry_edges;
  total->pose_prior_edges += m.pose_prior_edges;
  total->imu_samples += m.imu_samples;
  total->landmarks += m.landmarks;
  total->landmarks_good += m.landmarks_good;
  total->landmarks_bad += m.landmarks_bad;
  total->landmarks_unknown += m.landmarks_unknown;
  total->observations += m.observations;
  total->keypoints += m.keypoints;
  total->keypoints_with_landmark += m.keypoints_with_landmark;
  total->keypoints_tracked += m.keypoints_tracked;
  total->landmarks_cross_mission += m.landmarks_cross_mission;
  total->landmarks_good_cross_mission += m.landmarks_good_cross_mission;
  total->path_length_m += m.path_length_m;
}

uint64_t VertexBytes(const mapstore::Vertex& v) {
  uint64_t bytes = sizeof(v);
  for (const mapstore::VisualFrame& f : v.frames) {
    bytes += sizeof(f) + f.keypoints.capacity() * sizeof(mapstore::Keypoint) +
             f.descriptors.capacity() + f.track_ids.capacity() * sizeof(int64_t) +
             f.landmark_ids.capacity() * sizeof(mapstore::LandmarkId);
  }
  return bytes;
}

}  // namespace

MapStatistics ComputeMapStatistics(const VIMap& map) {
  MapStatistics stats;
  for (const mapstore::MissionId& mission_id : map.mission_ids()) {
    const mapstore::Mission& mission = map.mission(mission_id);
    MissionStatistics m;
    m.id = mission_id;
    m.name = mission.name;
    m.baseframe_known = mission.baseframe_known;
    m.complete = mission.complete;
    m.cameras = mission.rig.cameras.size();
    const auto& vertex_ids = map.vertex_ids(mission_id);
    m.vertices = vertex_ids.size();
    bool first = true;
    for (const mapstore::VertexId& id : vertex_ids) {
      const mapstore::Vertex& v = map.vertex(id);
      if (first || v.t_ns < m.start_t_ns) m.start_t_ns = v.t_ns;
      if (first || v.t_ns > m.end_t_ns) m.end_t_ns = v.t_ns;
      first = false;
      for (const mapstore::VisualFrame& f : v.frames) {
        m.keypoints += f.size();
        for (std::size_t k = 0; k < f.size(); ++k) {
          if (f.landmark_ids[k].IsValid()) ++m.keypoints_with_landmark;
          if (f.track_ids[k] >= 0) ++m.keypoints_tracked;
        }
      }
      stats.memory_bytes += VertexBytes(v);
    }
    const std::vector<mapstore::VertexId> chain = map.VertexChain(mission_id);
    for (std::size_t i = 1; i < chain.size(); ++i) {
      m.path_length_m += (map.vertex(chain[i]).T_M_I.translation() -
                          map.vertex(chain[i - 1]).T_M_I.translation())
                             .norm();
    }
    for (const mapstore::EdgeId& id : map.edge_ids(mission_id)) {
      const mapstore::Edge& e = map.edge(id);
      switch (e.type) {
        case EdgeType::kImu: ++m.imu_edges; break;
        case EdgeType::kLoopClosure: ++m.loop_closure_edges; break;
        case EdgeType::kOdometry: ++m.odometry_edges; break;
        case EdgeType::kPosePrior: ++m.pose_prior_edges; break;
      }
      m.imu_samples += e.imu_samples.size();
      stats.memory_bytes += sizeof(e) + e.imu_samples.capacity() * sizeof(ImuSample);
    }
    const std::unordered_set<mapstore::VertexId, mapstore::IdHash> own(vertex_ids.begin(),
                                                                       vertex_ids.end());
    for (const mapstore::LandmarkId& id : map.landmark_ids(mission_id)) {
      const mapstore::Landmark& l = map.landmark(id);
      ++m.landmarks;
      switch (l.quality) {
        case LandmarkQuality::kGood: ++m.landmarks_good; break;
        case LandmarkQuality::kBad: ++m.landmarks_bad; break;
        case LandmarkQuality::kUnknown: ++m.landmarks_unknown; break;
      }
      m.observations += l.observations.size();
      for (const mapstore::LandmarkObservation& o : l.observations) {
        if (own.count(o.vertex_id) == 0) {
          ++m.landmarks_cross_mission;
          m.landmarks_good_cross_mission += l.quality == LandmarkQuality::kGood;
          break;
        }
      }
      stats.memory_bytes +=
          sizeof(l) + l.observations.capacity() * sizeof(mapstore::LandmarkObservation);
    }
    Add(&stats.total, m);
    stats.missions.push_back(m);
  }
  stats.total.start_t_ns = 0;
  stats.total.end_t_ns = 0;
  stats.resources = map.resources().List().size();
  return stats;
}

std::string MapStatistics::BriefReport() const {
  char line[256];
  std::snprintf(line, sizeof(line),
                "%zu missions, %zu vertices, %zu landmarks (%zu good), %zu observations, "
                "memory %.1f MB",
                missions.size(), total.vertices, total.landmarks, total.landmarks_good,
                total.observations, memory_bytes / 1e6);
  return line;
}

std::string MapStatistics::FullReport() const {
  std::ostringstream out;
  char line[512];
  std::snprintf(line, sizeof(line), "%-10s %-16s %5s %7s %7s %6s %9s %8s %8s %8s %9s %9s %8s\n",
                "mission", "name", "base", "vertex", "imu_e", "lc_e", "landmark", "good", "bad",
                "unknown", "obs", "path_m", "dur_s");
  out << line;
  auto row = [&](const std::string& id, const std::string& name, const char* base,
                 const MissionStatistics& m, double duration_s) {
    std::snprintf(line, sizeof(line),
                  "%-10s %-16s %5s %7zu %7zu %6zu %9zu %8zu %8zu %8zu %9zu %9.2f %8.1f\n",
                  id.c_str(), name.substr(0, 16).c_str(), base, m.vertices, m.imu_edges,
                  m.loop_closure_edges, m.landmarks, m.landmarks_good, m.landmarks_bad,
                  m.landmarks_unknown, m.observations, m.path_length_m, duration_s);
    out << line;
  };
  double total_duration_s = 0.0;
  for (const MissionStatistics& m : missions) {
    row(m.id.Hex().substr(0, 8), m.name.empty() ? "-" : m.name,
        m.baseframe_known ? "known" : "unkn", m, m.duration_s());
    total_duration_s += m.duration_s();
  }
  row("total", std::to_string(missions.size()) + " missions", "", total, total_duration_s);
  const double good_share =
      total.landmarks > 0 ? 100.0 * total.landmarks_good / total.landmarks : 0.0;
  const double good_cross_share =
      total.landmarks_good > 0
          ? 100.0 * static_cast<double>(total.landmarks_good_cross_mission) / total.landmarks_good
          : 0.0;
  std::snprintf(line, sizeof(line),
                "good landmarks %.1f %%, cross-mission landmarks %zu (good %zu: %.1f %% of the "
                "good ones), odometry edges %zu, pose priors %zu, IMU samples %zu, resources "
                "%zu, memory %.1f MB\n",
                good_share, total.landmarks_cross_mission, total.landmarks_good_cross_mission,
                good_cross_share, total.odometry_edges,
                total.pose_prior_edges, total.imu_samples, resources, memory_bytes / 1e6);
  out << line;
  return out.str();
}

std::string MapStatistics::MissionReport(const MissionStatistics& m) {
  std::ostringstream out;
  out << "mission " << m.id.Hex() << (m.name.empty() ? "" : " (" + m.name + ")") << "\n"
      << "  baseframe                " << (m.baseframe_known ? "known" : "unknown") << "\n"
      << "  complete                 " << (m.complete ? "yes" : "no") << "\n"
      << "  cameras                  " << m.cameras << "\n"
      << "  vertices                 " << m.vertices << "\n"
      << "  edges imu / loop / odom / prior  " << m.imu_edges << " / " << m.loop_closure_edges
      << " / " << m.odometry_edges << " / " << m.pose_prior_edges << "\n"
      << "  imu samples              " << m.imu_samples << "\n"
      << "  landmarks                " << m.landmarks << " (good " << m.landmarks_good
      << ", bad " << m.landmarks_bad << ", unknown " << m.landmarks_unknown << ")\n"
      << "  cross-mission landmarks  " << m.landmarks_cross_mission << " (good "
      << m.landmarks_good_cross_mission << ")\n"
      << "  observations             " << m.observations << "\n"
      << "  keypoints                " << m.keypoints << " (with landmark "
      << m.keypoints_with_landmark << ", tracked " << m.keypoints_tracked << ")\n";
  char line[160];
  std::snprintf(line, sizeof(line), "  path length              %.3f m\n", m.path_length_m);
  out << line;
  std::snprintf(line, sizeof(line), "  time                     %.3f s (%.3f .. %.3f s)\n",
                m.duration_s(), m.start_t_ns * 1e-9, m.end_t_ns * 1e-9);
  out << line;
  if (m.vertices > 0) {
    std::snprintf(line, sizeof(line), "  landmarks per vertex     %.1f observed, %.1f keypoints\n",
                  static_cast<double>(m.keypoints_with_landmark) / m.vertices,
                  static_cast<double>(m.keypoints) / m.vertices);
    out << line;
  }
  return out.str();
}

std::vector<mapstore::MissionId> ResolveMissions(const VIMap& map,
                                                 const std::string& comma_separated) {
  std::vector<mapstore::MissionId> missions;
  std::size_t begin = 0;
  while (begin <= comma_separated.size()) {
    std::size_t end = comma_separated.find(',', begin);
    if (end == std::string::npos) end = comma_separated.size();
    const std::string word = comma_separated.substr(begin, end - begin);
    if (!word.empty()) missions.push_back(ResolveMission(map, word));
    begin = end + 1;
  }
  return missions;
}

mapstore::MissionId ResolveMission(const VIMap& map, const std::string& text) {
  std::vector<mapstore::MissionId> matches;
  for (const mapstore::MissionId& id : map.mission_ids()) {
    if (map.mission(id).name == text && !text.empty()) return id;
  }
  std::string lower;
  for (char c : text) lower += static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  if (lower.size() >= 4) {
    for (const mapstore::MissionId& id : map.mission_ids()) {
      if (id.Hex().rfind(lower, 0) == 0) matches.push_back(id);
    }
  }
  if (matches.size() == 1) return matches[0];
  std::string known;
  for (const mapstore::MissionId& id : map.mission_ids()) {
    known += " " + id.Hex().substr(0, 8);
    if (!map.mission(id).name.empty()) known += " (" + map.mission(id).name + ")";
  }
  if (known.empty()) known = " none";
  throw std::invalid_argument("mission '" + text + "': " +
                              (matches.empty() ? "expected a mission id (or a unique prefix of "
                                                 "at least 4 hex digits) or name"
                                               : "the prefix matches several missions") +
                              "; missions:" + known);
}

uint64_t FolderSizeBytes(const std::string& folder) {
  namespace fs = std::filesystem;
  std::error_code error;
  if (!fs::is_directory(folder, error)) return 0;
  uint64_t bytes = 0;
  for (const auto& entry : fs::recursive_directory_iterator(folder, error)) {
    if (entry.is_regular_file(error)) bytes += entry.file_size(error);
  }
  return bytes;
}

}  // namespace vilma::mapping
