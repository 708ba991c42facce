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
//
// With ba_estimate_noise_scales the solve is repeated with the noise components' sigmas rescaled
// by variance component estimation (variance_components.h) until they agree with the residuals
// (on a copy of the map: a failure or a cancel in any solve still leaves it untouched).
#pragma once

#include <array>
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
  // On top of ba_imu_noise_scale: the gyroscope's densities (white noise and random walk)
  // times ba_gyro_noise_scale, the accelerometer's times ba_accel_noise_scale (1: as they are).
  // The real EuRoC IMU's accelerometer disagrees with its datasheet more than its gyroscope
  // (docs/optimization-scale.md).
  double ba_gyro_noise_scale = 1.0;
  double ba_accel_noise_scale = 1.0;
  // Variance component estimation (docs/optimization.md "Noise scales estimated from the
  // data"): after a converged solve, the variance factor of each noise component (keypoint
  // noise; gyroscope and accelerometer white noise and random walk) from its residuals and
  // its redundancy; the components' sigmas rescaled by sqrt(factor) and the problem solved
  // again, until no scale moves by more than ba_noise_scale_tolerance (a scale held at its
  // bound does not count) or after ba_noise_scale_rounds solves. Starts from the scales above;
  // each scale stays within [1/ba_noise_scale_max, ba_noise_scale_max], the IMU's at least
  // ba_noise_scale_imu_min. optvi only.
  bool ba_estimate_noise_scales = false;
  int ba_noise_scale_rounds = 5;            // solves in all (the first with the given noise)
  double ba_noise_scale_tolerance = 0.05;   // |sqrt(factor) - 1| below this: converged
  double ba_noise_scale_max = 30.0;         // bound on each sigma scale, both ways
  // Lower bound on the IMU's four estimated sigma scales (on top of the scales above): 1
  // (default) takes the rig's densities as a floor, as a datasheet is (a real IMU is never
  // better than its datasheet; the simulator's is exactly as declared and its estimates scatter
  // around 1: docs/optimization-scale.md section 6); 0: 1/ba_noise_scale_max as the keypoints'.
  double ba_noise_scale_imu_min = 1.0;
  // Hutchinson probes for the redundancies' traces (the estimate's cost: one sparse solve each).
  int ba_noise_scale_probes = 32;
  // Also rescale the keypoint noise (and with it the robust loss, which is in sigma units);
  // false: the keypoints keep their declared sigma and only the IMU's four components are
  // rescaled (their factors are still relative to the residuals of the whole problem).
  bool ba_noise_scale_visual = true;
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

// Noise components of the problem, in this order (NoiseScales, NoiseFactors): the keypoint
// noise of the reprojection residuals, the gyroscope's and the accelerometer's white noise
// densities, their random walks.
inline constexpr const char* kNoiseComponentNames[5] = {"visual", "gyro_noise", "accel_noise",
                                                        "gyro_walk", "accel_walk"};

// Multipliers of each component's sigma (keypoint sigma_px, IMU density) in a solve.
struct NoiseScales {
  std::array<double, 5> sigma{1.0, 1.0, 1.0, 1.0, 1.0};
};

// One variance component estimate at a converged solution (variance_components.h): per
// component the factor on its variance (1: the weights agree with the residuals), its
// chi² (rᵀ G_k r), redundancy and rows (tr G_k); not estimated (factor 1): no rows, or
// redundancy below 3.
struct NoiseFactors {
  static constexpr int kCount = 5;
  std::array<double, 5> factor{1.0, 1.0, 1.0, 1.0, 1.0};
  std::array<double, 5> chi2{}, redundancy{}, rows{};
  std::array<bool, 5> estimated{};
  int unknowns = 0;
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
  // With ba_estimate_noise_scales: the scales of each solve and the factors estimated after it
  // (one entry per solve; the last solve's scales are the result).
  std::vector<NoiseScales> noise_scales;
  std::vector<NoiseFactors> noise_factors;
  std::string BriefReport() const;
  std::string FullReport() const;
};

// Optimizes the selected missions (empty: all). Throws std::invalid_argument (map unchanged) for
// invalid options, an empty problem, a selected mission without IMU edges (inertial), or a
// non-finite state; Cancelled (map unchanged) when the progress observer asks to stop.
ViOptimizationSummary OptimizeViMap(const ViOptimizationOptions& options, mapstore::VIMap* map,
                                    const std::vector<mapstore::MissionId>& missions = {},
                                    ProgressObserver* progress = nullptr);

// One solve with the noise components scaled by `scales` (on top of the options' IMU scales);
// with `factors`, the variance components are estimated at the solution. OptimizeViMap without
// ba_estimate_noise_scales is SolveViMap with unit scales.
ViOptimizationSummary SolveViMap(const ViOptimizationOptions& options, const NoiseScales& scales,
                                 mapstore::VIMap* map,
                                 const std::vector<mapstore::MissionId>& missions,
                                 ProgressObserver* progress, NoiseFactors* factors);

}  // namespace vilma::mapping
