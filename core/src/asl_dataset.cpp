#include "vilma/core/asl_dataset.h"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <opencv2/imgcodecs.hpp>
#include <sstream>
#include <stdexcept>

#include "vilma/core/error.h"

namespace vilma {
namespace fs = std::filesystem;

namespace {

std::string Trim(const std::string& s) {
  const auto begin = s.find_first_not_of(" \t\r\n");
  if (begin == std::string::npos) return "";
  const auto end = s.find_last_not_of(" \t\r\n");
  return s.substr(begin, end - begin + 1);
}

// One data row of an ASL CSV file, split at commas, with its position for error messages.
struct CsvRow {
  int line_number = 0;
  std::vector<std::string> fields;
};

// Reads the data rows of an ASL CSV file (lines starting with '#' and blank lines skipped).
std::vector<CsvRow> ReadCsv(const std::string& path) {
  std::ifstream in(path);
  if (!in) throw InputError(FormatInputError(path, "", "cannot open the file"));
  std::vector<CsvRow> rows;
  std::string line;
  int line_number = 0;
  while (std::getline(in, line)) {
    ++line_number;
    line = Trim(line);
    if (line.empty() || line[0] == '#') continue;
    CsvRow row;
    row.line_number = line_number;
    std::stringstream ss(line);
    std::string field;
    while (std::getline(ss, field, ',')) row.fields.push_back(Trim(field));
    rows.push_back(std::move(row));
  }
  return rows;
}

std::string Where(const std::string& path, const CsvRow& row) {
  return path + ":" + std::to_string(row.line_number);
}

void CheckColumns(const std::string& path, const CsvRow& row, std::size_t expected,
                  const std::string& layout) {
  if (row.fields.size() != expected) {
    throw InputError(FormatInputError(
        Where(path, row), "",
        "expected " + std::to_string(expected) + " comma-separated columns (" + layout +
            "), got " + std::to_string(row.fields.size())));
  }
}

int64_t ParseTimestamp(const std::string& path, const CsvRow& row, std::size_t column) {
  const std::string& s = row.fields[column];
  try {
    std::size_t used = 0;
    const long long value = std::stoll(s, &used);
    if (used == s.size() && value >= 0) return value;
  } catch (const std::exception&) {
  }
  throw InputError(FormatInputError(Where(path, row), "column " + std::to_string(column + 1),
                                    "a timestamp in whole nanoseconds >= 0, got '" + s + "'"));
}

double ParseNumber(const std::string& path, const CsvRow& row, std::size_t column) {
  const std::string& s = row.fields[column];
  try {
    std::size_t used = 0;
    const double value = std::stod(s, &used);
    if (used == s.size() && std::isfinite(value)) return value;
  } catch (const std::exception&) {
  }
  throw InputError(FormatInputError(Where(path, row), "column " + std::to_string(column + 1),
                                    "a finite number, got '" + s + "'"));
}

Eigen::Vector3d ParseVector3(const std::string& path, const CsvRow& row, std::size_t first) {
  return Eigen::Vector3d(ParseNumber(path, row, first), ParseNumber(path, row, first + 1),
                         ParseNumber(path, row, first + 2));
}

// Sorts by time and removes duplicate stamps; says what it changed in `warnings`.
template <typename T>
void SortAndDeduplicate(std::vector<T>* items, const std::string& path,
                        std::vector<std::string>* warnings) {
  const bool sorted = std::is_sorted(items->begin(), items->end(),
                                     [](const T& a, const T& b) { return a.t_ns < b.t_ns; });
  if (!sorted) {
    std::stable_sort(items->begin(), items->end(),
                     [](const T& a, const T& b) { return a.t_ns < b.t_ns; });
    warnings->push_back(path + ": rows are not in time order; sorted");
  }
  const std::size_t before = items->size();
  items->erase(std::unique(items->begin(), items->end(),
                           [](const T& a, const T& b) { return a.t_ns == b.t_ns; }),
               items->end());
  if (items->size() != before) {
    warnings->push_back(path + ": " + std::to_string(before - items->size()) +
                        " rows repeat an earlier timestamp; kept the first");
  }
}

std::string FormatNumber(double x) {
  char buffer[32];
  std::snprintf(buffer, sizeof(buffer), "%.10g", x);
  return buffer;
}

}  // namespace

AslDataset AslDataset::Open(const std::string& root) {
  const fs::path p(root);
  AslDataset dataset;
  if (fs::is_directory(p / "mav0")) {
    dataset.mav0_dir_ = (p / "mav0").string();
  } else if (fs::is_directory(p) && (fs::exists(p / "imu0") || fs::exists(p / "cam0"))) {
    dataset.mav0_dir_ = p.string();
  } else {
    throw InputError(FormatInputError(root, "", "an ASL/EuRoC dataset folder containing mav0/"));
  }
  const fs::path mav0(dataset.mav0_dir_);

  // Cameras: cam0, cam1, ... in numeric order.
  std::vector<std::pair<int, fs::path>> camera_dirs;
  for (const auto& entry : fs::directory_iterator(mav0)) {
    const std::string name = entry.path().filename().string();
    if (!entry.is_directory() || name.rfind("cam", 0) != 0 || name.size() == 3) continue;
    if (!std::all_of(name.begin() + 3, name.end(), ::isdigit)) continue;
    camera_dirs.emplace_back(std::stoi(name.substr(3)), entry.path());
  }
  std::sort(camera_dirs.begin(), camera_dirs.end());
  for (const auto& [index, dir] : camera_dirs) {
    (void)index;
    const std::string csv = (dir / "data.csv").string();
    AslCamera camera;
    camera.name = dir.filename().string();
    std::size_t missing = 0;
    std::string first_missing;
    for (const CsvRow& row : ReadCsv(csv)) {
      CheckColumns(csv, row, 2, "timestamp [ns], filename");
      CameraFrame frame;
      frame.t_ns = ParseTimestamp(csv, row, 0);
      const fs::path image = dir / "data" / row.fields[1];
      if (!fs::exists(image)) {
        if (missing++ == 0) first_missing = row.fields[1];
        continue;
      }
      frame.image_path = image.string();
      camera.frames.push_back(frame);
    }
    if (missing > 0) {
      dataset.warnings_.push_back(csv + ": " + std::to_string(missing) +
                                  " rows name images that do not exist (first: " +
                                  first_missing + "); skipped them");
    }
    SortAndDeduplicate(&camera.frames, csv, &dataset.warnings_);
    dataset.cameras_.push_back(std::move(camera));
  }

  const fs::path imu_csv = mav0 / "imu0" / "data.csv";
  if (fs::exists(imu_csv)) {
    const std::string path = imu_csv.string();
    for (const CsvRow& row : ReadCsv(path)) {
      CheckColumns(path, row, 7, "timestamp [ns], w_x, w_y, w_z [rad/s], a_x, a_y, a_z [m/s^2]");
      ImuSample s;
      s.t_ns = ParseTimestamp(path, row, 0);
      s.omega_I = ParseVector3(path, row, 1);
      s.a_I = ParseVector3(path, row, 4);
      dataset.imu_.push_back(s);
    }
    SortAndDeduplicate(&dataset.imu_, path, &dataset.warnings_);
  }

  const fs::path gt_csv = mav0 / "state_groundtruth_estimate0" / "data.csv";
  if (fs::exists(gt_csv)) {
    const std::string path = gt_csv.string();
    for (const CsvRow& row : ReadCsv(path)) {
      if (row.fields.size() != 8 && row.fields.size() != 17) {
        CheckColumns(path, row, 17,
                     "timestamp [ns], p xyz [m], q wxyz, v xyz [m/s], b_w xyz [rad/s], "
                     "b_a xyz [m/s^2]; or the first 8 of these");
      }
      GroundTruthState s;
      s.t_ns = ParseTimestamp(path, row, 0);
      s.p_W_I = ParseVector3(path, row, 1);
      const Eigen::Quaterniond q(ParseNumber(path, row, 4), ParseNumber(path, row, 5),
                                 ParseNumber(path, row, 6), ParseNumber(path, row, 7));
      if (std::abs(q.norm() - 1.0) > 1e-3) {
        throw InputError(FormatInputError(Where(path, row), "columns 5-8",
                                          "a unit quaternion (w, x, y, z), norm is " +
                                              std::to_string(q.norm())));
      }
      s.q_W_I = q.normalized();
      if (row.fields.size() == 17) {
        s.v_W = ParseVector3(path, row, 8);
        s.b_g = ParseVector3(path, row, 11);
        s.b_a = ParseVector3(path, row, 14);
      }
      dataset.ground_truth_.push_back(s);
    }
    SortAndDeduplicate(&dataset.ground_truth_, path, &dataset.warnings_);
  }
  return dataset;
}

cv::Mat AslDataset::LoadImage(const std::string& path, bool unchanged) {
  cv::Mat image = cv::imread(path, unchanged ? cv::IMREAD_UNCHANGED : cv::IMREAD_GRAYSCALE);
  if (image.empty()) {
    throw InputError(FormatInputError(path, "", "a readable image file (PNG, JPEG, ...)"));
  }
  return image;
}

AslDatasetWriter::AslDatasetWriter(const std::string& root, int num_cameras)
    : mav0_dir_((fs::path(root) / "mav0").string()),
      camera_stamps_(static_cast<std::size_t>(num_cameras)) {
  std::error_code ec;
  for (int i = 0; i < num_cameras; ++i) {
    fs::create_directories(fs::path(mav0_dir_) / ("cam" + std::to_string(i)) / "data", ec);
    if (ec) throw InputError(FormatInputError(mav0_dir_, "", "a writable folder: " + ec.message()));
  }
  fs::create_directories(fs::path(mav0_dir_) / "imu0", ec);
  fs::create_directories(fs::path(mav0_dir_) / "state_groundtruth_estimate0", ec);
  if (ec) throw InputError(FormatInputError(mav0_dir_, "", "a writable folder: " + ec.message()));
}

void AslDatasetWriter::AddImage(int camera_index, int64_t t_ns, const cv::Mat& image) {
  if (camera_index < 0 || camera_index >= static_cast<int>(camera_stamps_.size())) {
    throw std::out_of_range("AslDatasetWriter::AddImage: no camera " +
                            std::to_string(camera_index));
  }
  std::vector<uchar> png;
  if (!cv::imencode(".png", image, png)) {
    throw InputError(FormatInputError(mav0_dir_, "", "an image that PNG can encode"));
  }
  const fs::path path = fs::path(mav0_dir_) / ("cam" + std::to_string(camera_index)) / "data" /
                        (std::to_string(t_ns) + ".png");
  // Images are not fsynced one by one: the dataset only becomes valid when Finish() writes the
  // CSV files that list them, atomically.
  std::ofstream out(path, std::ios::binary);
  out.write(reinterpret_cast<const char*>(png.data()), static_cast<std::streamsize>(png.size()));
  if (!out) throw InputError(FormatInputError(path.string(), "", "a writable file"));
  camera_stamps_[static_cast<std::size_t>(camera_index)].push_back(t_ns);
}

void AslDatasetWriter::AddImu(const ImuSample& sample) { imu_.push_back(sample); }

void AslDatasetWriter::AddGroundTruth(const GroundTruthState& state) {
  ground_truth_.push_back(state);
}

void AslDatasetWriter::Finish() {
  for (std::size_t i = 0; i < camera_stamps_.size(); ++i) {
    std::string csv = "#timestamp [ns],filename\n";
    for (const int64_t t : camera_stamps_[i]) {
      csv += std::to_string(t) + "," + std::to_string(t) + ".png\n";
    }
    WriteFileAtomically(
        (fs::path(mav0_dir_) / ("cam" + std::to_string(i)) / "data.csv").string(), csv);
  }
  std::string imu =
      "#timestamp [ns],w_RS_S_x [rad s^-1],w_RS_S_y [rad s^-1],w_RS_S_z [rad s^-1],"
      "a_RS_S_x [m s^-2],a_RS_S_y [m s^-2],a_RS_S_z [m s^-2]\n";
  for (const ImuSample& s : imu_) {
    imu += std::to_string(s.t_ns);
    for (int k = 0; k < 3; ++k) imu += "," + FormatNumber(s.omega_I[k]);
    for (int k = 0; k < 3; ++k) imu += "," + FormatNumber(s.a_I[k]);
    imu += "\n";
  }
  WriteFileAtomically((fs::path(mav0_dir_) / "imu0" / "data.csv").string(), imu);

  if (!ground_truth_.empty()) {
    std::string gt =
        "#timestamp [ns], p_RS_R_x [m], p_RS_R_y [m], p_RS_R_z [m], q_RS_w [], q_RS_x [], "
        "q_RS_y [], q_RS_z [], v_RS_R_x [m s^-1], v_RS_R_y [m s^-1], v_RS_R_z [m s^-1], "
        "b_w_RS_S_x [rad s^-1], b_w_RS_S_y [rad s^-1], b_w_RS_S_z [rad s^-1], "
        "b_a_RS_S_x [m s^-2], b_a_RS_S_y [m s^-2], b_a_RS_S_z [m s^-2]\n";
    for (const GroundTruthState& s : ground_truth_) {
      gt += std::to_string(s.t_ns);
      for (int k = 0; k < 3; ++k) gt += "," + FormatNumber(s.p_W_I[k]);
      gt += "," + FormatNumber(s.q_W_I.w()) + "," + FormatNumber(s.q_W_I.x()) + "," +
            FormatNumber(s.q_W_I.y()) + "," + FormatNumber(s.q_W_I.z());
      for (int k = 0; k < 3; ++k) gt += "," + FormatNumber(s.v_W[k]);
      for (int k = 0; k < 3; ++k) gt += "," + FormatNumber(s.b_g[k]);
      for (int k = 0; k < 3; ++k) gt += "," + FormatNumber(s.b_a[k]);
      gt += "\n";
    }
    WriteFileAtomically(
        (fs::path(mav0_dir_) / "state_groundtruth_estimate0" / "data.csv").string(), gt);
  }
}

std::vector<AslEvent> ArrivalOrder(const AslDataset& dataset, const std::vector<int>& cameras,
                                   int64_t t_begin_ns, int64_t t_end_ns) {
  const auto in_range = [&](int64_t t) { return t >= t_begin_ns && t <= t_end_ns; };
  std::vector<AslEvent> events;
  const std::vector<ImuSample>& imu = dataset.imu();
  for (std::size_t i = 0; i < imu.size(); ++i) {
    if (in_range(imu[i].t_ns)) events.push_back({imu[i].t_ns, -1, i});
  }
  for (int c : cameras) {
    if (c < 0 || c >= static_cast<int>(dataset.cameras().size())) {
      throw std::out_of_range("ArrivalOrder: camera " + std::to_string(c) + " of " +
                              std::to_string(dataset.cameras().size()));
    }
    const std::vector<CameraFrame>& frames = dataset.cameras()[static_cast<std::size_t>(c)].frames;
    for (std::size_t i = 0; i < frames.size(); ++i) {
      if (in_range(frames[i].t_ns)) events.push_back({frames[i].t_ns, c, i});
    }
  }
  // Equal stamps: the IMU (-1) first, then the cameras by index.
  std::stable_sort(events.begin(), events.end(), [](const AslEvent& a, const AslEvent& b) {
    return a.t_ns != b.t_ns ? a.t_ns < b.t_ns : a.stream < b.stream;
  });
  return events;
}

}  // namespace vilma
