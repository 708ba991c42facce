// Trajectories on disk: a time-ordered list of poses T_W_B (body B in some world frame W) read
// from and written to the three formats the evaluation tools of the field use:
//
//   TUM     "t x y z qx qy qz qw", whitespace separated, t in seconds, quaternion x y z w
//           (Hamilton); '#' lines are comments (evo, rpg_trajectory_evaluation, TUM RGB-D).
//   EuRoC   CSV, "#timestamp [ns], p_RS_R_x [m], ..., q_RS_w, q_RS_x, q_RS_y, q_RS_z[, v_RS_R
//           (3), b_w_RS_S (3), b_a_RS_S (3)]": 8 (pose) or 17 (full state) columns, t integer
//           nanoseconds, quaternion w FIRST (Hamilton).
//   KITTI   12 whitespace-separated numbers, the 3x4 row-major matrix [R | p] of T_W_B, one pose
//           per line and no time stamps (poses are associated by index).
//
// The format is told from the content (see DetectTrajectoryFormat), never from the file name.
// Every reader rejects bad input with a vilma::InputError "FILE: line N: expected ...".
#pragma once

#include <cstdint>
#include <iosfwd>
#include <string>
#include <vector>

#include "vilma/core/geometry.h"

namespace vilma {

enum class TrajectoryFormat { kTum, kEuroc, kKitti };

// "tum", "euroc", "kitti".
const char* TrajectoryFormatName(TrajectoryFormat format);

// A trajectory: poses T_W_B with strictly increasing time stamps t_ns (nanoseconds, the clock of
// whoever wrote the file). KITTI files carry no time: has_timestamps is false and t_ns holds the
// pose index 0, 1, 2, ... so that the vector stays strictly increasing.
struct Trajectory {
  std::vector<int64_t> t_ns;
  std::vector<Transformation> T_W_B;
  bool has_timestamps = true;
  TrajectoryFormat format = TrajectoryFormat::kTum;  // the format it was read from

  std::size_t size() const { return T_W_B.size(); }
  bool empty() const { return T_W_B.empty(); }
  void Add(int64_t t, const Transformation& T) {
    t_ns.push_back(t);
    T_W_B.push_back(T);
  }
};

// Tells the format from the first data line (the first line that is neither empty nor starts
// with '#'): commas -> EuRoC CSV (8 or 17 columns); whitespace -> 8 columns TUM, 12 columns
// KITTI. Throws InputError naming `name` and the line for anything else, or when there is no
// data line at all.
TrajectoryFormat DetectTrajectoryFormat(std::istream& in, const std::string& name);

// Reads a whole trajectory, format detected from the content. `name` is used in error
// messages (the file name). Requirements checked, each with its own message: every data line
// of the detected format and column count; every field a finite number; quaternions of norm
// within 0.1 of one (they are normalized) and KITTI rotations orthonormal within 1e-3 (they are
// re-orthonormalized); time stamps strictly increasing; at least one pose.
Trajectory ReadTrajectory(std::istream& in, const std::string& name);
// Opens `path` (InputError if it cannot be opened) and calls the above.
Trajectory ReadTrajectoryFile(const std::string& path);

// Writers. TUM stamps are written in seconds with nanosecond resolution ("%d.%09d"), so that
// TUM -> read -> TUM is exact; EuRoC stamps as integer ns with the 8-column pose header;
// KITTI drops the stamps. Doubles with 9 significant decimals after the point.
void WriteTumTrajectory(std::ostream& out, const Trajectory& trajectory);
void WriteEurocTrajectory(std::ostream& out, const Trajectory& trajectory);
void WriteKittiTrajectory(std::ostream& out, const Trajectory& trajectory);
// Writes to `path` in `format` (InputError if it cannot be written).
void WriteTrajectoryFile(const std::string& path, const Trajectory& trajectory,
                         TrajectoryFormat format);

// Parses a decimal time in seconds ("1403715274.30214", "12", "-0.5", "1.4e9") to nanoseconds.
// Plain decimals are converted exactly (no double rounding of 19-digit stamps); exponent
// notation goes through double. Returns false if `text` is not such a number.
bool ParseSecondsToNs(const std::string& text, int64_t* t_ns);

}  // namespace vilma
