#include "vilma/mapping/from_poses/target_detections.h"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <limits>
#include <set>
#include <sstream>
#include <stdexcept>

#include "vilma/core/error.h"
#include "vilma/core/strict_parse.h"

namespace vilma::mapping {
namespace {

namespace fs = std::filesystem;

std::string Trim(const std::string& s) {
  const std::size_t b = s.find_first_not_of(" \t\r");
  if (b == std::string::npos) return "";
  return s.substr(b, s.find_last_not_of(" \t\r") - b + 1);
}

// The comma-separated fields of data line `line` (blank and '#' lines: empty).
std::vector<std::string> Fields(const std::string& text) {
  std::vector<std::string> out;
  std::stringstream ss(text);
  std::string field;
  while (std::getline(ss, field, ',')) out.push_back(Trim(field));
  return out;
}

// Reads the data rows of a CSV file; `expected_columns` names them in order. Calls row(fields,
// where) for each, where = "FILE: line N".
template <typename RowFunction>
void ReadRows(const std::string& path, const std::vector<std::string>& columns, RowFunction row) {
  std::ifstream in(path);
  if (!in) throw InputError(FormatInputError(path, "", "a readable file"));
  std::string text;
  int line = 0;
  while (std::getline(in, text)) {
    ++line;
    text = Trim(text);
    if (text.empty() || text[0] == '#') continue;
    const std::vector<std::string> fields = Fields(text);
    const std::string where = path + ": line " + std::to_string(line);
    if (fields.size() != columns.size()) {
      std::string names;
      for (const std::string& c : columns) names += (names.empty() ? "" : ",") + c;
      throw InputError(FormatInputError(where, "", std::to_string(columns.size()) +
                                                       " columns (" + names + "), found " +
                                                       std::to_string(fields.size())));
    }
    row(fields, where);
  }
}

double Number(const std::vector<std::string>& fields, std::size_t i, const char* name,
              const std::string& where) {
  try {
    return ParseStrictDouble(fields[i]);
  } catch (const std::invalid_argument&) {
    throw InputError(FormatInputError(where, name, "a finite number, found '" + fields[i] + "'"));
  }
}

int64_t Integer(const std::vector<std::string>& fields, std::size_t i, const char* name,
                const std::string& where, int64_t min, int64_t max) {
  try {
    return ParseStrictInt(fields[i], min, max);
  } catch (const std::invalid_argument& e) {
    throw InputError(FormatInputError(where, name, std::string(e.what()) + ", found '" +
                                                       fields[i] + "'"));
  }
}

}  // namespace

TargetImage ReadTargetImage(const std::string& path, int64_t t_ns) {
  static const std::vector<std::string> kColumns = {
      "ts", "tag_rows", "tag_cols", "tag_size", "tag_spacing", "kp_x",
      "kp_y", "p_x", "p_y", "p_z", "tag_id", "corner_idx"};
  TargetImage image;
  image.t_ns = t_ns;
  std::set<int64_t> seen;
  ReadRows(path, kColumns, [&](const std::vector<std::string>& f, const std::string& where) {
    const int64_t ts = Integer(f, 0, "ts", where, 0, std::numeric_limits<int64_t>::max());
    if (ts != t_ns) {
      throw InputError(FormatInputError(where, "ts", "the stamp of the file name (" +
                                                         std::to_string(t_ns) + "), found " +
                                                         std::to_string(ts)));
    }
    TargetCorner c;
    c.uv = Eigen::Vector2d(Number(f, 5, "kp_x", where), Number(f, 6, "kp_y", where));
    c.p_T = Eigen::Vector3d(Number(f, 7, "p_x", where), Number(f, 8, "p_y", where),
                            Number(f, 9, "p_z", where));
    c.tag_id = static_cast<int>(Integer(f, 10, "tag_id", where, 0, 1'000'000));
    c.corner_index = static_cast<int>(Integer(f, 11, "corner_idx", where, 0, 3));
    if (!seen.insert(c.key()).second) {
      throw InputError(FormatInputError(where, "tag_id, corner_idx",
                                        "each corner once per image, found tag " +
                                            std::to_string(c.tag_id) + " corner " +
                                            std::to_string(c.corner_index) + " again"));
    }
    image.corners.push_back(c);
  });
  return image;
}

std::vector<TargetImage> ReadTargetCamera(const std::string& folder) {
  std::error_code ec;
  if (!fs::is_directory(folder, ec)) {
    throw InputError(FormatInputError(folder, "", "a folder of detection files <ts>.csv"));
  }
  std::vector<std::pair<int64_t, std::string>> files;
  for (const fs::directory_entry& e : fs::directory_iterator(folder)) {
    if (e.path().extension() != ".csv") continue;
    const std::string stem = e.path().stem().string();
    try {
      files.emplace_back(ParseStrictInt(stem, 0), e.path().string());
    } catch (const std::invalid_argument&) {
      throw InputError(FormatInputError(e.path().string(), "file name",
                                        "the image stamp in ns (an integer), found '" + stem + "'"));
    }
  }
  if (files.empty()) throw InputError(FormatInputError(folder, "", "detection files <ts>.csv"));
  std::sort(files.begin(), files.end());
  std::vector<TargetImage> images;
  images.reserve(files.size());
  for (const auto& [t, path] : files) images.push_back(ReadTargetImage(path, t));
  return images;
}

std::vector<ImuSample> ReadTargetImu(const std::string& path) {
  static const std::vector<std::string> kColumns = {"ts", "wx", "wy", "wz", "ax", "ay", "az"};
  std::vector<ImuSample> imu;
  ReadRows(path, kColumns, [&](const std::vector<std::string>& f, const std::string& where) {
    ImuSample s;
    s.t_ns = Integer(f, 0, "ts", where, 0, std::numeric_limits<int64_t>::max());
    if (!imu.empty() && s.t_ns <= imu.back().t_ns) {
      throw InputError(FormatInputError(where, "ts", "stamps increasing row by row, found " +
                                                         std::to_string(s.t_ns) + " after " +
                                                         std::to_string(imu.back().t_ns)));
    }
    s.omega_I = Eigen::Vector3d(Number(f, 1, "wx", where), Number(f, 2, "wy", where),
                                Number(f, 3, "wz", where));
    s.a_I = Eigen::Vector3d(Number(f, 4, "ax", where), Number(f, 5, "ay", where),
                            Number(f, 6, "az", where));
    imu.push_back(s);
  });
  if (imu.size() < 2) throw InputError(FormatInputError(path, "", "at least two IMU samples"));
  return imu;
}

}  // namespace vilma::mapping
