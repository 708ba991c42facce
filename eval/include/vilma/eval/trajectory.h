// Trajectories on disk: a time-ordered list of poses T_W_B (body B in some world frame W) read
// from and written to the three formats the evaluation tools of the field use:
//
//   TUM     "t x y z qx qy qz qw", whitespace separated, t in seconds, quaternion x y z w
//           (Hamilton); '#' lines are comments (evo, rpg_trajectory_evaluation, TUM RGB-D).
//   EuRoC   CSV, "#timestamp [ns], p_RS_R_x [m], ..., q_RS_w, q_RS_x, q_RS_y, q_RS_z[, v_RS_R
//           (3), b_w_RS_S (3), b_a_RS_S (3)]": 8 (pose), 17 (full state) or any other number
//           >= 8 of columns (those after the 8th are ignored, as evo does), t integer
//           nanoseconds, quaternion w FIRST (Hamilton).
//   KITTI   12 whitespace-separated numbers, the 3x4 row-major matrix [R | p] of T_W_B, one pose
//           per line and no time stamps (poses are associated by index).
//
// The format is told from the content (see DetectTrajectoryFormat), never from the file name.
// Files written by other systems (ORB-SLAM, VINS, OpenVINS, ...) bend these formats; the reader
// takes them the way evo does and reports every bend it meets (TrajectoryReadReport): header
// rows with or without '#', commas / spaces / tabs / mixed separators, trailing separators,
// blank lines, CRLF line ends, a UTF-8 byte order mark, stamps in nanoseconds in a TUM file
// (integers > 1e12) or in seconds in a CSV (decimals), a header naming the quaternion's w
// column against the separator's convention, and repeated time stamps (the FIRST pose of a
// repeated stamp is kept, the others dropped with a warning naming their lines). Decreasing
// stamps are an error. Every reader rejects bad input with a vilma::InputError
// "FILE: line N: expected ...". Details and the reasons: docs/evaluation.md, "Reading other
// systems' files".
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

// Tells the format from the first data line (the first line that is neither empty, nor starts
// with '#', nor is a header row whose first field is not a number): commas -> EuRoC CSV (>= 8
// columns); whitespace -> 8 columns TUM, 12 columns KITTI; a header line naming the
// quaternion's w column (qw, q_w, q_RS_w, ...) in column 5 or 8 decides the quaternion order
// (EuRoC w x y z, TUM x y z w) against the separator's convention. Throws InputError naming
// `name` and the line for anything else, or when there is no data line at all.
TrajectoryFormat DetectTrajectoryFormat(std::istream& in, const std::string& name);

enum class StampUnit { kNone, kSeconds, kNanoseconds };

// A pose dropped because its time stamp repeated the previous pose's.
struct RepeatedStamp {
  int line = 0;        // 1-based line of the dropped pose
  int first_line = 0;  // line of the kept (first) pose with that stamp
  std::string stamp;   // as written in the file
};

// What ReadTrajectory met on its way: the detected layout and every quirk of the file.
struct TrajectoryReadReport {
  std::string name;       // the file name given to the reader
  std::size_t poses = 0;  // poses read (repeated stamps not counted)
  TrajectoryFormat format = TrajectoryFormat::kTum;
  std::size_t columns = 0;  // fields per data line
  // The header named the quaternion's w column against the separator's convention (a CSV in
  // x y z w order, or a whitespace file in w x y z order).
  bool quaternion_order_from_header = false;
  StampUnit stamp_unit = StampUnit::kNone;  // kNone for KITTI
  std::string stamp_unit_reason;            // why: "> 1e12", "<= 1e12", "decimals <= 1e12",
                                            // "CSV integers, the EuRoC convention"
  bool comma = false;                       // separators met between the fields of data lines
  bool space = false;
  bool tab = false;
  std::size_t header_lines = 0;              // before the first pose: '#' lines and header rows
  std::size_t header_rows_without_hash = 0;  // of those, rows whose first field is not a number
  std::size_t comment_lines = 0;             // '#' lines after the first pose
  std::size_t blank_lines = 0;
  std::size_t crlf_lines = 0;                  // lines ending in "\r\n"
  bool byte_order_mark = false;                // a UTF-8 BOM before the first line
  std::size_t trailing_separator_lines = 0;    // data lines ending in a comma or a blank
  std::vector<RepeatedStamp> repeated_stamps;  // dropped poses, in file order
};

// One line "read FILE: N poses, format TUM, stamps in seconds, space-separated[, quirk, ...]"
// naming the layout and every quirk met (each once, with counts).
std::string TrajectoryReadSummary(const TrajectoryReadReport& report);
// One warning per repeated stamp, "FILE: line L: repeated time stamp T (first at line K):
// dropped", for the first 5; beyond that one more line with the count and the lines. Empty when
// nothing was dropped.
std::vector<std::string> TrajectoryReadWarnings(const TrajectoryReadReport& report);

// Reads a whole trajectory, format detected from the content. `name` is used in error
// messages (the file name). Requirements checked, each with its own message naming the line
// and the column: every data line of the detected separator and column count; every field a
// finite number; quaternions of norm within 0.1 of one (they are normalized) and KITTI
// rotations orthonormal within 1e-3 (they are re-orthonormalized); time stamps increasing,
// all in the unit of the first one; at least one pose. A stamp equal to the previous pose's is
// dropped (the first pose is kept) and recorded in the report. With `report`, it is filled in.
Trajectory ReadTrajectory(std::istream& in, const std::string& name,
                          TrajectoryReadReport* report = nullptr);
// Opens `path` (InputError if it cannot be opened) and calls the above.
Trajectory ReadTrajectoryFile(const std::string& path, TrajectoryReadReport* report = nullptr);

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
// Parses a time in nanoseconds: an integer ("1403715273262142976", exact), a decimal
// ("1403715273262142976.000000", integer part exact, rounded to the nearest ns) or exponent
// notation ("1.40372e+18", through double). Returns false if `text` is not such a number or
// does not fit int64.
bool ParseNanoseconds(const std::string& text, int64_t* t_ns);

}  // namespace vilma
