#include "vilma/core/trajectory.h"

#include <cctype>
#include <cerrno>
#include <cinttypes>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <istream>
#include <limits>
#include <ostream>
#include <sstream>

#include "vilma/core/error.h"
#include "vilma/core/time.h"

namespace vilma {
namespace {

// Quaternions in text files are rounded to ~6 decimals; anything further than this from unit
// norm is not a rotation but a column mix-up (e.g. x y z w read as w x y z does not change the
// norm, but a velocity column read as a quaternion does).
constexpr double kQuaternionNormTolerance = 0.1;
// KITTI poses are printed with 7 significant digits.
constexpr double kKittiRotationTolerance = 1e-3;

const char* const kTumExpectation = "TUM: t x y z qx qy qz qw";
const char* const kEurocExpectation =
    "EuRoC CSV: timestamp [ns], p_x, p_y, p_z, q_w, q_x, q_y, q_z[, v (3), b_w (3), b_a (3)]";
const char* const kKittiExpectation = "KITTI: r11 r12 r13 tx r21 r22 r23 ty r31 r32 r33 tz";

std::string LineField(int line_number) { return "line " + std::to_string(line_number); }

[[noreturn]] void ThrowLineError(const std::string& name, int line_number,
                                 const std::string& expectation) {
  throw InputError(FormatInputError(name, LineField(line_number), expectation));
}

std::string Trim(const std::string& s) {
  std::size_t b = 0;
  std::size_t e = s.size();
  while (b < e && std::isspace(static_cast<unsigned char>(s[b]))) ++b;
  while (e > b && std::isspace(static_cast<unsigned char>(s[e - 1]))) --e;
  return s.substr(b, e - b);
}

bool IsDataLine(const std::string& trimmed) { return !trimmed.empty() && trimmed[0] != '#'; }

// Splits a data line into fields: on commas when it has any (each field trimmed), otherwise on
// runs of whitespace.
std::vector<std::string> SplitFields(const std::string& trimmed, bool* is_csv) {
  std::vector<std::string> fields;
  *is_csv = trimmed.find(',') != std::string::npos;
  if (*is_csv) {
    std::size_t start = 0;
    while (true) {
      const std::size_t comma = trimmed.find(',', start);
      fields.push_back(Trim(trimmed.substr(start, comma - start)));
      if (comma == std::string::npos) break;
      start = comma + 1;
    }
  } else {
    std::istringstream ss(trimmed);
    std::string f;
    while (ss >> f) fields.push_back(f);
  }
  return fields;
}

bool ParseDouble(const std::string& text, double* value) {
  if (text.empty()) return false;
  errno = 0;
  char* end = nullptr;
  const double v = std::strtod(text.c_str(), &end);
  if (end != text.c_str() + text.size() || errno == ERANGE || !std::isfinite(v)) return false;
  *value = v;
  return true;
}

bool ParseInt64(const std::string& text, int64_t* value) {
  if (text.empty()) return false;
  errno = 0;
  char* end = nullptr;
  const long long v = std::strtoll(text.c_str(), &end, 10);
  if (end != text.c_str() + text.size() || errno == ERANGE) return false;
  *value = static_cast<int64_t>(v);
  return true;
}

std::string ColumnCountMessage(std::size_t expected, bool csv, const char* layout,
                               std::size_t got) {
  return "expected " + std::to_string(expected) + (csv ? " comma" : " whitespace") +
         "-separated columns (" + layout + "), got " + std::to_string(got);
}

// What a data line with `n` fields and separator `csv` is, or an explanation of why not.
bool FormatFromShape(std::size_t n, bool csv, TrajectoryFormat* format) {
  if (csv && (n == 8 || n == 17)) {
    *format = TrajectoryFormat::kEuroc;
    return true;
  }
  if (!csv && n == 8) {
    *format = TrajectoryFormat::kTum;
    return true;
  }
  if (!csv && n == 12) {
    *format = TrajectoryFormat::kKitti;
    return true;
  }
  return false;
}

std::string UnknownShapeMessage(std::size_t n, bool csv) {
  return std::string("expected a trajectory line: 8 whitespace-separated columns (") +
         kTumExpectation + "), 12 whitespace-separated columns (" + kKittiExpectation +
         ") or 8 or 17 comma-separated columns (" + kEurocExpectation + "); got " +
         std::to_string(n) + (csv ? " comma" : " whitespace") + "-separated columns";
}

Eigen::Quaterniond CheckedQuaternion(double w, double x, double y, double z,
                                     const std::string& name, int line_number) {
  Eigen::Quaterniond q(w, x, y, z);
  const double norm = q.norm();
  if (std::abs(norm - 1.0) > kQuaternionNormTolerance) {
    std::ostringstream msg;
    msg << "expected a unit quaternion (norm within " << kQuaternionNormTolerance
        << " of 1), got norm " << norm;
    ThrowLineError(name, line_number, msg.str());
  }
  q.coeffs() /= norm;
  return q;
}

}  // namespace

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

bool ParseSecondsToNs(const std::string& text, int64_t* t_ns) {
  if (text.empty()) return false;
  if (text.find_first_of("eE") != std::string::npos) {
    double s = 0.0;
    if (!ParseDouble(text, &s) || std::abs(s) > 9.2e9) return false;
    *t_ns = SecondsToNs(s);
    return true;
  }
  // Exact decimal: [sign] digits [. digits], rounded to the nearest nanosecond.
  std::size_t i = 0;
  bool negative = false;
  if (text[i] == '+' || text[i] == '-') {
    negative = text[i] == '-';
    ++i;
  }
  int64_t whole = 0;
  std::size_t whole_digits = 0;
  while (i < text.size() && std::isdigit(static_cast<unsigned char>(text[i]))) {
    whole = whole * 10 + (text[i] - '0');
    if (whole >= std::numeric_limits<int64_t>::max() / kNanosecondsPerSecond) {
      return false;  // would overflow int64 nanoseconds (~292 years)
    }
    ++whole_digits;
    ++i;
  }
  int64_t frac_ns = 0;
  std::size_t frac_digits = 0;
  if (i < text.size() && text[i] == '.') {
    ++i;
    int64_t scale = kNanosecondsPerSecond / 10;
    bool round_up = false;
    while (i < text.size() && std::isdigit(static_cast<unsigned char>(text[i]))) {
      if (scale > 0) {
        frac_ns += (text[i] - '0') * scale;
        scale /= 10;
      } else if (frac_digits == 9) {
        round_up = text[i] >= '5';  // the 10th decimal decides rounding
      }
      ++frac_digits;
      ++i;
    }
    if (round_up) ++frac_ns;
  }
  if (i != text.size() || whole_digits + frac_digits == 0) return false;
  const int64_t value = whole * kNanosecondsPerSecond + frac_ns;
  *t_ns = negative ? -value : value;
  return true;
}

TrajectoryFormat DetectTrajectoryFormat(std::istream& in, const std::string& name) {
  std::string line;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    const std::string trimmed = Trim(line);
    if (!IsDataLine(trimmed)) continue;
    bool csv = false;
    const std::vector<std::string> fields = SplitFields(trimmed, &csv);
    TrajectoryFormat format;
    if (!FormatFromShape(fields.size(), csv, &format)) {
      ThrowLineError(name, line_number, UnknownShapeMessage(fields.size(), csv));
    }
    return format;
  }
  throw InputError(FormatInputError(
      name, "", "expected at least one trajectory line (TUM, EuRoC CSV or KITTI), found none"));
}

