#include "vilma/sim/simulator.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <iomanip>
#include <ostream>
#include <sstream>

#include "vilma/core/asl_dataset.h"
#include "vilma/core/error.h"
#include "vilma/core/time.h"
#include "vilma/sim/random.h"
#include "vilma/sim/sim_yaml.h"

namespace vilma {
namespace sim {

std::string SimOptions::Validate() const {
  if (world.empty()) return "world: expected a preset name or a world YAML path";
  if (session < 0 || session > 1000) return "session: expected 0 .. 1000";
  if (!(seconds > 0.5 && seconds <= 3600.0)) return "seconds: expected 0.5 .. 3600";
  if (!(camera_rate_hz > 0.0 && camera_rate_hz <= 1000.0)) return "camera_rate_hz: expected (0, 1000]";
  if (motion_blur_samples < 1 || motion_blur_samples > 64) return "motion_blur_samples: expected 1 .. 64";
  if (!(exposure_s >= 0.0 && exposure_s < 1.0 / camera_rate_hz)) return "exposure_s: expected 0 .. frame period";
  if (std::llabs(camera_time_offset_ns) > 100000000) return "camera_time_offset_ns: expected |offset| <= 0.1 s";
  if (!(noise_sigma >= 0.0)) return "noise_sigma: expected >= 0";
  if (!(vignetting >= 0.0 && vignetting < 1.0)) return "vignetting: expected 0 .. <1";
  if (imu_draw < 0) return "imu_draw: expected >= 0";
  TrajectoryOptions t = trajectory;
  t.duration_s = seconds;
  t.static_start_s = std::min(t.static_start_s, 0.5 * seconds);
  std::string e = t.Validate();
  if (!e.empty()) return "trajectory." + e;
  if (revisit_seconds != 0.0) {
    if (session == 0) return "revisit_seconds: expected 0 for session 0 (it is the reference)";
    if (!(revisit_seconds > 0.5 && revisit_seconds <= 3600.0))
      return "revisit_seconds: expected 0 (off) or 0.5 .. 3600";
    e = revisit.Validate();
    if (!e.empty()) return "revisit." + e;
  }
  e = imu.Validate();
  if (!e.empty()) return "imu." + e;
  return "";
}

uint64_t ImuSeed(uint64_t seed, int session, int draw) {
  const uint64_t own = DeriveSeed(seed, 2000 + static_cast<uint64_t>(session));
  return draw == 0 ? own : DeriveSeed(own, static_cast<uint64_t>(draw));
}

SensorRig MakeEurocRig(bool stereo, const ImuNoise& noise) {
  SensorRig rig;
  rig.imu.name = "imu0";
  rig.imu.rate_hz = 200.0;
  rig.imu.noise = noise;
  // EuRoC V1_01 cam0/cam1 sensor.yaml (T_BS with B = IMU).
  Eigen::Matrix4d T0, T1;
  T0 << 0.0148655429818, -0.999880929698, 0.00414029679422, -0.0216401454975,  //
      0.999557249008, 0.0149672133247, 0.025715529948, -0.064676986768,        //
      -0.0257744366974, 0.00375618835797, 0.999660727178, 0.00981073058949,    //
      0.0, 0.0, 0.0, 1.0;
  T1 << 0.0125552670891, -0.999755099723, 0.0182237714554, -0.0198435579556,  //
      0.999598781151, 0.0130119051815, 0.0251588363115, 0.0453689425024,      //
      -0.0253898008918, 0.0179005838253, 0.999517347078, 0.00786212447038,    //
      0.0, 0.0, 0.0, 1.0;
  auto make = [](const std::string& name, const Eigen::Matrix4d& T, const Eigen::Vector4d& k,
                 const Eigen::Vector4d& d) {
    CameraConfig c;
    c.name = name;
    c.rate_hz = 20.0;
    Eigen::VectorXd coeffs = d;
    c.camera = Camera(752, 480, k, DistortionModel::kRadTan, coeffs);
    // Orthonormalize the (slightly non-orthonormal) calibrated rotation.
    Eigen::Quaterniond q(Eigen::Matrix3d(T.topLeftCorner<3, 3>()));
    c.T_I_C = Transformation(q.normalized(), T.topRightCorner<3, 1>());
    return c;
  };
  rig.cameras.push_back(make("cam0", T0, Eigen::Vector4d(458.654, 457.296, 367.215, 248.375),
                             Eigen::Vector4d(-0.28340811, 0.07395907, 0.00019359, 1.76187114e-05)));
  if (stereo) {
    rig.cameras.push_back(make("cam1", T1, Eigen::Vector4d(457.587, 456.134, 379.999, 255.238),
                               Eigen::Vector4d(-0.28368365, 0.07451284, -0.00010473, -3.55590700e-05)));
  }
  return rig;
}

Simulator::Simulator(const SimOptions& options) : options_(options) {
  const std::string error = options.Validate();
  if (!error.empty()) throw InputError(FormatInputError("simulator options", "", error));
  if (!IsPresetName(options.world) && !std::ifstream(options.world).good()) {
    throw InputError(FormatInputError(options.world, "world",
                                      "expected a preset (room, room-fast, hall, street) or a readable "
                                      "world YAML file"));
  }
  world_ = IsPresetName(options.world) ? MakePresetWorld(options.world, options.seed)
                                       : LoadWorldYaml(options.world, options.seed);
  world_.GenerateTextures();
  rig_ = MakeEurocRig(options.stereo, options.imu.noise);
  for (CameraConfig& c : rig_.cameras) {
    c.rate_hz = options.camera_rate_hz;
    c.time_offset_ns = options.camera_time_offset_ns;
  }
  rig_.imu.rate_hz = options.imu.rate_hz;
  rig_.imu.gravity_magnitude = options.imu.gravity_magnitude;

  TrajectoryOptions topt = options.trajectory;
  topt.duration_s = options.seconds;
  // Short sequences keep at most half of their length static.
  topt.static_start_s = std::min(topt.static_start_s, 0.5 * options.seconds);
  if (options.revisit_seconds > 0.0) {
    // Session 0's path exactly as `vilma-sim --session 0 --seconds revisit_seconds` draws it.
    TrajectoryOptions reference_options = options.trajectory;
    reference_options.duration_s = options.revisit_seconds;
    reference_options.static_start_s =
        std::min(reference_options.static_start_s, 0.5 * options.revisit_seconds);
    const Trajectory reference =
        GenerateTrajectory(world_, reference_options, DeriveSeed(options.seed, 1000));
    trajectory_ = GenerateRevisitTrajectory(world_, reference, topt, options.revisit,
                                            DeriveSeed(options.seed, 1000 + options.session),
                                            &trajectory_report_);
  } else {
    trajectory_ = GenerateTrajectory(world_, topt, DeriveSeed(options.seed, 1000 + options.session),
                                     &trajectory_report_);
  }
  start_time_ns_ = options.start_time_ns + options.session * 86400LL * kNanosecondsPerSecond;
  Rng imu_rng(ImuSeed(options.seed, options.session, options.imu_draw));
  imu_ = SimulateImu(trajectory_, start_time_ns_, options.seconds, options.imu, &imu_rng);

  render_options_.noise_sigma = options.noise_sigma;
  render_options_.vignetting = options.vignetting;
  render_options_.render_focal_scale = options.render_focal_scale;
  if (options.session > 0 && options.session_lighting) {
    // Another time of day / lamp setting: brightness and contrast change.
    Rng light(DeriveSeed(options.seed, 3000 + options.session));
    render_options_.gain = light.Uniform(0.65, 1.3);
    render_options_.offset = light.Uniform(-15.0, 15.0);
  }
  for (const CameraConfig& c : rig_.cameras) {
    renderers_.push_back(std::make_unique<Renderer>(world_, c.camera, render_options_));
  }
  // Frames whose exposure lies inside the trajectory.
  const double period = 1.0 / options.camera_rate_hz;
  num_frames_ = static_cast<int>(std::floor(options.seconds / period + 1e-9)) + 1;
}

int64_t Simulator::frame_time_ns(int frame_index) const {
  return start_time_ns_ + std::llround(frame_index * 1e9 / options_.camera_rate_hz);
}

Transformation Simulator::T_W_C(int camera_index, int64_t t_cam_ns) const {
  const int64_t t_imu_ns = t_cam_ns + rig_.cameras[camera_index].time_offset_ns;
  const TrajectoryState s = trajectory_.Evaluate(NsToSeconds(t_imu_ns - start_time_ns_));
  return s.T_W_I * rig_.cameras[camera_index].T_I_C;
}

void Simulator::RenderFrame(int camera_index, int frame_index, cv::Mat* image) {
  const int64_t t_ns = frame_time_ns(frame_index);
  std::vector<Transformation> poses;
  const int n = options_.motion_blur_samples;
  if (n <= 1) {
    poses.push_back(T_W_C(camera_index, t_ns));
  } else {
    // Uniform samples over the exposure centred on the stamp.
    for (int k = 0; k < n; ++k) {
      const double dt = options_.exposure_s * ((k + 0.5) / n - 0.5);
      poses.push_back(T_W_C(camera_index, t_ns + std::llround(dt * 1e9)));
    }
  }
  const uint64_t noise_seed =
      DeriveSeed(DeriveSeed(options_.seed, 4000 + options_.session), frame_index * 16 + camera_index);
  renderers_[camera_index]->Render(poses, noise_seed, image);
}

DatasetSummary Simulator::WriteDataset(const std::string& out_dir, std::ostream* log) {
  using Clock = std::chrono::steady_clock;
  const auto t_start = Clock::now();
  DatasetSummary summary;
  summary.trajectory = trajectory_report_;
  const int num_cameras = static_cast<int>(rig_.cameras.size());
  AslDatasetWriter writer(out_dir, num_cameras);
  cv::Mat image;
  double render_s = 0.0;
  for (int i = 0; i < num_frames_; ++i) {
    for (int c = 0; c < num_cameras; ++c) {
      const auto t0 = Clock::now();
      RenderFrame(c, i, &image);
      render_s += std::chrono::duration<double>(Clock::now() - t0).count();
      writer.AddImage(c, frame_time_ns(i), image);
      ++summary.num_images;
    }
    if (log && (i % 200 == 0 || i + 1 == num_frames_)) {
      *log << "frame " << i + 1 << "/" << num_frames_ << "\n" << std::flush;
    }
  }
  WriteEurocSensorYamls(rig_, writer.mav0_dir());
  WriteImuAndFiles(&writer, out_dir, "");
  summary.num_frames = num_frames_;
  summary.num_imu_samples = static_cast<int>(imu_.samples.size());
  summary.render_seconds = render_s;
  summary.total_seconds = std::chrono::duration<double>(Clock::now() - t_start).count();
  return summary;
}

void Simulator::WriteImuAndFiles(AslDatasetWriter* writer, const std::string& out_dir,
                                 const std::string& extra) const {
  for (const ImuSample& s : imu_.samples) writer->AddImu(s);
  for (const GroundTruthState& g : imu_.ground_truth) writer->AddGroundTruth(g);
  writer->Finish();
  SaveSensorRig(rig_, out_dir + "/rig.yaml");
  std::ostringstream info;
  info << std::setprecision(17);
  info << "# vilma-sim parameters of this dataset (regenerate with the same values)\n"
       << "world: " << options_.world << "\n"
       << "world_name: " << world_.name << "\n"
       << "session: " << options_.session << "\n"
       << "seconds: " << options_.seconds << "\n"
       << "seed: " << options_.seed << "\n"
       << "revisit_seconds: " << options_.revisit_seconds << "\n"
       << "stereo: " << (options_.stereo ? "true" : "false") << "\n"
       << "camera_time_offset_ns: " << options_.camera_time_offset_ns << "\n"
       << "motion_blur_samples: " << options_.motion_blur_samples << "\n"
       << "noise_sigma: " << options_.noise_sigma << "\n"
       << "lighting_gain: " << render_options_.gain << "\n"
       << "lighting_offset: " << render_options_.offset << "\n"
       << "frames: " << num_frames_ << "\n"
       << "imu_samples: " << imu_.samples.size() << "\n";
  // Written only for another draw, so that the sets' own sim.yaml stay as before.
  if (options_.imu_draw != 0) info << "imu_draw: " << options_.imu_draw << "\n";
  info << extra;
  WriteFileAtomically(out_dir + "/sim.yaml", info.str());
}

DatasetSummary Simulator::WriteDatasetWithImagesFrom(const std::string& out_dir,
                                                     const std::string& images_dir) {
  namespace fs = std::filesystem;
  using Clock = std::chrono::steady_clock;
  const auto t_start = Clock::now();
  const std::string error = CheckSameImages(images_dir, options_, num_frames_);
  if (!error.empty()) throw InputError(error);
  std::error_code ec;
  if (fs::exists(out_dir) && fs::equivalent(out_dir, images_dir, ec)) {
    throw InputError(FormatInputError(out_dir, "", "expected another folder than --images-from's"));
  }
  const int num_cameras = static_cast<int>(rig_.cameras.size());
  std::vector<fs::path> targets;
  for (int c = 0; c < num_cameras; ++c) {
    targets.push_back(fs::canonical(fs::path(images_dir) / "mav0" / ("cam" + std::to_string(c))));
  }
  // IMU and ground truth only; the cameras are linked, so their sensor.yaml are the source's.
  AslDatasetWriter writer(out_dir, 0);
  SensorRig imu_rig = rig_;
  imu_rig.cameras.clear();
  WriteEurocSensorYamls(imu_rig, writer.mav0_dir());
  for (int c = 0; c < num_cameras; ++c) {
    const fs::path link = fs::path(writer.mav0_dir()) / ("cam" + std::to_string(c));
    fs::remove_all(link);  // an earlier rendering's folder, or a link (not followed)
    fs::create_directory_symlink(targets[c], link);
  }
  WriteImuAndFiles(&writer, out_dir,
                   "images_from: " + fs::absolute(images_dir).lexically_normal().string() + "\n");
  DatasetSummary summary;
  summary.trajectory = trajectory_report_;
  summary.num_frames = num_frames_;
  summary.num_images = 0;
  summary.num_imu_samples = static_cast<int>(imu_.samples.size());
  summary.total_seconds = std::chrono::duration<double>(Clock::now() - t_start).count();
  return summary;
}

}  // namespace sim
}  // namespace vilma
