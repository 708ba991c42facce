// The visual-inertial simulator: a world, a session's trajectory, the EuRoC-like sensor rig,
// the IMU stream with ground truth, and rendered camera frames; writes ASL/EuRoC datasets.
#pragma once

#include <cstdint>
#include <iosfwd>
#include <memory>
#include <string>
#include <vector>

#include "vilma/core/asl_dataset.h"
#include "vilma/core/rig.h"
#include "vilma/sim/imu_sim.h"
#include "vilma/sim/renderer.h"
#include "vilma/sim/trajectory.h"
#include "vilma/sim/world.h"

namespace vilma {
namespace sim {

struct SimOptions {
  std::string world = "room";  // preset name (room, room-fast, hall, street) or a world YAML path
  int session = 0;             // sessions share the world and its frame W; other path and lighting
  double seconds = 60.0;       // sequence length [s], including the static start
  uint64_t seed = 1;           // fixes world, trajectories, noise
  bool stereo = false;         // add cam1 (EuRoC cam1 intrinsics and extrinsics)
  double camera_rate_hz = 20.0;
  // Camera time shift of the rig (t_imu = t_cam + offset): frame t_cam shows the world at
  // t_cam + offset. EuRoC's is ~0.
  int64_t camera_time_offset_ns = 0;
  int motion_blur_samples = 1;  // > 1: average this many renders over the exposure
  double exposure_s = 0.004;    // exposure time for motion blur [s]
  double noise_sigma = 2.0;     // pixel noise [grey levels]
  double vignetting = 0.3;      // relative darkening at the corners
  bool session_lighting = true;  // sessions > 0 get another brightness/contrast
  double render_focal_scale = 0.85;  // see RenderOptions
  TrajectoryOptions trajectory;  // duration_s is set from `seconds`
  // Sessions > 0 only. 0: the session draws its own path through the world. > 0: it revisits
  // session 0's path, as session 0 is generated with this length [s] (give session 0's
  // --seconds), with the offsets of `revisit` (GenerateRevisitTrajectory).
  double revisit_seconds = 0.0;
  RevisitOptions revisit;
  ImuSimOptions imu;
  // Which realization of the IMU noise and biases (docs/simulator.md "IMU draws"): 0 = the
  // session's own (random stream ImuSeed(seed, session, 0)), N >= 1 = another one with the same
  // world, path and images (ImuSeed(seed, session, N)).
  int imu_draw = 0;
  // Time of the first sample [ns]; EuRoC-like epoch stamps. Session k starts k days later.
  int64_t start_time_ns = 1600000000000000000;

  std::string Validate() const;
};

// The IMU's random stream: DeriveSeed(seed, 2000 + session) for draw 0 (every world's session-0
// set of one seed shares it), DeriveSeed(DeriveSeed(seed, 2000 + session), draw) for draw >= 1.
uint64_t ImuSeed(uint64_t seed, int session, int draw);

// The EuRoC VI-sensor rig: cam0 (and cam1) intrinsics, radial-tangential distortion and
// T_I_C from EuRoC's sensor.yaml T_BS (the IMU is the body frame), ADIS16448 noise.
SensorRig MakeEurocRig(bool stereo, const ImuNoise& noise = ImuNoise());

struct DatasetSummary {
  int num_frames = 0;        // per camera
  int num_images = 0;        // all cameras
  int num_imu_samples = 0;
  double render_seconds = 0.0;   // wall time spent rendering (one core)
  double total_seconds = 0.0;    // wall time of the whole write
  double frames_per_second() const { return render_seconds > 0 ? num_images / render_seconds : 0; }
  TrajectoryReport trajectory;
};

class Simulator {
 public:
  // Builds the world (textures), the trajectory and the IMU stream. Throws InputError for bad
  // options or world files.
  explicit Simulator(const SimOptions& options);

  const SimOptions& options() const { return options_; }
  const SensorRig& rig() const { return rig_; }
  const World& world() const { return world_; }
  const Trajectory& trajectory() const { return trajectory_; }
  const TrajectoryReport& trajectory_report() const { return trajectory_report_; }
  const ImuSimResult& imu() const { return imu_; }
  int64_t start_time_ns() const { return start_time_ns_; }
  const RenderOptions& render_options() const { return render_options_; }

  int num_frames() const { return num_frames_; }
  int64_t frame_time_ns(int frame_index) const;  // camera clock
  // Camera pose at camera time t_cam_ns (the world at t_cam + time offset).
  Transformation T_W_C(int camera_index, int64_t t_cam_ns) const;
  // Renders frame `frame_index` of camera `camera_index` (CV_8UC1).
  void RenderFrame(int camera_index, int frame_index, cv::Mat* image);

  // Writes the ASL/EuRoC folder (mav0/...), EuRoC sensor.yaml files, `rig.yaml` and
  // `sim.yaml` (the options) into `out_dir`. Progress lines go to `log` if given.
  DatasetSummary WriteDataset(const std::string& out_dir, std::ostream* log = nullptr);

  // The same folder without rendering: mav0/cam0 (cam1) are symbolic links to the image folders
  // of `images_dir` (to their resolved targets), an earlier rendering whose sim.yaml matches
  // these options but for the IMU draw (CheckSameImages in sim_yaml.h); the IMU, ground truth,
  // imu0/sensor.yaml, rig.yaml and sim.yaml (with `images_from:`) are written. Throws
  // InputError naming the file and field when the rendering differs.
  DatasetSummary WriteDatasetWithImagesFrom(const std::string& out_dir,
                                            const std::string& images_dir);

 private:
  // imu0 and ground truth through `writer`, rig.yaml and sim.yaml (`extra` appended).
  void WriteImuAndFiles(AslDatasetWriter* writer, const std::string& out_dir,
                        const std::string& extra) const;

  SimOptions options_;
  World world_;
  SensorRig rig_;
  Trajectory trajectory_;
  TrajectoryReport trajectory_report_;
  ImuSimResult imu_;
  RenderOptions render_options_;
  int64_t start_time_ns_ = 0;
  int num_frames_ = 0;
  std::vector<std::unique_ptr<Renderer>> renderers_;
};

}  // namespace sim
}  // namespace vilma