Trajectory ReadTrajectory(std::istream& in, const std::string& name) {
  Trajectory trajectory;
  bool have_format = false;
  std::size_t columns = 0;
  std::string line;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    const std::string trimmed = Trim(line);
    if (!IsDataLine(trimmed)) continue;
    bool csv = false;
    const std::vector<std::string> fields = SplitFields(trimmed, &csv);

    if (!have_format) {
      if (!FormatFromShape(fields.size(), csv, &trajectory.format)) {
        ThrowLineError(name, line_number, UnknownShapeMessage(fields.size(), csv));
      }
      have_format = true;
      columns = fields.size();
      trajectory.has_timestamps = trajectory.format != TrajectoryFormat::kKitti;
    }
    const TrajectoryFormat format = trajectory.format;
    const bool want_csv = format == TrajectoryFormat::kEuroc;
    const char* layout = format == TrajectoryFormat::kTum     ? kTumExpectation
                         : format == TrajectoryFormat::kEuroc ? kEurocExpectation
                                                              : kKittiExpectation;
    if (csv != want_csv || fields.size() != columns) {
      ThrowLineError(name, line_number, ColumnCountMessage(columns, want_csv, layout,
                                                           fields.size()) +
                                            (csv != want_csv ? " with other separators" : ""));
    }

    // Column 1 of TUM and EuRoC is the time stamp, parsed first and exactly (a header line
    // without '#' fails here, with a hint).
    int64_t t = 0;
    if (format == TrajectoryFormat::kTum && !ParseSecondsToNs(fields[0], &t)) {
      ThrowLineError(name, line_number,
                     "expected a time stamp in seconds in column 1 (" +
                         std::string(kTumExpectation) + "), got '" + fields[0] +
                         "' (header lines must start with '#')");
    }
    if (format == TrajectoryFormat::kEuroc && !ParseInt64(fields[0], &t)) {
      ThrowLineError(name, line_number,
                     "expected an integer time stamp in nanoseconds in column 1 (" +
                         std::string(kEurocExpectation) + "), got '" + fields[0] +
                         "' (header lines must start with '#')");
    }
    const std::size_t first_value = format == TrajectoryFormat::kKitti ? 0 : 1;
    double v[17];
    for (std::size_t c = first_value; c < fields.size(); ++c) {
      if (!ParseDouble(fields[c], &v[c])) {
        ThrowLineError(name, line_number,
                       "expected a finite number in column " + std::to_string(c + 1) + " (" +
                           layout + "), got '" + fields[c] + "'");
      }
    }

    Transformation T_W_B;
    switch (format) {
      case TrajectoryFormat::kTum: {
        const Eigen::Quaterniond q = CheckedQuaternion(v[7], v[4], v[5], v[6], name, line_number);
        T_W_B = Transformation(q, Eigen::Vector3d(v[1], v[2], v[3]));
        break;
      }
      case TrajectoryFormat::kEuroc: {
        const Eigen::Quaterniond q = CheckedQuaternion(v[4], v[5], v[6], v[7], name, line_number);
        T_W_B = Transformation(q, Eigen::Vector3d(v[1], v[2], v[3]));
        break;
      }
      case TrajectoryFormat::kKitti: {
        Eigen::Matrix3d R;
        R << v[0], v[1], v[2], v[4], v[5], v[6], v[8], v[9], v[10];
        if (!IsRotationMatrix(R, kKittiRotationTolerance)) {
          ThrowLineError(name, line_number,
                         "expected an orthonormal rotation with determinant +1 (within 1e-3) in "
                         "columns 1-3, 5-7, 9-11 (" +
                             std::string(kKittiExpectation) + ")");
        }
        // Re-orthonormalize through the quaternion (nearest rotation for small deviations).
        T_W_B = Transformation(Eigen::Quaterniond(R), Eigen::Vector3d(v[3], v[7], v[11]));
        t = static_cast<int64_t>(trajectory.size());
        break;
      }
    }
    if (!trajectory.empty() && t <= trajectory.t_ns.back()) {
      ThrowLineError(name, line_number,
                     "expected strictly increasing time stamps, got " + fields[0] +
                         " after the previous line's");
    }
    trajectory.Add(t, T_W_B);
  }
  if (in.bad()) throw InputError(FormatInputError(name, "", "expected a readable file"));
  if (trajectory.empty()) {
    throw InputError(FormatInputError(
        name, "", "expected at least one trajectory line (TUM, EuRoC CSV or KITTI), found none"));
  }
  return trajectory;
}

Trajectory ReadTrajectoryFile(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(FormatInputError(path, "", "expected a readable trajectory file"));
  return ReadTrajectory(in, path);
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
  std::ofstream out(path);
  if (!out) throw InputError(FormatInputError(path, "", "expected a writable file"));
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
  out.flush();
  if (!out) throw InputError(FormatInputError(path, "", "expected a writable file (write failed)"));
}

}  // namespace vilma
