// ViOptimizationOptions::Validate and the summary's reports (vi_optimization.h).
#include <cmath>
#include <sstream>

#include "vilma/mapping/optimization/vi_optimization.h"

namespace vilma::mapping {

std::string ViOptimizationOptions::Validate() const {
  if (!visual && !inertial) return "visual, inertial: expected at least one kind of term";
  if (ba_num_iterations < 1) return "ba_num_iterations: expected >= 1";
  if (ba_iterations_per_round < 1) return "ba_iterations_per_round: expected >= 1";
  if (!(ba_function_tolerance > 0 && ba_function_tolerance < 1)) {
    return "ba_function_tolerance: expected in (0, 1)";
  }
  if (ba_robust_loss != "huber" && ba_robust_loss != "cauchy" && ba_robust_loss != "none") {
    return "ba_robust_loss: expected huber, cauchy or none";
  }
  if (!(ba_robust_loss_scale_sigma > 0 && std::isfinite(ba_robust_loss_scale_sigma))) {
    return "ba_robust_loss_scale_sigma: expected > 0";
  }
  if (!(ba_robust_loss_scale_px >= 0 && std::isfinite(ba_robust_loss_scale_px))) {
    return "ba_robust_loss_scale_px: expected >= 0 (0: ba_robust_loss_scale_sigma applies)";
  }
  if (!(keypoint_sigma_px >= 0 && std::isfinite(keypoint_sigma_px))) {
    return "keypoint_sigma_px: expected >= 0 (0: each keypoint's own sigma from the map)";
  }
  if (!(ba_imu_noise_scale > 0 && std::isfinite(ba_imu_noise_scale))) {
    return "ba_imu_noise_scale: expected > 0 (1: the rig's IMU densities)";
  }
  if (!(ba_gyro_noise_scale > 0 && std::isfinite(ba_gyro_noise_scale))) {
    return "ba_gyro_noise_scale: expected > 0 (1: the rig's gyroscope densities)";
  }
  if (!(ba_accel_noise_scale > 0 && std::isfinite(ba_accel_noise_scale))) {
    return "ba_accel_noise_scale: expected > 0 (1: the rig's accelerometer densities)";
  }
  if (ba_estimate_noise_scales && !(inertial && visual)) {
    return "ba_estimate_noise_scales: needs inertial and visual terms (optvi)";
  }
  if (ba_noise_scale_rounds < 1) return "ba_noise_scale_rounds: expected >= 1";
  if (!(ba_noise_scale_tolerance > 0 && ba_noise_scale_tolerance < 1)) {
    return "ba_noise_scale_tolerance: expected in (0, 1)";
  }
  if (!(ba_noise_scale_max >= 1 && std::isfinite(ba_noise_scale_max))) {
    return "ba_noise_scale_max: expected >= 1";
  }
  if (!(ba_noise_scale_imu_min >= 0 && ba_noise_scale_imu_min <= ba_noise_scale_max)) {
    return "ba_noise_scale_imu_min: expected in [0, ba_noise_scale_max] (1: the rig's densities "
           "as a floor)";
  }
  if (ba_noise_scale_probes < 1) return "ba_noise_scale_probes: expected >= 1";
  if (!(ba_outlier_threshold_px > 0)) return "ba_outlier_threshold_px: expected > 0";
  if (ba_num_threads < 1) return "ba_num_threads: expected >= 1";
  if (ba_linear_solver != "sparse_schur" && ba_linear_solver != "iterative_schur" &&
      ba_linear_solver != "sparse_normal_cholesky" && ba_linear_solver != "dense_schur") {
    return "ba_linear_solver: expected sparse_schur, iterative_schur, sparse_normal_cholesky or "
           "dense_schur";
  }
  if (ba_estimate_time_offset && !(inertial && visual)) {
    return "ba_estimate_time_offset: needs inertial and visual terms (optvi)";
  }
  if (ba_estimate_baseframe_tilt && !(inertial && ba_fix_landmarks)) {
    return "ba_estimate_baseframe_tilt: needs inertial terms and ba_fix_landmarks";
  }
  std::string problem = preintegration.Validate();
  if (!problem.empty()) return "preintegration." + problem;
  problem = quality.Validate();
  return problem.empty() ? "" : "quality." + problem;
}


std::string ViOptimizationSummary::BriefReport() const {
  std::ostringstream out;
  out << command << ": cost " << initial_cost << " -> " << final_cost << " in " << iterations
      << " iterations (" << rounds << " rounds), reprojection RMSE " << reprojection_rmse_before_px
      << " -> " << reprojection_rmse_after_px << " px, " << total_seconds << " s";
  return out.str();
}

std::string ViOptimizationSummary::FullReport() const {
  std::ostringstream out;
  out << BriefReport() << "\n"
      << "  residuals: reprojection " << reprojection_residuals << ", inertial "
      << inertial_residuals << "; vertices " << vertices << ", landmarks " << landmarks
      << ", clusters " << clusters << "\n"
      << "  solver: " << solve_seconds << " s, "
      << (iterations > 0 ? 1000.0 * solve_seconds / iterations : 0.0) << " ms per iteration; "
      << termination << "\n"
      << "  outlier observations removed " << outlier_observations << ", IMU re-integrations "
      << reintegrations << "; good landmarks " << good_landmarks_before << " -> "
      << good_landmarks_after << "\n";
  for (const MissionChange& c : missions) {
    out << "  mission " << c.mission.Hex().substr(0, 8) << ": " << c.vertices
        << " vertices moved mean " << c.mean_shift_m << " m (max " << c.max_shift_m << "), "
        << c.mean_rotation_deg << " deg (max " << c.max_rotation_deg << ")\n";
  }
  for (const CameraCalibrationChange& c : cameras) {
    const Transformation d = c.T_I_C_before.inverse() * c.T_I_C_after;
    out << "  mission " << c.mission.Hex().substr(0, 8) << " camera " << c.camera
        << ": T_I_C moved " << 1000.0 * d.translation().norm() << " mm, "
        << AngleBetween(c.T_I_C_before.rotation(), c.T_I_C_after.rotation()) * 180.0 / M_PI
        << " deg; time offset " << 1000.0 * c.time_offset_before_s << " -> "
        << 1000.0 * c.time_offset_after_s << " ms\n";
  }
  for (std::size_t i = 0; i < noise_factors.size(); ++i) {
    const NoiseFactors& f = noise_factors[i];
    out << "  noise scales, solve " << i + 1 << ":";
    for (int k = 0; k < NoiseFactors::kCount; ++k) {
      out << " " << kNoiseComponentNames[k] << " " << noise_scales[i].sigma[k];
    }
    out << "\n    variance factors (chi2 / redundancy):";
    for (int k = 0; k < NoiseFactors::kCount; ++k) {
      out << " " << kNoiseComponentNames[k] << " ";
      if (f.estimated[k]) {
        out << f.factor[k] << " (" << f.chi2[k] << " / " << f.redundancy[k] << ")";
      } else {
        out << "- (redundancy " << f.redundancy[k] << ")";
      }
    }
    out << "\n";
  }
  if (baseframe_tilt_change_deg > 0.0) {
    out << "  baseframe tilt changed by " << baseframe_tilt_change_deg << " deg\n";
  }
  return out.str();
}


}  // namespace vilma::mapping
