// optimize_visual_inertial / optvi and optimize_visual / optv (mapping/optimization,
// docs/optimization.md).
#include "vilma/console/command_registry.h"
#include "vilma/mapping/inspection/map_statistics.h"
#include "vilma/mapping/optimization/vi_optimization.h"

namespace vilma::console {
namespace {

struct OptOptions : mapping::ViOptimizationOptions {
  std::string map_mission;  // "" = every mission
};

template <typename O>
Command<O> OptimizationFlags(Command<O> c) {
  return std::move(
      c.Flag("ba_num_iterations", &O::ba_num_iterations, "solver iterations in all")
          .Flag("ba_iterations_per_round", &O::ba_iterations_per_round,
                "iterations between re-integration / outlier rejection / progress")
          .Flag("ba_function_tolerance", &O::ba_function_tolerance,
                "converged when the relative cost change is below this")
          .Flag("ba_robust_loss", &O::ba_robust_loss, "cauchy, huber or none")
          .Flag("ba_robust_loss_scale_sigma", &O::ba_robust_loss_scale_sigma,
                "where the robust loss starts, in sigma of each observation's keypoint noise "
                "(3: 3 px for a 1 px keypoint, 0.45 px for a 0.15 px refined one)")
          .Flag("ba_robust_loss_scale_px", &O::ba_robust_loss_scale_px,
                "> 0: where the robust loss starts in pixels, the same for every observation "
                "(overrides ba_robust_loss_scale_sigma); 0: in sigma")
          .Flag("keypoint_sigma_px", &O::keypoint_sigma_px,
                "keypoint noise [px]; 0: each keypoint's sigma stored in the map, > 0 overrides")
          .Flag("ba_fix_landmarks", &O::ba_fix_landmarks, "hold the landmark positions")
          .Flag("ba_fix_biases", &O::ba_fix_biases, "hold the IMU biases")
          .Flag("ba_fix_extrinsics", &O::ba_fix_extrinsics, "hold the camera extrinsics T_I_C")
          .Flag("ba_imu_noise_scale", &O::ba_imu_noise_scale,
                "multiplies the rig's IMU noise densities and random walks (optvi; 1: as they are)")
          .Flag("ba_gyro_noise_scale", &O::ba_gyro_noise_scale,
                "multiplies the gyroscope's noise density and random walk (optvi; on top of "
                "ba_imu_noise_scale)")
          .Flag("ba_accel_noise_scale", &O::ba_accel_noise_scale,
                "multiplies the accelerometer's noise density and random walk (optvi; on top of "
                "ba_imu_noise_scale)")
          .Flag("ba_estimate_noise_scales", &O::ba_estimate_noise_scales,
                "variance component estimation: rescale the keypoint noise and the four IMU "
                "densities to their residuals and solve again (optvi)")
          .Flag("ba_noise_scale_rounds", &O::ba_noise_scale_rounds,
                "solves in all with ba_estimate_noise_scales")
          .Flag("ba_noise_scale_tolerance", &O::ba_noise_scale_tolerance,
                "noise scales converged when every sqrt(variance factor) is within this of 1")
          .Flag("ba_noise_scale_max", &O::ba_noise_scale_max,
                "bound on each estimated noise scale (both ways)")
          .Flag("ba_noise_scale_imu_min", &O::ba_noise_scale_imu_min,
                "lower bound on the IMU's estimated noise scales (1: the rig's densities as a "
                "floor; 0: 1/ba_noise_scale_max)")
          .Flag("ba_noise_scale_probes", &O::ba_noise_scale_probes,
                "Hutchinson probes of the variance component estimate")
          .Flag("ba_noise_scale_visual", &O::ba_noise_scale_visual,
                "with ba_estimate_noise_scales: rescale the keypoint noise too (false: the IMU's "
                "components only)")
          .Flag("ba_estimate_time_offset", &O::ba_estimate_time_offset,
                "estimate a camera-IMU time offset per camera (optvi)")
          .Flag("ba_estimate_baseframe_tilt", &O::ba_estimate_baseframe_tilt,
                "estimate roll/pitch of unknown baseframes (held landmarks not gravity aligned)")
          .Flag("ba_outlier_rejection", &O::ba_outlier_rejection,
                "drop observations behind the camera or beyond the threshold between rounds")
          .Flag("ba_outlier_threshold_px", &O::ba_outlier_threshold_px,
                "outlier threshold on the reprojection error [px]")
          .Flag("ba_num_threads", &O::ba_num_threads, "solver threads")
          .Flag("ba_linear_solver", &O::ba_linear_solver,
                "sparse_schur, iterative_schur, sparse_normal_cholesky or dense_schur")
          .Flag("ba_initialize_imu_states", &O::ba_initialize_imu_states,
                "first fit velocities and biases to the current poses (optvi)")
          .Flag("evaluate_quality", &O::evaluate_quality, "elq after the optimization")
          .Flag("map_mission", &O::map_mission,
                "mission ids, unique prefixes or names, comma separated (default: all)",
                {"mission"}));
}

void Run(CommandContext& c, const OptOptions& o) {
  const std::vector<mapstore::MissionId> missions =
      mapping::ResolveMissions(c.map(), o.map_mission);
  try {
    c.out() << mapping::OptimizeViMap(o, &c.map(), missions, c.progress()).FullReport();
  } catch (const std::invalid_argument& e) {
    throw CommandError(e.what());
  }
}

void Register(CommandRegistry* registry) {
  registry->Add(OptimizationFlags(Command<OptOptions>("optimize_visual_inertial")
                                      .Alias("optvi")
                                      .Group("optimization")
                                      .Summary("visual-inertial bundle adjustment of the map "
                                               "(reprojection + IMU preintegration, Ceres)")
                                      .Access(MapAccess::kModify))
                    .Run(Run));
  struct VisualOnly : OptOptions {
    VisualOnly() { inertial = false; }
  };
  registry->Add(OptimizationFlags(Command<VisualOnly>("optimize_visual")
                                      .Alias("optv")
                                      .Group("optimization")
                                      .Summary("visual-only bundle adjustment of the map "
                                               "(reprojection terms, Ceres)")
                                      .Access(MapAccess::kModify))
                    .Run([](CommandContext& c, const VisualOnly& o) { Run(c, o); }));
}

}  // namespace
}  // namespace vilma::console

VILMA_CONSOLE_COMMANDS(vilma::console::Register)
