// Statistics of a VI-map (maplab's map_stats / mission_stats): per mission vertices, edges by
// type, landmarks by quality, observations, path length, duration, baseframe, and the map's
// size in memory. Also the lookup of a mission by id, id prefix or name that commands share.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "vilma/mapstore/vi_map.h"

namespace vilma::mapping {

struct MissionStatistics {
  mapstore::MissionId id;
  std::string name;
  bool baseframe_known = false;
  bool complete = false;
  std::size_t cameras = 0;
  std::size_t vertices = 0;
  std::size_t imu_edges = 0;
  std::size_t loop_closure_edges = 0;
  std::size_t odometry_edges = 0;
  std::size_t pose_prior_edges = 0;
  std::size_t imu_samples = 0;
  std::size_t landmarks = 0;  // stored in this mission's vertices
  std::size_t landmarks_good = 0;
  std::size_t landmarks_bad = 0;
  std::size_t landmarks_unknown = 0;
  std::size_t observations = 0;      // of this mission's landmarks (from any mission)
  std::size_t keypoints = 0;         // in this mission's vertices
  std::size_t keypoints_with_landmark = 0;
  std::size_t keypoints_tracked = 0;  // with a track id
  // Landmarks of this mission observed from at least one vertex of another mission.
  std::size_t landmarks_cross_mission = 0;
  std::size_t landmarks_good_cross_mission = 0;  // of those, good
  double path_length_m = 0.0;  // along the vertex chain
  int64_t start_t_ns = 0;
  int64_t end_t_ns = 0;
  double duration_s() const { return (end_t_ns - start_t_ns) * 1e-9; }
};

struct MapStatistics {
  std::vector<MissionStatistics> missions;  // in map order
  MissionStatistics total;                  // sums (id, name, times unset)
  std::size_t resources = 0;
  uint64_t memory_bytes = 0;  // estimate of the map's heap memory (vectors' capacities)

  // One line: missions, vertices, landmarks (good), memory (core/report.h's shape).
  std::string BriefReport() const;
  // The table of map_stats: one row per mission and a total row.
  std::string FullReport() const;
  // mission_stats: every field of one mission, one per line.
  static std::string MissionReport(const MissionStatistics& m);
};

MapStatistics ComputeMapStatistics(const mapstore::VIMap& map);

// A mission by full 32-digit hex id, unique hex prefix (at least 4 digits), or exact name.
// Throws std::invalid_argument naming what was asked and the missions there are.
mapstore::MissionId ResolveMission(const mapstore::VIMap& map, const std::string& id_prefix_or_name);
// A comma-separated list of the above (the console's --map_mission); empty text: no mission
// (commands read it as "every mission").
std::vector<mapstore::MissionId> ResolveMissions(const mapstore::VIMap& map,
                                                 const std::string& comma_separated);

// Total size of the regular files under `folder` [bytes] (0 if it does not exist).
uint64_t FolderSizeBytes(const std::string& folder);

}  // namespace vilma::mapping
