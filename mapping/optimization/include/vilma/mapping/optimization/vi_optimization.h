// Visual-inertial batch optimization of a VI-map (maplab's VIWLS: optimize_visual_inertial /
// optvi, and visual only: optimize_visual / optv; docs/optimization.md).
//
// Problem: the reprojection residual (reprojection_residual.h) of every observation of every
// good landmark stored in the selected missions (observers of other missions enter with their
// poses held), whitened by its keypoint's sigma, robust loss at k sigma (or at a scale in
// pixels); with `inertial`, the inertial residual (inertial_residual.h) of every IMU edge
// between consecutive vertices, from its raw samples.
// Unknowns: vertex poses T_M_I, velocities and biases (inertial), landmark positions p_G;
// baseframes T_G_M and camera extrinsics T_I_C are held (extrinsics freed by an option).
//
// Gauge (docs/optimization.md "Gauge"): the missions are grouped into clusters that share
// landmarks; in each cluster one mission anchors it (the first with a known baseframe, else the
// first): with inertial terms the position and the yaw of its first vertex are held (the four
// directions VI cannot observe; gravity fixes roll and pitch), visual only its first vertex's
// pose and the distance to the vertex farthest from it (the scale: 7 directions).
//
// With inertial terms the velocities and biases are first fitted to the current poses (poses and
// landmarks held), so that a map with poor bias estimates does not start with IMU residuals
// that dwarf the rest. Then solve in rounds of ba_iterations_per_round Levenberg-Marquardt iterations (Ceres,
// SPARSE_SCHUR with landmarks eliminated by default); between rounds: IMU edges whose bias moved
// far are re-integrated (imu_preintegration.h), observations behind their camera or beyond
// ba_outlier_threshold_px are dropped (outlier rejection, maplab's default), progress is
// reported (a safe point: Ctrl-C cancels there). Only after the last round is the map written:
// a failure or a cancel leaves it untouched. Then landmarks are re-evaluated (elq rules).
#pragma once

#include <cstddef>
#include <string>
#include <vector>

#include "vilma/core/geometry.h"
#include "vilma/core/progress.h"
#include "vilma/mapping/map_builder_options.h"
#include "vilma/mapping/optimization/imu_preintegration.h"
#include "vilma/mapstore/vi_map.h"

