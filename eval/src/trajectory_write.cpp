#include "vilma/eval/trajectory.h"

#include <cinttypes>
#include <cstdio>
#include <sstream>
#include <ostream>

#include "vilma/core/atomic_file.h"
#include "vilma/core/error.h"
#include "vilma/core/time.h"

// The writers; the readers are in trajectory_read.cpp.

namespace vilma {

const char* TrajectoryFormatName(TrajectoryFormat format) {
  switch (format) {
    case TrajectoryFormat::kTum:
      return "tum";
    case TrajectoryFormat::kEuroc:
      return "euroc";
    case TrajectoryFormat::kKitti:
      return "kitti";
  }
  return "unknown";
}

namespace {

std::string FormatSeconds(int64_t t_ns) {
  const bool negative = t_ns < 0;
  const uint64_t a = negative ? static_cast<uint64_t>(-(t_ns + 1)) + 1 : t_ns;
  char buf[48];
  std::snprintf(buf, sizeof(buf), "%s%" PRIu64 ".%09" PRIu64, negative ? "-" : "",
                a / static_cast<uint64_t>(kNanosecondsPerSecond),
                a % static_cast<uint64_t>(kNanosecondsPerSecond));
  return buf;
}

}  // namespace

void WriteTumTrajectory(std::ostream& out, const Trajectory& trajectory) {
  out << "# timestamp[s] tx ty tz qx qy qz qw\n";
  char buf[256];
  for (std::size_t i = 0; i < trajectory.size(); ++i) {
    const Eigen::Vector3d& p = trajectory.T_W_B[i].translation();
    const Eigen::Quaterniond& q = trajectory.T_W_B[i].rotation();
    std::snprintf(buf, sizeof(buf), " %.9f %.9f %.9f %.9f %.9f %.9f %.9f\n", p.x(), p.y(), p.z(),
                  q.x(), q.y(), q.z(), q.w());
    out << FormatSeconds(trajectory.t_ns[i]) << buf;
  }
}

void WriteEurocTrajectory(std::ostream& out, const Trajectory& trajectory) {
  out << "#timestamp [ns],p_RS_R_x [m],p_RS_R_y [m],p_RS_R_z [m],q_RS_w [],q_RS_x [],q_RS_y [],"
         "q_RS_z []\n";
  char buf[256];
  for (std::size_t i = 0; i < trajectory.size(); ++i) {
    const Eigen::Vector3d& p = trajectory.T_W_B[i].translation();
    const Eigen::Quaterniond& q = trajectory.T_W_B[i].rotation();
    std::snprintf(buf, sizeof(buf), "%" PRId64 ",%.9f,%.9f,%.9f,%.9f,%.9f,%.9f,%.9f\n",
                  trajectory.t_ns[i], p.x(), p.y(), p.z(), q.w(), q.x(), q.y(), q.z());
    out << buf;
  }
}

void WriteKittiTrajectory(std::ostream& out, const Trajectory& trajectory) {
  char buf[64];
  for (std::size_t i = 0; i < trajectory.size(); ++i) {
    const Eigen::Matrix4d T = trajectory.T_W_B[i].matrix();
    for (int r = 0; r < 3; ++r) {
      for (int c = 0; c < 4; ++c) {
        std::snprintf(buf, sizeof(buf), "%s%.9e", (r == 0 && c == 0) ? "" : " ", T(r, c));
        out << buf;
      }
    }
    out << '\n';
  }
}

void WriteTrajectoryFile(const std::string& path, const Trajectory& trajectory,
                         TrajectoryFormat format) {
  // Written whole and atomically (core's one writer): a reader or a crash never sees half a
  // trajectory, and an existing file stays as it was when the write fails.
  std::ostringstream out;
  switch (format) {
    case TrajectoryFormat::kTum:
      WriteTumTrajectory(out, trajectory);
      break;
    case TrajectoryFormat::kEuroc:
      WriteEurocTrajectory(out, trajectory);
      break;
    case TrajectoryFormat::kKitti:
      WriteKittiTrajectory(out, trajectory);
      break;
  }
  WriteFileAtomically(path, out.str());
}

}  // namespace vilma
