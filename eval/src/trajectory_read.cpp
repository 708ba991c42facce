// Reading trajectories, also those written by other systems (trajectory.h; docs/evaluation.md,
// "Reading other systems' files"). One pass over the lines; the first data line fixes the
// separator class (commas or whitespace), the column count, the quaternion order and the time
// unit, and every later line is checked against it.
#include <algorithm>
#include <cctype>
#include <cerrno>
#include <cmath>
#include <cstdlib>
#include <fstream>
#include <istream>
#include <limits>
#include <sstream>

#include "vilma/core/error.h"
#include "vilma/core/time.h"
#include "vilma/eval/trajectory.h"

namespace vilma {
namespace {

// Quaternions in text files are rounded to ~6 decimals; anything further than this from unit
// norm is not a rotation but a column mix-up (e.g. x y z w read as w x y z does not change the
// norm, but a velocity column read as a quaternion does).
constexpr double kQuaternionNormTolerance = 0.1;
// KITTI poses are printed with 7 significant digits.
constexpr double kKittiRotationTolerance = 1e-3;
// Stamps above this magnitude are nanoseconds: 1e12 s would be 31,700 years, 1e12 ns is 17
// minutes (a Unix time in ns is ~1.4e18; in s ~1.4e9). Milliseconds or microseconds are not
// guessed: they would be taken for nanoseconds.
constexpr double kNanosecondStampThreshold = 1e12;
// Repeated stamps warned one by one; the rest are summarized in one line.
constexpr std::size_t kRepeatWarnings = 5;
constexpr std::size_t kRepeatLinesListed = 20;

const char* const kTumExpectation = "TUM: t x y z qx qy qz qw";
const char* const kEurocExpectation =
    "EuRoC CSV: t, p_x, p_y, p_z, q_w, q_x, q_y, q_z[, more columns, ignored]";
const char* const kKittiExpectation = "KITTI: r11 r12 r13 tx r21 r22 r23 ty r31 r32 r33 tz";

[[noreturn]] void ThrowLineError(const std::string& name, int line_number,
                                 const std::string& expectation) {
  throw InputError(FormatInputError(name, "line " + std::to_string(line_number), expectation));
}

bool IsBlank(char c) {
  return c == ' ' || c == '\t' || c == '\r' || c == '\n' || c == '\v' || c == '\f';
}

std::string Trim(const std::string& s) {
  std::size_t b = 0;
  std::size_t e = s.size();
  while (b < e && IsBlank(s[b])) ++b;
  while (e > b && IsBlank(s[e - 1])) --e;
  return s.substr(b, e - b);
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

bool IsInteger(const std::string& text) {
  std::size_t i = (!text.empty() && (text[0] == '+' || text[0] == '-')) ? 1 : 0;
  if (i == text.size()) return false;
  for (; i < text.size(); ++i) {
    if (!std::isdigit(static_cast<unsigned char>(text[i]))) return false;
  }
  return true;
}

// A trimmed data line split into fields. Separators are commas and whitespace: a run of blanks
// with at most one comma separates two fields; each further comma in the run is an empty field
// (",," or ", ,"). A comma run at the end of the line is a trailing separator, not a field.
struct SplitLine {
  std::vector<std::string> fields;
  bool comma = false;
  bool space = false;
  bool tab = false;
  bool trailing_separator = false;
};

SplitLine Split(const std::string& trimmed) {
  SplitLine out;
  std::size_t i = 0;
  const std::size_t n = trimmed.size();
  std::string field;
  while (i < n) {
    const char c = trimmed[i];
    if (c != ',' && !IsBlank(c)) {
      field += c;
      ++i;
      continue;
    }
    // A separator run [i, j).
    std::size_t commas = 0;
    bool tab = false;
    bool space = false;
    std::size_t j = i;
    for (; j < n && (trimmed[j] == ',' || IsBlank(trimmed[j])); ++j) {
      if (trimmed[j] == ',') {
        ++commas;
      } else if (trimmed[j] == '\t') {
        tab = true;
      } else {
        space = true;
      }
    }
    const bool at_start = i == 0;
    const bool trailing = j == n && !at_start;  // (the line is trimmed: commas only)
    if (!at_start) out.fields.push_back(field);
    field.clear();
    // Empty fields: a leading run has one per comma; an inner run one per comma beyond the
    // first; a trailing run one per comma beyond the last (which is the trailing separator).
    std::size_t empties = at_start ? commas : (commas > 0 ? commas - 1 : 0);
    for (std::size_t k = 0; k < empties; ++k) out.fields.emplace_back();
    if (trailing) {
      out.trailing_separator = true;
      out.comma |= commas > 1;
    } else {
      out.comma |= commas > 0;
      out.tab |= tab;
      out.space |= space;
    }
    i = j;
  }
  if (!field.empty()) out.fields.push_back(field);
  return out;
}

// The column (0-based) that a header line names as the quaternion's w ("qw", "q_w", "q_RS_w
// []", "quat_w", "w"), when the header has exactly `columns` names; -1 otherwise.
int HeaderWColumn(const std::string& header, std::size_t columns) {
  std::size_t b = 0;
  while (b < header.size() && (header[b] == '#' || IsBlank(header[b]))) ++b;
  const std::string body = header.substr(b);
  std::vector<std::string> names;
  if (body.find(',') != std::string::npos) {
    std::stringstream ss(body);
    std::string name;
    while (std::getline(ss, name, ',')) names.push_back(Trim(name));
  } else {
    std::istringstream ss(body);
    std::string name;
    while (ss >> name) names.push_back(name);
  }
  if (names.size() != columns) return -1;
  for (std::size_t c = 0; c < names.size(); ++c) {
    std::string name = names[c].substr(0, names[c].find_first_of(" [("));
    std::transform(name.begin(), name.end(), name.begin(),
                   [](unsigned char ch) { return static_cast<char>(std::tolower(ch)); });
    if (name == "w" || (name.size() >= 2 && name.front() == 'q' && name.back() == 'w')) {
      return static_cast<int>(c);
    }
  }
  return -1;
}

std::string UnknownShapeMessage(std::size_t n, bool csv) {
  return std::string("expected a trajectory line: 8 whitespace-separated columns (") +
         kTumExpectation + "), 12 whitespace-separated columns (" + kKittiExpectation +
         ") or 8 or more comma-separated columns (" + kEurocExpectation + "); got " +
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

// The line-by-line reader shared by DetectTrajectoryFormat and ReadTrajectory.
class LineReader {
 public:
  LineReader(const std::string& name, TrajectoryReadReport* report)
      : name_(name), report_(*report) {
    report_ = TrajectoryReadReport();
    report_.name = name;
  }

  // Reads one raw line (without its '\n'). With only_detect, stops after fixing the layout.
  void Consume(std::string line, bool only_detect);
  bool have_layout() const { return have_layout_; }
  const Trajectory& trajectory() const { return trajectory_; }
  Trajectory&& TakeTrajectory() { return std::move(trajectory_); }

 private:
  void FixLayout(const SplitLine& split);
  const char* Layout() const {
    return trajectory_.format == TrajectoryFormat::kTum     ? kTumExpectation
           : trajectory_.format == TrajectoryFormat::kEuroc ? kEurocExpectation
                                                            : kKittiExpectation;
  }
  // The stamp's unit by the rule of docs/evaluation.md, with the reason.
  StampUnit UnitOf(const std::string& text, double value, std::string* reason) const;
  int64_t ParseStamp(const std::string& text);
  void AddPose(const SplitLine& split);

  const std::string& name_;
  TrajectoryReadReport& report_;
  Trajectory trajectory_;
  int line_number_ = 0;
  bool have_layout_ = false;
  bool csv_ = false;  // the first data line had commas
  int w_column_ = 0;  // the quaternion's w: 4 (w x y z) or 7 (x y z w)
  std::string last_header_;
  int first_stamp_line_ = 0;
  int last_line_ = 0;       // line of the last kept pose
  std::string last_stamp_;  // its stamp as written
};

void LineReader::Consume(std::string line, bool only_detect) {
  ++line_number_;
  if (line_number_ == 1 && line.compare(0, 3, "\xEF\xBB\xBF") == 0) {
    report_.byte_order_mark = true;
    line.erase(0, 3);
  }
  if (!line.empty() && line.back() == '\r') {
    ++report_.crlf_lines;
    line.pop_back();
  }
  const std::string trimmed = Trim(line);
  if (trimmed.empty()) {
    ++report_.blank_lines;
    return;
  }
  if (trimmed[0] == '#') {
    if (have_layout_) {
      ++report_.comment_lines;
    } else {
      ++report_.header_lines;
      last_header_ = trimmed;
    }
    return;
  }
  SplitLine split = Split(trimmed);
  split.trailing_separator |= IsBlank(line.back());  // "... qw " (evo rejects it)
  double first = 0.0;
  if (!have_layout_ && !split.fields.empty() && !ParseDouble(split.fields[0], &first)) {
    // A header row without '#' (e.g. "timestamp,x,y,z,qw,qx,qy,qz"): only before any pose.
    ++report_.header_lines;
    ++report_.header_rows_without_hash;
    last_header_ = trimmed;
    return;
  }
  if (!have_layout_) {
    FixLayout(split);
    if (only_detect) return;
  }
  AddPose(split);
}

void LineReader::FixLayout(const SplitLine& split) {
  const std::size_t n = split.fields.size();
  csv_ = split.comma;
  if (csv_ && n >= 8) {
    trajectory_.format = TrajectoryFormat::kEuroc;
    w_column_ = 4;
  } else if (!csv_ && n == 8) {
    trajectory_.format = TrajectoryFormat::kTum;
    w_column_ = 7;
  } else if (!csv_ && n == 12) {
    trajectory_.format = TrajectoryFormat::kKitti;
    trajectory_.has_timestamps = false;
  } else {
    ThrowLineError(name_, line_number_, UnknownShapeMessage(n, csv_));
  }
  if (trajectory_.format != TrajectoryFormat::kKitti) {
    // The header's column names overrule the separator's convention for the quaternion order.
    const int named = HeaderWColumn(last_header_, n);
    if ((named == 4 || named == 7) && named != w_column_) {
      w_column_ = named;
      trajectory_.format = named == 4 ? TrajectoryFormat::kEuroc : TrajectoryFormat::kTum;
      report_.quaternion_order_from_header = true;
    }
  }
  report_.format = trajectory_.format;
  report_.columns = n;
  have_layout_ = true;
}

StampUnit LineReader::UnitOf(const std::string& text, double value, std::string* reason) const {
  if (std::abs(value) > kNanosecondStampThreshold) {
    *reason = "> 1e12";
    return StampUnit::kNanoseconds;
  }
  if (csv_ && IsInteger(text)) {
    *reason = "CSV integers, the EuRoC convention";
    return StampUnit::kNanoseconds;
  }
  *reason = csv_ ? "decimals <= 1e12" : "<= 1e12";
  return StampUnit::kSeconds;
}

int64_t LineReader::ParseStamp(const std::string& text) {
  double value = 0.0;
  if (!ParseDouble(text, &value)) {
    ThrowLineError(name_, line_number_,
                   "expected a time stamp in column 1 (" + std::string(Layout()) + "), got '" +
                       text + "'" +
                       (trajectory_.empty() ? "" : " (header rows only before the first pose)"));
  }
  std::string reason;
  const StampUnit unit = UnitOf(text, value, &reason);
  if (report_.stamp_unit == StampUnit::kNone) {
    report_.stamp_unit = unit;
    report_.stamp_unit_reason = reason;
    first_stamp_line_ = line_number_;
  } else if (unit != report_.stamp_unit) {
    const bool ns = report_.stamp_unit == StampUnit::kNanoseconds;
    ThrowLineError(name_, line_number_,
                   std::string("expected a time stamp in ") + (ns ? "nanoseconds" : "seconds") +
                       " in column 1 like line " + std::to_string(first_stamp_line_) + ", got '" +
                       text + "' (" + (ns ? "seconds" : "nanoseconds") + ": " + reason + ")");
  }
  int64_t t = 0;
  const bool ok =
      unit == StampUnit::kNanoseconds ? ParseNanoseconds(text, &t) : ParseSecondsToNs(text, &t);
  if (!ok) {
    ThrowLineError(
        name_, line_number_,
        "expected a time stamp that fits int64 nanoseconds in column 1, got '" + text + "'");
  }
  return t;
}

void LineReader::AddPose(const SplitLine& split) {
  const std::vector<std::string>& fields = split.fields;
  if (split.comma != csv_ || fields.size() != report_.columns) {
    ThrowLineError(name_, line_number_,
                   "expected " + std::to_string(report_.columns) +
                       (csv_ ? " comma" : " whitespace") + "-separated columns (" + Layout() +
                       "), got " + std::to_string(fields.size()) +
                       (split.comma != csv_ ? " with other separators" : ""));
  }
  if (split.trailing_separator) ++report_.trailing_separator_lines;
  report_.comma |= split.comma;
  report_.space |= split.space;
  report_.tab |= split.tab;

  const bool kitti = trajectory_.format == TrajectoryFormat::kKitti;
  const int64_t t = kitti ? static_cast<int64_t>(trajectory_.size()) : ParseStamp(fields[0]);
  // Only the pose columns are parsed; evo ignores the columns after the 8th as well.
  const std::size_t used = kitti ? 12 : 8;
  double v[12];
  for (std::size_t c = kitti ? 0 : 1; c < used; ++c) {
    if (!ParseDouble(fields[c], &v[c])) {
      ThrowLineError(name_, line_number_,
                     "expected a finite number in column " + std::to_string(c + 1) + " (" +
                         Layout() + "), got '" + fields[c] + "'");
    }
  }

  Transformation T_W_B;
  if (kitti) {
    Eigen::Matrix3d R;
    R << v[0], v[1], v[2], v[4], v[5], v[6], v[8], v[9], v[10];
    if (!IsRotationMatrix(R, kKittiRotationTolerance)) {
      ThrowLineError(name_, line_number_,
                     "expected an orthonormal rotation with determinant +1 (within 1e-3) in "
                     "columns 1-3, 5-7, 9-11 (" +
                         std::string(kKittiExpectation) + ")");
    }
    // Re-orthonormalize through the quaternion (nearest rotation for small deviations).
    T_W_B = Transformation(Eigen::Quaterniond(R), Eigen::Vector3d(v[3], v[7], v[11]));
  } else {
    const Eigen::Quaterniond q =
        w_column_ == 4 ? CheckedQuaternion(v[4], v[5], v[6], v[7], name_, line_number_)
                       : CheckedQuaternion(v[7], v[4], v[5], v[6], name_, line_number_);
    T_W_B = Transformation(q, Eigen::Vector3d(v[1], v[2], v[3]));
  }
  // A dropped row is still checked in full above: malformed rows are errors everywhere.
  if (!kitti && !trajectory_.empty()) {
    const int64_t previous = trajectory_.t_ns.back();
    if (t == previous) {
      // ORB-SLAM2 and others repeat a stamp now and then: keep the first pose (docs).
      report_.repeated_stamps.push_back({line_number_, last_line_, fields[0]});
      return;
    }
    if (t < previous) {
      ThrowLineError(name_, line_number_,
                     "expected increasing time stamps, got " + fields[0] + " after " + last_stamp_ +
                         " at line " + std::to_string(last_line_) +
                         " (decreasing stamps are not sorted: two runs in one file?)");
    }
  }
  trajectory_.Add(t, T_W_B);
  last_line_ = line_number_;
  last_stamp_ = fields[0];
}

[[noreturn]] void ThrowNoPose(const std::string& name) {
  throw InputError(FormatInputError(
      name, "", "expected at least one trajectory line (TUM, EuRoC CSV or KITTI), found none"));
}

std::string Plural(std::size_t n, const std::string& word) {
  return std::to_string(n) + " " + word + (n == 1 ? "" : "s");
}

}  // namespace

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

bool ParseNanoseconds(const std::string& text, int64_t* t_ns) {
  if (text.empty()) return false;
  if (text.find_first_of("eE") != std::string::npos) {
    double v = 0.0;
    if (!ParseDouble(text, &v) || std::abs(v) >= 9.2e18) return false;
    *t_ns = std::llround(v);
    return true;
  }
  // [sign] digits [. digits]: the integer part exactly, the first decimal rounds.
  std::size_t i = 0;
  bool negative = false;
  if (text[i] == '+' || text[i] == '-') {
    negative = text[i] == '-';
    ++i;
  }
  int64_t whole = 0;
  std::size_t digits = 0;
  for (; i < text.size() && std::isdigit(static_cast<unsigned char>(text[i])); ++i, ++digits) {
    if (whole > (std::numeric_limits<int64_t>::max() - 9) / 10) return false;
    whole = whole * 10 + (text[i] - '0');
  }
  if (i < text.size() && text[i] == '.') {
    ++i;
    if (i < text.size() && std::isdigit(static_cast<unsigned char>(text[i])) && text[i] >= '5') {
      ++whole;
    }
    for (; i < text.size() && std::isdigit(static_cast<unsigned char>(text[i])); ++i) ++digits;
  }
  if (i != text.size() || digits == 0) return false;
  *t_ns = negative ? -whole : whole;
  return true;
}

TrajectoryFormat DetectTrajectoryFormat(std::istream& in, const std::string& name) {
  TrajectoryReadReport report;
  LineReader reader(name, &report);
  std::string line;
  while (std::getline(in, line)) {
    reader.Consume(line, true);
    if (reader.have_layout()) return reader.trajectory().format;
  }
  ThrowNoPose(name);
}

Trajectory ReadTrajectory(std::istream& in, const std::string& name, TrajectoryReadReport* report) {
  TrajectoryReadReport local;
  TrajectoryReadReport* r = report != nullptr ? report : &local;
  LineReader reader(name, r);
  std::string line;
  while (std::getline(in, line)) reader.Consume(line, false);
  if (in.bad()) throw InputError(FormatInputError(name, "", "expected a readable file"));
  if (reader.trajectory().empty()) ThrowNoPose(name);
  r->poses = reader.trajectory().size();
  return reader.TakeTrajectory();
}

Trajectory ReadTrajectoryFile(const std::string& path, TrajectoryReadReport* report) {
  std::ifstream in(path, std::ios::binary);  // "\r\n" reaches the reader, which reports it
  if (!in) throw InputError(FormatInputError(path, "", "expected a readable trajectory file"));
  return ReadTrajectory(in, path, report);
}

std::string TrajectoryReadSummary(const TrajectoryReadReport& r) {
  std::ostringstream s;
  s << "read " << r.name << ": " << Plural(r.poses, "pose") << ", format ";
  switch (r.format) {
    case TrajectoryFormat::kTum:
      s << "TUM (t x y z qx qy qz qw)";
      break;
    case TrajectoryFormat::kEuroc:
      s << "EuRoC (t p_xyz q_wxyz)";
      break;
    case TrajectoryFormat::kKitti:
      s << "KITTI";
      break;
  }
  if (r.quaternion_order_from_header) s << " from the header";
  if (r.stamp_unit == StampUnit::kNone) {
    s << ", no stamps (paired by index)";
  } else {
    s << ", stamps in " << (r.stamp_unit == StampUnit::kSeconds ? "seconds" : "nanoseconds") << " ("
      << r.stamp_unit_reason << ")";
  }
  const int kinds = int{r.comma} + int{r.space} + int{r.tab};
  if (kinds == 1) {
    s << ", " << (r.comma ? "comma" : r.space ? "space" : "tab") << "-separated";
  } else if (kinds > 1) {
    s << ", mixed separators (" << (r.comma ? "comma" : "")
      << (r.comma && (r.space || r.tab) ? ", " : "") << (r.space ? "space" : "")
      << (r.space && r.tab ? ", " : "") << (r.tab ? "tab" : "") << ")";
  }
  if (r.columns > 8 && r.format != TrajectoryFormat::kKitti) {
    s << ", " << r.columns << " columns (9-" << r.columns << " ignored)";
  }
  if (r.header_lines > 0) {
    s << ", " << Plural(r.header_lines, "header line");
    if (r.header_rows_without_hash > 0) s << " (" << r.header_rows_without_hash << " without '#')";
  }
  if (r.comment_lines > 0) s << ", " << Plural(r.comment_lines, "comment line");
  if (r.blank_lines > 0) s << ", " << Plural(r.blank_lines, "blank line");
  if (r.crlf_lines > 0) s << ", CRLF line ends";
  if (r.byte_order_mark) s << ", UTF-8 byte order mark";
  if (r.trailing_separator_lines > 0) {
    s << ", trailing separator on " << Plural(r.trailing_separator_lines, "line");
  }
  if (!r.repeated_stamps.empty()) {
    s << ", " << Plural(r.repeated_stamps.size(), "repeated stamp") << " dropped";
  }
  return s.str();
}

std::vector<std::string> TrajectoryReadWarnings(const TrajectoryReadReport& r) {
  std::vector<std::string> warnings;
  const std::size_t n = r.repeated_stamps.size();
  for (std::size_t i = 0; i < std::min(n, kRepeatWarnings); ++i) {
    const RepeatedStamp& p = r.repeated_stamps[i];
    warnings.push_back(r.name + ": line " + std::to_string(p.line) + ": repeated time stamp " +
                       p.stamp + " (first at line " + std::to_string(p.first_line) + "): dropped");
  }
  if (n > kRepeatWarnings) {
    std::string lines;
    for (std::size_t i = kRepeatWarnings; i < n && i < kRepeatWarnings + kRepeatLinesListed; ++i) {
      lines += (i == kRepeatWarnings ? "" : ", ") + std::to_string(r.repeated_stamps[i].line);
    }
    if (n > kRepeatWarnings + kRepeatLinesListed) lines += ", ...";
    warnings.push_back(r.name + ": " + std::to_string(n - kRepeatWarnings) +
                       " more repeated time stamps dropped (lines " + lines + ")");
  }
  return warnings;
}

}  // namespace vilma