namespace vilma::mapping {

struct ViOptimizationOptions {
  bool visual = true;    // reprojection terms
  bool inertial = true;  // IMU terms (false: optv)
  int ba_num_iterations = 30;       // solver iterations in all rounds together
  int ba_iterations_per_round = 3;  // then re-integration, outlier rejection, progress
  // Stop when a round's relative cost change falls below this (Ceres' function_tolerance).
  double ba_function_tolerance = 1e-6;
  // cauchy, huber or none. Cauchy (default since 2026-11-27, Huber before): its influence
  // falls off beyond the scale, so the tail of slid patches of refined keypoints (up to ~30
  // sigma) weighs little; Huber keeps a constant influence there (docs/optimization.md).
  std::string ba_robust_loss = "cauchy";
  // Where the robust loss turns robust, in units of each observation's keypoint sigma (on the
  // whitened residual): k sigma, i.e. 3 px for a 1 px detector keypoint and 0.45 px for a
  // 0.15 px refined one at the default 3 (maplab's 3 sigma). Used when
  // ba_robust_loss_scale_px is 0.
  double ba_robust_loss_scale_sigma = 3.0;
  // > 0: the scale in pixels instead, the same for every observation whatever its sigma
  // (scale_px / sigma in whitened units); 0 (default): ba_robust_loss_scale_sigma. On maps
  // whose keypoints are all at 1 px both give the same loss (the scale before 2026-11-27 was
  // 3 px).
  double ba_robust_loss_scale_px = 0.0;
  // Keypoint noise that whitens the reprojection residuals [px]: 0 (default) each
  // observation's own sigma_px from the map (mapstore::Keypoint; 1 px in maps that do not
  // record it); > 0 overrides every observation's.
  double keypoint_sigma_px = 0.0;
  // Landmark positions held. They then fix the frame G themselves, so no vertex is held for
  // the gauge (a calibration target's corners: docs/optimization.md "Target calibration").
  bool ba_fix_landmarks = false;
  bool ba_fix_biases = false;      // biases held (velocities stay free)
  // Multiplies the rig's four IMU densities (white noise and random walk of gyroscope and
  // accelerometer) in the inertial residuals' covariance, as the VIO's noise.imu_noise_scale:
  // for an IMU whose real errors (vibration on a MAV) exceed its datasheet densities. 1
  // (default): the rig's densities as they are. On the real EuRoC moving slice the datasheet
  // densities make optvi trust the IMU's unmodelled errors (docs/optimization-scale.md).
  double ba_imu_noise_scale = 1.0;
  bool ba_fix_extrinsics = true;   // camera extrinsics T_I_C held
  // A camera-IMU time offset per mission camera (time_offset_residual.h): how far the image's
  // exposure lies after its vertex time [s], from 0. Needs inertial and visual terms (the
  // pose is carried over the offset by the vertex's velocity and the gyroscope's rate).
  bool ba_estimate_time_offset = false;
  // The tilt (roll, pitch) of the baseframe T_G_M of missions whose baseframe is not known:
  // for a map whose G is fixed by held landmarks that are not gravity aligned (a calibration
  // target). Needs ba_fix_landmarks and inertial terms.
  bool ba_estimate_baseframe_tilt = false;
  bool ba_outlier_rejection = true;
  double ba_outlier_threshold_px = 10.0;  // drop observations with a larger error [px]
  // Solver threads. 1 (default): bit-identical results run after run (the deterministic
  // offline rule); more threads reduce the Schur complement in a varying order, equal to
  // round-off only, for ~8 % less time on 2 cores (docs/optimization.md).
  int ba_num_threads = 1;
  // sparse_schur (landmarks eliminated, SuiteSparse), iterative_schur (SCHUR_JACOBI, for maps
  // whose reduced camera matrix does not fit), sparse_normal_cholesky, dense_schur (tiny maps).
  std::string ba_linear_solver = "sparse_schur";
  PreintegrationOptions preintegration;
  // Before the bundle adjustment: velocities and biases fitted to the current trajectory with
  // poses and landmarks held (inertial terms only, re-integrating as the biases settle).
  bool ba_initialize_imu_states = true;
  bool evaluate_quality = true;      // elq after the optimization
  LandmarkQualityOptions quality;
  std::string Validate() const;
};

struct MissionChange {
  mapstore::MissionId mission;
  std::size_t vertices = 0;
  double mean_shift_m = 0.0, max_shift_m = 0.0;    // vertex positions in G
  double mean_rotation_deg = 0.0, max_rotation_deg = 0.0;
};

// A mission camera's calibration before and after (when extrinsics or time offsets were free).
struct CameraCalibrationChange {
  mapstore::MissionId mission;
  uint32_t camera = 0;
  Transformation T_I_C_before, T_I_C_after;
  // The rig's time_offset_ns plus the estimated offset [s] (equal without the estimate).
  double time_offset_before_s = 0.0, time_offset_after_s = 0.0;
};

struct ViOptimizationSummary {
  std::string command;  // "optvi" or "optv"
  std::size_t vertices = 0, landmarks = 0;
  std::size_t reprojection_residuals = 0, inertial_residuals = 0;
  std::size_t clusters = 0;
  double initial_cost = 0.0, final_cost = 0.0;
  int iterations = 0, rounds = 0;
  double solve_seconds = 0.0, total_seconds = 0.0;
  double reprojection_rmse_before_px = 0.0, reprojection_rmse_after_px = 0.0;
  std::size_t outlier_observations = 0;
  std::size_t reintegrations = 0;
  std::string termination;  // Ceres' last termination type and message
  std::vector<MissionChange> missions;
  std::vector<CameraCalibrationChange> cameras;  // with free extrinsics or time offsets
  double baseframe_tilt_change_deg = 0.0;        // largest, with ba_estimate_baseframe_tilt
  std::size_t good_landmarks_before = 0, good_landmarks_after = 0;
  std::string BriefReport() const;
  std::string FullReport() const;
};

// Optimizes the selected missions (empty: all). Throws std::invalid_argument (map unchanged) for
// invalid options, an empty problem, a selected mission without IMU edges (inertial), or a
// non-finite state; Cancelled (map unchanged) when the progress observer asks to stop.
ViOptimizationSummary OptimizeViMap(const ViOptimizationOptions& options, mapstore::VIMap* map,
                                    const std::vector<mapstore::MissionId>& missions = {},
                                    ProgressObserver* progress = nullptr);

}  // namespace vilma::mapping
