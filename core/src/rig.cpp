#include "vilma/core/rig.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <filesystem>
#include <iomanip>
#include <sstream>

#include "vilma/core/asl_dataset.h"
#include "vilma/core/error.h"
#include "vilma/core/yaml_io.h"

namespace vilma {
namespace fs = std::filesystem;

namespace {

// Reads a 4x4 homogeneous transform and checks that it is a rigid transformation.
Transformation ReadTransform(const YamlNode& node, const std::string& key) {
  const Eigen::Matrix4d T = node.GetMatrix(key, 4, 4);
  const Eigen::Matrix3d R = T.topLeftCorner<3, 3>();
  if (!IsRotationMatrix(R, 1e-6)) {
    std::ostringstream what;
    what << "a rotation block that is orthonormal with determinant +1 (|R^T R - I|max = "
         << (R.transpose() * R - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff()
         << ", det = " << R.determinant() << ")";
    node.Fail(key, what.str());
  }
  if ((T.row(3) - Eigen::RowVector4d(0, 0, 0, 1)).cwiseAbs().maxCoeff() > 1e-9) {
    node.Fail(key, "a last row of 0 0 0 1");
  }
  return Transformation(R, Eigen::Vector3d(T.topRightCorner<3, 1>()));
}

// EuRoC/Kalibr matrices are maps {rows, cols, data}.
Transformation ReadEurocTransform(const YamlNode& node, const std::string& key) {
  const YamlNode m = node.Child(key);
  if (m.Get<int>("rows") != 4 || m.Get<int>("cols") != 4) m.Fail("", "a 4x4 matrix");
  return ReadTransform(m, "data");
}

double ReadPositive(const YamlNode& node, const std::string& key) {
  const double value = node.Get<double>(key);
  if (!(value > 0.0)) node.Fail(key, "a number > 0, got " + std::to_string(value));
  return value;
}

double ReadNonNegative(const YamlNode& node, const std::string& key) {
  const double value = node.Get<double>(key);
  if (value < 0.0) node.Fail(key, "a number >= 0, got " + std::to_string(value));
  return value;
}

ImuNoise ReadImuNoise(const YamlNode& node) {
  ImuNoise noise;
  noise.gyroscope_noise_density = ReadNonNegative(node, "gyroscope_noise_density");
  noise.gyroscope_random_walk = ReadNonNegative(node, "gyroscope_random_walk");
  noise.accelerometer_noise_density = ReadNonNegative(node, "accelerometer_noise_density");
  noise.accelerometer_random_walk = ReadNonNegative(node, "accelerometer_random_walk");
  return noise;
}

Camera ReadCameraModel(const YamlNode& node, const std::string& model_key) {
  const Eigen::VectorXd resolution = node.GetVector("resolution", 2);
  const Eigen::VectorXd intrinsics = node.GetVector("intrinsics", 4);
  const std::string model_name = node.Get<std::string>(model_key);
  DistortionModel model;
  if (!ParseDistortionModel(model_name, &model)) {
    node.Fail(model_key, "one of none, radtan (radial-tangential), equidistant, got '" +
                             model_name + "'");
  }
  const Eigen::VectorXd coefficients =
      node.GetVector("distortion_coefficients", NumDistortionCoefficients(model));
  // The bound keeps the conversion to int defined (found by fuzz_rig_yaml: 1.1e18 px).
  constexpr double kMaxResolution = 65535.0;
  for (int i = 0; i < 2; ++i) {
    if (!(resolution[i] >= 1.0 && resolution[i] <= kMaxResolution) ||
        resolution[i] != std::floor(resolution[i])) {
      node.Fail("resolution", "two whole numbers from 1 to 65535 (width, height)");
    }
  }
  Camera camera(static_cast<int>(resolution[0]), static_cast<int>(resolution[1]), intrinsics,
                model, coefficients);
  const std::string problem = camera.Validate();
  if (!problem.empty()) node.Fail("intrinsics", "a valid camera model: " + problem);
  return camera;
}

// Shortest of %.15g .. %.17g that reads back to exactly x (so files stay readable and a
// save/load round trip is lossless).
std::string FormatDouble(double x) {
  char buffer[40];
  for (int precision = 15; precision <= 17; ++precision) {
    std::snprintf(buffer, sizeof(buffer), "%.*g", precision, x);
    if (std::strtod(buffer, nullptr) == x) break;
  }
  return buffer;
}

std::string FormatVector(const Eigen::VectorXd& v) {
  std::string out = "[";
  for (Eigen::Index i = 0; i < v.size(); ++i) {
    if (i > 0) out += ", ";
    out += FormatDouble(v[i]);
  }
  return out + "]";
}

std::string FormatMatrixRows(const Eigen::Matrix4d& T, const std::string& indent) {
  std::string out;
  for (int r = 0; r < 4; ++r) {
    out += indent + "- " + FormatVector(T.row(r).transpose()) + "\n";
  }
  return out;
}

std::string FindMav0(const std::string& root) {
  const fs::path p(root);
  if (fs::is_directory(p / "mav0")) return (p / "mav0").string();
  if (p.filename() == "mav0" && fs::is_directory(p)) return p.string();
  throw InputError(FormatInputError(root, "", "a dataset folder that contains mav0/"));
}

}  // namespace

std::string SensorRig::Validate() const {
  if (cameras.empty()) return "cameras: expected at least one camera";
  const std::string imu_problem = imu.noise.Validate();
  if (!imu_problem.empty()) return "imu." + imu_problem;
  if (!(imu.rate_hz > 0.0)) return "imu.rate_hz: expected a number > 0";
  if (!(imu.gravity_magnitude > 0.0)) return "imu.gravity_magnitude: expected a number > 0";
  for (std::size_t i = 0; i < cameras.size(); ++i) {
    const std::string where = "cameras[" + std::to_string(i) + "]";
    const std::string problem = cameras[i].camera.Validate();
    if (!problem.empty()) return where + ": " + problem;
    if (!(cameras[i].rate_hz > 0.0)) return where + ".rate_hz: expected a number > 0";
    if (!IsRotationMatrix(cameras[i].T_I_C.rotationMatrix())) {
      return where + ".T_I_C: expected a rotation";
    }
    for (std::size_t j = 0; j < i; ++j) {
      if (cameras[j].name == cameras[i].name) return where + ".name: expected a unique name";
    }
  }
  return "";
}

int SensorRig::CameraIndex(const std::string& name) const {
  for (std::size_t i = 0; i < cameras.size(); ++i) {
    if (cameras[i].name == name) return static_cast<int>(i);
  }
  return -1;
}

namespace {

SensorRig ParseSensorRigNode(const YamlNode& root) {
  if (!root.IsMap()) root.Fail("", "a map with the keys imu and cameras");
  SensorRig rig;

  const YamlNode imu = root.Child("imu");
  rig.imu.name = imu.GetOr<std::string>("name", "imu0");
  rig.imu.rate_hz = ReadPositive(imu, "rate_hz");
  rig.imu.noise = ReadImuNoise(imu);
  rig.imu.gravity_magnitude = imu.GetOr<double>("gravity_magnitude", kDefaultGravityMagnitude);
  if (!(rig.imu.gravity_magnitude > 0.0)) imu.Fail("gravity_magnitude", "a number > 0");
  imu.CheckNoUnknownKeys();

  const YamlNode cameras = root.Child("cameras");
  const std::vector<YamlNode> elements = cameras.Elements();
  if (elements.empty()) cameras.Fail("", "at least one camera");
  for (const YamlNode& c : elements) {
    CameraConfig config;
    config.name = c.Get<std::string>("name");
    config.rate_hz = ReadPositive(c, "rate_hz");
    config.camera = ReadCameraModel(c, "distortion_model");
    config.T_I_C = ReadTransform(c, "T_I_C");
    config.time_offset_ns = c.GetOr<int64_t>("time_offset_ns", 0);
    c.CheckNoUnknownKeys();
    if (rig.CameraIndex(config.name) >= 0) c.Fail("name", "a unique camera name");
    rig.cameras.push_back(config);
  }
  root.CheckNoUnknownKeys();
  return rig;
}

}  // namespace

SensorRig ParseSensorRig(const std::string& yaml_text, const std::string& source_name) {
  return ParseSensorRigNode(YamlNode::LoadString(yaml_text, source_name));
}

SensorRig LoadSensorRig(const std::string& path) {
  return ParseSensorRigNode(YamlNode::LoadFile(path));
}

std::string SensorRigToYaml(const SensorRig& rig) {
  std::ostringstream y;
  y << "# vilma sensor rig (docs/formats.md). T_I_C: camera frame C in the IMU frame I,\n"
    << "# p_I = T_I_C * p_C, row-major 4x4. time_offset_ns: t_imu = t_cam + offset.\n";
  y << "imu:\n"
    << "  name: " << rig.imu.name << "\n"
    << "  rate_hz: " << FormatDouble(rig.imu.rate_hz) << "\n"
    << "  gyroscope_noise_density: " << FormatDouble(rig.imu.noise.gyroscope_noise_density)
    << "      # [rad/s/sqrt(Hz)]\n"
    << "  gyroscope_random_walk: " << FormatDouble(rig.imu.noise.gyroscope_random_walk)
    << "        # [rad/s^2/sqrt(Hz)]\n"
    << "  accelerometer_noise_density: "
    << FormatDouble(rig.imu.noise.accelerometer_noise_density) << "  # [m/s^2/sqrt(Hz)]\n"
    << "  accelerometer_random_walk: " << FormatDouble(rig.imu.noise.accelerometer_random_walk)
    << "    # [m/s^3/sqrt(Hz)]\n"
    << "  gravity_magnitude: " << FormatDouble(rig.imu.gravity_magnitude) << "  # [m/s^2]\n";
  y << "cameras:\n";
  for (const CameraConfig& c : rig.cameras) {
    y << "  - name: " << c.name << "\n"
      << "    rate_hz: " << FormatDouble(c.rate_hz) << "\n"
      << "    resolution: [" << c.camera.width() << ", " << c.camera.height() << "]\n"
      << "    intrinsics: " << FormatVector(c.camera.intrinsics()) << "  # fx, fy, cx, cy [px]\n"
      << "    distortion_model: " << ToString(c.camera.distortion_model()) << "\n"
      << "    distortion_coefficients: " << FormatVector(c.camera.distortion_coefficients())
      << "\n"
      << "    T_I_C:\n"
      << FormatMatrixRows(c.T_I_C.matrix(), "      ")
      << "    time_offset_ns: " << c.time_offset_ns << "\n";
  }
  return y.str();
}

void SaveSensorRig(const SensorRig& rig, const std::string& path) {
  WriteFileAtomically(path, SensorRigToYaml(rig));
}

SensorRig ImportEurocRig(const std::string& dataset_root) {
  const std::string mav0 = FindMav0(dataset_root);
  SensorRig rig;

  const std::string imu_path = (fs::path(mav0) / "imu0" / "sensor.yaml").string();
  const YamlNode imu = YamlNode::LoadFile(imu_path);
  const Transformation T_B_I = ReadEurocTransform(imu, "T_BS");
  rig.imu.name = "imu0";
  rig.imu.rate_hz = ReadPositive(imu, "rate_hz");
  rig.imu.noise = ReadImuNoise(imu);

  std::vector<fs::path> camera_dirs;
  for (const auto& entry : fs::directory_iterator(mav0)) {
    const std::string name = entry.path().filename().string();
    if (entry.is_directory() && name.rfind("cam", 0) == 0 &&
        fs::exists(entry.path() / "sensor.yaml")) {
      camera_dirs.push_back(entry.path());
    }
  }
  std::sort(camera_dirs.begin(), camera_dirs.end());
  if (camera_dirs.empty()) {
    throw InputError(FormatInputError(mav0, "", "at least one cam<i>/sensor.yaml"));
  }
  for (const fs::path& dir : camera_dirs) {
    const YamlNode cam = YamlNode::LoadFile((dir / "sensor.yaml").string());
    const std::string model = cam.GetOr<std::string>("camera_model", "pinhole");
    if (model != "pinhole") cam.Fail("camera_model", "pinhole, got '" + model + "'");
    CameraConfig config;
    config.name = dir.filename().string();
    config.rate_hz = ReadPositive(cam, "rate_hz");
    config.camera = ReadCameraModel(cam, "distortion_model");
    config.T_I_C = T_B_I.inverse() * ReadEurocTransform(cam, "T_BS");
    // Kalibr's camchain stores the time shift; EuRoC sensor.yaml files do not.
    const double timeshift_s = cam.GetOr<double>("timeshift_cam_imu", 0.0);
    config.time_offset_ns = static_cast<int64_t>(std::llround(timeshift_s * 1e9));
    rig.cameras.push_back(config);
  }
  const std::string problem = rig.Validate();
  if (!problem.empty()) throw InputError(FormatInputError(mav0, "", problem));
  return rig;
}

void WriteEurocSensorYamls(const SensorRig& rig, const std::string& mav0_dir) {
  auto format_T_BS = [](const Eigen::Matrix4d& T) {
    std::string out = "T_BS:\n  cols: 4\n  rows: 4\n  data: [";
    for (int r = 0; r < 4; ++r) {
      for (int c = 0; c < 4; ++c) {
        out += FormatDouble(T(r, c));
        if (r * 4 + c < 15) out += (c == 3 ? ",\n         " : ", ");
      }
    }
    return out + "]\n";
  };
  for (std::size_t i = 0; i < rig.cameras.size(); ++i) {
    const CameraConfig& c = rig.cameras[i];
    std::ostringstream y;
    y << "%YAML:1.0\n"
      << "sensor_type: camera\n"
      << "comment: " << c.name << " (written by vilma)\n"
      << format_T_BS(c.T_I_C.matrix())  // body frame B = IMU frame I
      << "rate_hz: " << FormatDouble(c.rate_hz) << "\n"
      << "resolution: [" << c.camera.width() << ", " << c.camera.height() << "]\n"
      << "camera_model: pinhole\n"
      << "intrinsics: " << FormatVector(c.camera.intrinsics()) << " #fu, fv, cu, cv\n"
      << "distortion_model: "
      << (c.camera.distortion_model() == DistortionModel::kRadTan
              ? "radial-tangential"
              : ToString(c.camera.distortion_model()))
      << "\n"
      << "distortion_coefficients: " << FormatVector(c.camera.distortion_coefficients())
      << "\n";
    if (c.time_offset_ns != 0) {
      y << "timeshift_cam_imu: " << FormatDouble(c.time_offset_ns * 1e-9) << "\n";
    }
    const fs::path dir = fs::path(mav0_dir) / ("cam" + std::to_string(i));
    fs::create_directories(dir);
    WriteFileAtomically((dir / "sensor.yaml").string(), y.str());
  }
  std::ostringstream y;
  y << "%YAML:1.0\n"
    << "sensor_type: imu\n"
    << "comment: " << rig.imu.name << " (written by vilma)\n"
    << format_T_BS(Eigen::Matrix4d::Identity()) << "rate_hz: " << FormatDouble(rig.imu.rate_hz)
    << "\n"
    << "gyroscope_noise_density: " << FormatDouble(rig.imu.noise.gyroscope_noise_density)
    << "     # [ rad / s / sqrt(Hz) ]\n"
    << "gyroscope_random_walk: " << FormatDouble(rig.imu.noise.gyroscope_random_walk)
    << "       # [ rad / s^2 / sqrt(Hz) ]\n"
    << "accelerometer_noise_density: "
    << FormatDouble(rig.imu.noise.accelerometer_noise_density) << "  # [ m / s^2 / sqrt(Hz) ]\n"
    << "accelerometer_random_walk: " << FormatDouble(rig.imu.noise.accelerometer_random_walk)
    << "    # [ m / s^3 / sqrt(Hz) ]\n";
  const fs::path dir = fs::path(mav0_dir) / "imu0";
  fs::create_directories(dir);
  WriteFileAtomically((dir / "sensor.yaml").string(), y.str());
}

}  // namespace vilma
