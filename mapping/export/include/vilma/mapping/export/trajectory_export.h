// export_trajectory_to_csv (maplab's `ettc`): the vertices' IMU poses of each mission as a
// trajectory file that `vilma eval`, evo and rpg_trajectory_evaluation read (docs/export.md).
//
//   tum    "t x y z qx qy qz qw", t in seconds with ns resolution, space separated, '#'
//          comments (the TUM RGB-D / evo `tum` format; core/trajectory.h reads it).
//   asl    EuRoC/ASL state CSV, 17 columns: t [ns], p (3), q (w, x, y, z), v (3), gyroscope
//          bias (3), accelerometer bias (3) — the layout of EuRoC's
//          state_groundtruth_estimate0/data.csv and of maplab's `asl` export without its id
//          columns (evo `euroc`, core/trajectory.h's 17-column EuRoC).
//   rpg    rpg_trajectory_evaluation's stamped_traj_estimate.txt: the TUM columns with
//          maplab's `rpg` header.
//   kitti  12 numbers per line, the 3x4 [R | p] of each pose, no time (evo `kitti`).
//
// Frame: G (T_G_I = T_G_M T_M_I, v_G = R_G_M v_M) or M (T_M_I, v_M); the header line of every
// file names it. A mission whose baseframe is unknown has the T_G_M it holds (identity unless
// set): its G export equals its M export, and the summary says so. Biases are in I either way.
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "vilma/core/progress.h"
#include "vilma/eval/trajectory.h"
#include "vilma/mapstore/vi_map.h"

namespace vilma::mapping {

enum class TrajectoryExportFormat { kTum, kAsl, kRpg, kKitti };
// Parses "tum", "asl" (or "euroc"), "rpg", "kitti"; false for anything else.
bool ParseTrajectoryExportFormat(const std::string& text, TrajectoryExportFormat* format);
const char* TrajectoryExportFormatName(TrajectoryExportFormat format);

// The frame poses are written in.
enum class ExportFrame { kGlobal, kMission };
// Parses "G" / "global" and "M" / "mission" (any case); false for anything else.
bool ParseExportFrame(const std::string& text, ExportFrame* frame);

struct TrajectoryExportOptions {
  // A file, or a folder (existing, or ending in '/'); several missions give one file each
  // (docs/export.md "Output paths"). Created folders as needed.
  std::string out;
  std::string format = "tum";  // tum | asl (euroc) | rpg | kitti
  std::string frame = "G";     // G (global) | M (each mission's own frame)
  // Missions to export; empty: every mission of the map.
  std::vector<mapstore::MissionId> missions;

  // "field: expectation", or "" when valid.
  std::string Validate() const;
};

struct TrajectoryExportFile {
  mapstore::MissionId mission_id;
  std::string path;
  std::size_t poses = 0;
  bool baseframe_known = false;
};

struct TrajectoryExportSummary {
  std::string format;  // tum, asl, rpg, kitti
  std::string frame;   // "G" or "M"
  std::vector<TrajectoryExportFile> files;
  std::size_t poses = 0;  // over all files
  // "trajectory: 2 files, 196 poses (tum, frame G) ..." plus one line per file.
  std::string BriefReport() const;  // one line: counts and where it went
  std::string FullReport() const;   // the brief line and the details (what the command prints)
};

// One state per vertex of the mission, ordered by time, in `frame`.
struct ExportedState {
  int64_t t_ns = 0;
  Transformation T_W_I;  // W = G or M
  Eigen::Vector3d v_W = Eigen::Vector3d::Zero();
  Eigen::Vector3d gyro_bias = Eigen::Vector3d::Zero();   // [rad/s], in I
  Eigen::Vector3d accel_bias = Eigen::Vector3d::Zero();  // [m/s^2], in I
};
// The mission's vertices sorted by time. Throws InputError naming the mission and both vertices
// when two vertices have the same time (a trajectory needs strictly increasing stamps), or when
// the mission has no vertex.
std::vector<ExportedState> MissionStates(const mapstore::VIMap& map,
                                         const mapstore::MissionId& mission_id, ExportFrame frame);

// The mission's poses as a core Trajectory (what `vilma eval` reads back).
Trajectory MissionTrajectory(const mapstore::VIMap& map, const mapstore::MissionId& mission_id,
                             ExportFrame frame);

// The file text for one mission (header comment naming frame and mission, then one line per
// state).
std::string FormatTrajectory(const std::vector<ExportedState>& states,
                             TrajectoryExportFormat format, ExportFrame frame,
                             const mapstore::Mission& mission);

// Writes one file per mission, each atomically, after every file's text has been made (bad
// input or Cancelled leave nothing written). Throws InputError for invalid options, a mission
// not in the map, an unwritable path or duplicate vertex times.
TrajectoryExportSummary ExportTrajectories(const mapstore::VIMap& map,
                                           const TrajectoryExportOptions& options,
                                           ProgressObserver* progress = nullptr);

}  // namespace vilma::mapping
