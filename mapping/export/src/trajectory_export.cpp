#include "vilma/mapping/export/trajectory_export.h"

#include <algorithm>
#include <cctype>
#include <cinttypes>
#include <cstdio>
#include <sstream>

#include "export_files.h"
#include "vilma/core/asl_dataset.h"
#include "vilma/core/error.h"

namespace vilma::mapping {

using mapstore::MissionId;
using mapstore::VertexId;
using mapstore::VIMap;

namespace {

std::string Lower(std::string s) {
  for (char& c : s) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  return s;
}

const char* FrameLetter(ExportFrame frame) { return frame == ExportFrame::kGlobal ? "G" : "M"; }

const char* Extension(TrajectoryExportFormat format) {
  return format == TrajectoryExportFormat::kAsl ? ".csv" : ".txt";
}

}  // namespace

bool ParseTrajectoryExportFormat(const std::string& text, TrajectoryExportFormat* format) {
  const std::string t = Lower(text);
  if (t == "tum") {
    *format = TrajectoryExportFormat::kTum;
  } else if (t == "asl" || t == "euroc") {
    *format = TrajectoryExportFormat::kAsl;
  } else if (t == "rpg") {
    *format = TrajectoryExportFormat::kRpg;
  } else if (t == "kitti") {
    *format = TrajectoryExportFormat::kKitti;
  } else {
    return false;
  }
  return true;
}

const char* TrajectoryExportFormatName(TrajectoryExportFormat format) {
  switch (format) {
    case TrajectoryExportFormat::kTum:
      return "tum";
    case TrajectoryExportFormat::kAsl:
      return "asl";
    case TrajectoryExportFormat::kRpg:
      return "rpg";
    case TrajectoryExportFormat::kKitti:
      return "kitti";
  }
  return "?";
}

bool ParseExportFrame(const std::string& text, ExportFrame* frame) {
  const std::string t = Lower(text);
  if (t == "g" || t == "global") {
    *frame = ExportFrame::kGlobal;
  } else if (t == "m" || t == "mission") {
    *frame = ExportFrame::kMission;
  } else {
    return false;
  }
  return true;
}

std::string TrajectoryExportOptions::Validate() const {
  if (out.empty()) return "out: expected the path of a file or folder to write";
  TrajectoryExportFormat f;
  if (!ParseTrajectoryExportFormat(format, &f)) {
    return "format: expected tum, asl (euroc), rpg or kitti, found '" + format + "'";
  }
  ExportFrame fr;
  if (!ParseExportFrame(frame, &fr)) return "frame: expected G or M, found '" + frame + "'";
  return "";
}

std::string TrajectoryExportSummary::BriefReport() const {
  const std::string full = FullReport();
  return full.substr(0, full.find('\n'));
}

std::string TrajectoryExportSummary::FullReport() const {
  std::ostringstream s;
  s << "trajectory: " << files.size() << (files.size() == 1 ? " file, " : " files, ") << poses
    << " poses (" << format << ", frame " << frame << ", body frame I)\n";
  for (const TrajectoryExportFile& f : files) {
    s << "  " << f.mission_id.Hex().substr(0, 8) << " " << f.poses << " poses -> " << f.path;
    if (frame == "G" && !f.baseframe_known) s << "  (baseframe unknown: G = M as stored)";
    s << "\n";
  }
  return s.str();
}

std::vector<ExportedState> MissionStates(const VIMap& map, const MissionId& mission_id,
                                         ExportFrame frame) {
  const mapstore::Mission& mission = map.mission(mission_id);
  std::vector<VertexId> ids = map.vertex_ids(mission_id);
  if (ids.empty()) {
    throw InputError(FormatInputError("mission " + mission_id.Hex(), "vertices",
                                      "expected at least one vertex to export"));
  }
  std::stable_sort(ids.begin(), ids.end(), [&map](const VertexId& a, const VertexId& b) {
    return map.vertex(a).t_ns < map.vertex(b).t_ns;
  });
  const Transformation T_W_M = frame == ExportFrame::kGlobal ? mission.T_G_M : Transformation();
  const Eigen::Matrix3d R_W_M = T_W_M.rotationMatrix();
  std::vector<ExportedState> states;
  states.reserve(ids.size());
  for (std::size_t i = 0; i < ids.size(); ++i) {
    const mapstore::Vertex& v = map.vertex(ids[i]);
    if (i > 0 && v.t_ns == states.back().t_ns) {
      throw InputError(FormatInputError(
          "mission " + mission_id.Hex(), "vertices",
          "expected strictly increasing vertex times (a trajectory has one pose per time), "
          "found vertices " +
              ids[i - 1].Hex() + " and " + ids[i].Hex() + " both at t = " + std::to_string(v.t_ns) +
              " ns"));
    }
    ExportedState s;
    s.t_ns = v.t_ns;
    s.T_W_I = T_W_M * v.T_M_I;  // p_W = T_W_M p_M
    s.v_W = R_W_M * v.v_M;      // velocities rotate, they do not translate
    s.gyro_bias = v.gyro_bias;
    s.accel_bias = v.accel_bias;
    states.push_back(s);
  }
  return states;
}

Trajectory MissionTrajectory(const VIMap& map, const MissionId& mission_id, ExportFrame frame) {
  Trajectory trajectory;
  for (const ExportedState& s : MissionStates(map, mission_id, frame)) {
    trajectory.Add(s.t_ns, s.T_W_I);
  }
  return trajectory;
}

std::string FormatTrajectory(const std::vector<ExportedState>& states,
                             TrajectoryExportFormat format, ExportFrame frame,
                             const mapstore::Mission& mission) {
  using export_files::Fixed;
  const std::string W = FrameLetter(frame);
  const std::string frame_note =
      frame == ExportFrame::kGlobal
          ? (mission.baseframe_known ? "frame G (global)"
                                     : "frame G (global; baseframe unknown: T_G_M as stored)")
          : "frame M (mission)";
  const std::string about = "vilma trajectory of mission " + mission.id.Hex() +
                            (mission.name.empty() ? "" : " (" + mission.name + ")") +
                            ", IMU poses T_" + W + "_I, " + frame_note;
  std::string text;
  text.reserve(states.size() * 200 + 400);
  auto pose_fields = [](const Transformation& T, bool w_first, char sep) {
    const Eigen::Vector3d& p = T.translation();
    const Eigen::Quaterniond& q = T.rotation();
    std::string s;
    for (int k = 0; k < 3; ++k) s += sep + Fixed(p[k], 9);
    const double quat[4] = {w_first ? q.w() : q.x(), w_first ? q.x() : q.y(),
                            w_first ? q.y() : q.z(), w_first ? q.z() : q.w()};
    for (double c : quat) s += sep + Fixed(c, 9);
    return s;
  };
  switch (format) {
    case TrajectoryExportFormat::kTum:
    case TrajectoryExportFormat::kRpg: {
      text += "# " + about + "\n";
      if (format == TrajectoryExportFormat::kTum) {
        text += "# timestamp[s] tx ty tz qx qy qz qw\n";
      } else {
        // maplab's rpg header (p_G_Ix ...), with the frame actually used.
        text += "# timestamp [s] p_" + W + "_Ix p_" + W + "_Iy p_" + W + "_Iz q_" + W + "_Ix q_" +
                W + "_Iy q_" + W + "_Iz q_" + W + "_Iw\n";
      }
      for (const ExportedState& s : states) {
        text += export_files::SecondsFromNs(s.t_ns) + pose_fields(s.T_W_I, false, ' ') + "\n";
      }
      break;
    }
    case TrajectoryExportFormat::kAsl: {
      // One header line only (EuRoC's own files have one; pandas takes the first line as the
      // column names): it names the frame in every pose and velocity column.
      text += "#timestamp [ns],p_" + W + "_I_x [m],p_" + W + "_I_y [m],p_" + W + "_I_z [m],q_" + W +
              "_I_w [],q_" + W + "_I_x [],q_" + W + "_I_y [],q_" + W + "_I_z [],v_" + W +
              "_I_x [m s^-1],v_" + W + "_I_y [m s^-1],v_" + W +
              "_I_z [m s^-1],b_w_I_x [rad s^-1]," +
              "b_w_I_y [rad s^-1],b_w_I_z [rad s^-1],b_a_I_x [m s^-2],b_a_I_y [m s^-2]," +
              "b_a_I_z [m s^-2]\n";
      for (const ExportedState& s : states) {
        text += std::to_string(s.t_ns) + pose_fields(s.T_W_I, true, ',');
        for (const Eigen::Vector3d* v : {&s.v_W, &s.gyro_bias, &s.accel_bias}) {
          for (int k = 0; k < 3; ++k) text += "," + Fixed((*v)[k], 9);
        }
        text += "\n";
      }
      break;
    }
    case TrajectoryExportFormat::kKitti: {
      // No comment line: KITTI files have none and evo's kitti reader takes every line.
      char buf[32];
      for (const ExportedState& s : states) {
        const Eigen::Matrix4d T = s.T_W_I.matrix();
        for (int r = 0; r < 3; ++r) {
          for (int c = 0; c < 4; ++c) {
            std::snprintf(buf, sizeof(buf), "%s%.12e", r == 0 && c == 0 ? "" : " ", T(r, c));
            text += buf;
          }
        }
        text += "\n";
      }
      break;
    }
  }
  return text;
}

TrajectoryExportSummary ExportTrajectories(const VIMap& map, const TrajectoryExportOptions& options,
                                           ProgressObserver* progress) {
  ThrowIfInvalid(options.Validate(), "export_trajectory_to_csv");
  TrajectoryExportFormat format;
  ParseTrajectoryExportFormat(options.format, &format);
  ExportFrame frame;
  ParseExportFrame(options.frame, &frame);
  const std::vector<MissionId> missions =
      export_files::MissionsToExport(map, options.missions, "mission");

  TrajectoryExportSummary summary;
  summary.format = TrajectoryExportFormatName(format);
  summary.frame = FrameLetter(frame);
  // Every text first: a mission that cannot be exported, or a cancel, writes nothing.
  BeginProgress(progress, "trajectories", missions.size());
  std::vector<std::string> texts;
  for (std::size_t i = 0; i < missions.size(); ++i) {
    const std::vector<ExportedState> states = MissionStates(map, missions[i], frame);
    texts.push_back(FormatTrajectory(states, format, frame, map.mission(missions[i])));
    TrajectoryExportFile file;
    file.mission_id = missions[i];
    file.poses = states.size();
    file.baseframe_known = map.mission(missions[i]).baseframe_known;
    summary.files.push_back(file);
    summary.poses += states.size();
    ReportProgress(progress, i + 1);
  }
  const std::vector<std::string> paths =
      export_files::PerMissionFiles(options.out, "out", missions, "trajectory", Extension(format));
  for (std::size_t i = 0; i < paths.size(); ++i) {
    WriteFileAtomically(paths[i], texts[i]);
    summary.files[i].path = paths[i];
  }
  return summary;
}

}  // namespace vilma::mapping
