// Options of the ROVIO-style filter (docs/estimator.md). Plain structs with in-class defaults,
// one comment per field, nested into FilterOptions, checked by Validate(). Loaded strictly
// from YAML (config/estimator.yaml documents every key): unknown and missing keys are errors.
// All sizes (feature count, patch size, pyramid levels) are runtime values.
#pragma once

#include <string>

#include "vilma/core/yaml_io.h"
#include "vilma/estimator/feature_detector.h"
#include "vilma/estimator/multilevel_patch.h"

namespace vilma::estimator {

// Moving start: visual-inertial alignment over the first frames (vi_initializer.h,
// docs/estimator.md, "Moving start").
struct DynamicInitOptions {
  bool enabled = true;  // false: a moving start takes roll/pitch from the mean accelerometer
  double window_s = 1.0;           // frames aligned together (the newest this long) [s]
  int max_corners = 150;           // tracked corners (KLT) [count]
  double min_corner_distance_px = 20.0;  // spacing of new corners [px]
  double max_klt_error_px = 1.0;   // forward-backward tracking check [px]
  int min_features = 20;           // features seen in >= 3 frames of the window [count]
  double min_parallax_px = 10.0;   // median rotation-compensated feature motion [px]
  double pixel_sigma = 1.0;        // observation noise of a tracked corner [px]
  double max_rms_px = 1.5;         // accept: RMS of the inlier bearing errors below [px]
  double min_inlier_ratio = 0.8;   // accept: observations within 3 sigma, at least [0..1]
  double max_gravity_error = 1.0;  // accept: | |unconstrained g| - g | below [m/s^2]
  double max_roll_pitch_sigma = 0.02;  // accept: gravity direction std below [rad]
  double gyro_bias_sigma = 0.1;    // prior std of the gyroscope bias [rad/s]
  double timeout_s = 3.0;          // then fall back to the mean accelerometer [s]
  std::string Validate() const;
};

// Initialization from the first IMU samples (docs/estimator.md, "Initialization").
struct InitOptions {
  double window_s = 0.5;  // IMU averaging window before the first frame (half needed) [s]
  // The start is static when the standard deviations of the 50 ms means of the accelerometer
  // and gyroscope over the window are below these (block means ignore vibration).
  double max_static_accel_std = 0.2;  // [m/s^2]
  double max_static_gyro_std = 0.02;  // [rad/s]
  // No initialization while | |mean accelerometer| - g | exceeds this: the mean would not
  // give the gravity direction (strong acceleration, or corrupted samples before a reset).
  double max_gravity_error = 1.0;  // [m/s^2]
  double sigma_velocity_static = 0.02;  // initial velocity std, static start [m/s]
  double sigma_velocity_moving = 1.0;   // initial velocity std, moving start [m/s]
  double sigma_roll_pitch = 0.02;       // initial roll/pitch std [rad]
  double sigma_yaw = 1e-3;              // yaw is unobservable; its std only conditions P [rad]
  double sigma_gyro_bias = 0.01;        // [rad/s]
  double sigma_accel_bias = 0.1;        // [m/s^2]
  double sigma_extrinsic_rotation = 0.01;     // if estimated [rad]
  double sigma_extrinsic_translation = 0.01;  // if estimated [m]
  double sigma_time_offset = 0.005;           // if estimated [s]
  DynamicInitOptions dynamic;
  std::string Validate() const;
};

// Process noise beyond the IMU densities of the rig (IMU noise comes from the rig YAML).
struct ProcessNoiseOptions {
  double bearing = 1e-3;          // feature bearing random walk [rad/sqrt(s)]
  double inverse_depth = 1e-3;    // feature inverse-distance random walk [1/m/sqrt(s)]
  double extrinsic_rotation = 1e-4;     // if estimated [rad/sqrt(s)]
  double extrinsic_translation = 1e-4;  // if estimated [m/sqrt(s)]
  double time_offset = 1e-5;            // if estimated [s/sqrt(s)]
  double imu_noise_scale = 1.0;   // multiplies the rig's IMU densities (model mismatch)
  std::string Validate() const;
};

// Photometric update (ROVIO IJRR 2017, sec. 5).
struct UpdateOptions {
  int max_iterations = 4;            // iterated EKF steps per feature
  double convergence_px = 0.02;      // stop when the pixel moves less [px]
  double intensity_sigma = 6.0;      // photometric noise per patch sample [grey levels]
  double pixel_sigma = 0.5;          // extra pixel noise (model errors) [px]
  double huber_threshold = 15.0;     // Huber weighting of samples above this |r| [grey levels]
  double mahalanobis_threshold = 13.8;  // chi^2 gate (2 DoF, 99.9%) on the aligned pixel
  double max_mean_abs_error = 30.0;  // patch is an outlier above this mean |r| [grey levels]
  int align_iterations = 10;         // patch alignment (outlier check) Gauss-Newton steps
  // A pixel-level error of the feature's template that persists from frame to frame (its
  // placement at extraction) [px]; 0: off. The update takes each frame's error as new, so the
  // variance of this part is counted with the number of updates n made with the template:
  // sigma^2 n at the n-th (docs/estimator.md, "Persistent template errors", session 36).
  double persistent_pixel_sigma = 0.0;
  std::string Validate() const;
};

// Feature management.
struct FeatureOptions {
  int max_features = 25;             // features in the state (preallocated) [count]
  double init_inverse_depth = 0.5;   // new features start at 1/rho = 2 m [1/m]
  double init_inverse_depth_sigma = 0.5;  // std of that guess [1/m]
  // ROVIO's median depth (getMedianDepthParameters): a new feature without a stereo depth starts
  // at the median inverse depth of the tracked features whose depth is known to
  // sigma_rho / rho <= median_depth_max_ratio (ROVIO's maxUncertaintyToDepthRatio), when there
  // are at least median_depth_min_features of them (stereo matches of the same detection
  // included); else at init_inverse_depth. The fixed 2 m
  // is far off in a street (facades 6-25 m): the C2 and C1 predictions of such a feature start
  // tens of pixels off. Sigma stays init_inverse_depth_sigma. false: always init_inverse_depth.
  bool median_depth_init = false;
  double median_depth_max_ratio = 0.3;
  int median_depth_min_features = 3;
  double init_bearing_sigma_px = 1.0;     // std of a new feature's pixel [px]
  int max_failures = 3;              // drop after this many consecutive failed updates
  double min_shi_tomasi = 20.0;      // drop / don't add patches weaker than this
  int detect_below = 20;             // look for new features when fewer are tracked [count]
  double min_inverse_depth = 0.0;    // features behind this are dropped [1/m]
  // Template refresh (ROVIO re-extracts the patch of every tracked feature after each frame):
  // after this many updates with its template, a feature updated in this frame has its patch
  // re-extracted at its updated pixel estimate (0: never, the template of the detection is
  // kept), when the new patch's Shi-Tomasi score is >= min_shi_tomasi and >=
  // refresh_min_relative_score x the old one's (docs/estimator.md, session 36).
  int refresh_patch_every = 0;
  double refresh_min_relative_score = 0.5;
  PatchOptions patch;
  FeatureDetectorOptions detector;
  PhotometricOptions photometric;
  std::string Validate() const;
};

// Divergence detection: a failed check resets the filter (re-initialization).
struct HealthOptions {
  double max_speed = 30.0;             // |v| above this is implausible [m/s]
  double max_position_sigma = 100.0;   // covariance blow-up [m]
  int max_frames_without_features = 20;  // all features lost for this long [frames]
  std::string Validate() const;
};

// Stereo (ROVIO's multi-camera update, docs/estimator.md "Stereo"): every feature is anchored
// in the VIO camera; the photometric update is also applied in the second camera, and a new
// feature's inverse distance comes from a match in the second image where one is found.
struct StereoOptions {
  bool enabled = false;  // use the second camera (off: monocular, as before)
  int camera = 1;        // rig index of the second camera (!= the VIO camera)
  bool update = true;    // photometric update in the second camera too
  // Stereo initialization of new features: the patch is searched along the epipolar line of
  // the second image for inverse distances in [0, max_inverse_depth] (coarse steps of
  // search_step_px), then aligned in 2D; accepted when the alignment converges with a mean
  // |residual| below max_match_error and the pixel lies within max_epipolar_px of the line.
  bool init_depth = true;
  double max_inverse_depth = 5.0;     // nearest searched point: 1/5 = 0.2 m [1/m]
  double search_step_px = 2.0;        // coarse search spacing along the line [px]
  double max_match_error = 15.0;      // [grey levels]
  double max_epipolar_px = 2.0;       // [px]
  double match_pixel_sigma = 0.5;     // std of the matched pixel (sets rho's std) [px]
  double min_inverse_depth_sigma = 0.02;  // floor of a matched feature's rho std [1/m]
  // A match is kept only when no other place along the line aligns with a mean |residual|
  // below this ratio times the match's (0: off). On the simulated room 10 % of the matches
  // without it are false (rho off by up to 40x with a 2 % sigma); 1.3 removes nearly all of
  // them, but the ATE over eight simulated sets was not better with it (docs/estimator.md
  // "False stereo matches and the filter's consistency"), so it is off by default.
  double min_uniqueness_ratio = 0.0;
  // One 4-row iterated update per feature over both cameras instead of a C1 update followed
  // by a separate C2 update: the two alignments of the same template share its model error
  // (docs/estimator-stereo-history.md, "The joint update of both cameras"; over the eight simulated
  // sets the median ATE stereo / mono is 0.59 with it, 0.73 without).
  bool joint_update = true;
  // Correlation [0, 1] of update.pixel_sigma's model error between the C1 and C2 rows of the
  // joint update (0: independent, as two separate updates: median 0.87; 1: 0.64; 0.9: 0.59).
  double model_error_correlation = 0.9;
  // With the joint update: a feature whose C2 alignment fails in this many consecutive frames
  // while it is predicted inside C2's image and its C1 update succeeds is removed (0: never;
  // off by default, one run per set measured): its two cameras disagree (e.g. a depth far too
  // near, which C1 alone does not correct; docs/estimator-stereo-history.md "Street: is the
  // disparity biased?").
  int max_disagreements = 0;
  // A feature with a stereo depth is updated in C1 alone during its first probation_frames
  // accepted updates (0: off); then, if the mean normalized innovation e^T S^-1 e of C1's
  // aligned pixel (2 DoF) over them exceeds probation_max_mean_nis, its depth disagrees with
  // C1's flow and the feature is removed, else the second camera joins its updates
  // (docs/estimator.md, session 36).
  int probation_frames = 0;
  double probation_max_mean_nis = 4.0;
  // A per-feature error of the second camera's alignment relative to the first that persists
  // over the feature's life (a disparity error: another view of the same C1 template; 0: off)
  // [px]. The C1 rows take it as shifted bearing, C2's cannot: taken as white, n frames would
  // pin the depth to a persistent error sqrt(n) x too confidently. Its variance enters the C2
  // rows only (uncorrelated with C1) as s^2 n at the n-th update with the template, as
  // update.persistent_pixel_sigma does for both cameras (docs/estimator.md, session 37).
  double persistent_disparity_sigma = 0.0;
  // With stereo on, the feature slots and the detection threshold replace features.max_features
  // and features.detect_below (0: keep those). Over four IMU draws of four simulated sets, 60 / 48
  // brought street's stereo / mono ATE to 0.75 (with 25 / 20: 1.24) at several times the time
  // per frame; the euroc profile keeps its 40 (docs/estimator.md, session 37).
  int max_features = 60;
  int detect_below = 48;
  // Session 38 (docs/estimator-stereo-diagnosis.md, "More stereo depths"):
  // Prefer matchable features: new features are chosen among the detector's candidates by
  // their stereo match; a candidate whose match fails is skipped, up to this many skips per
  // free slot in one detection (the detector is asked for (1 + N) x the free slots); once they
  // are used up, unmatched candidates fill the slots as without it (0: off).
  int candidates_per_slot = 0;
  // Deferred stereo match: a feature that started without a stereo depth searches C2's
  // epipolar curve again after each of its next N frames (its C1 template warped by the
  // tracked A), until it has a match or a C2 update; a match enters as an EKF update of rho
  // (measurement rho_match, std from match_pixel_sigma, gated by update.mahalanobis_threshold),
  // not as an overwrite of the state (0: off). The default since session 38: over 16 IMU draws
  // street's stereo / mono 0.78 -> 0.73, room-fast -11 %, room-easy -6 %, hall +1 %.
  int deferred_match_frames = 10;
  // The match's local minima of the coarse search aligned before it fails (lowest residual
  // first; StereoMatchOptions::max_candidates) and the alignment's iterations per pyramid stage
  // (0: update.align_iterations). Session 38's look at the "not converged" failures.
  int match_candidates = 3;
  int match_align_iterations = 0;
  std::string Validate() const;
};

struct FilterOptions {
  bool estimate_extrinsics = false;  // refine T_I_C online (else it is fixed from the rig)
  bool estimate_time_offset = false;  // refine the camera-IMU time offset online
  // Observability-constrained propagation of the yaw direction (OC-EKF, propagation.h
  // ConstrainYawNullspace; docs/estimator-stereo-history.md "Stereo and noisy IMUs", session 35):
  // the updates cannot gain information about yaw, which the data do not observe.
  bool yaw_observability_constraint = false;
  InitOptions init;
  ProcessNoiseOptions noise;
  UpdateOptions update;
  FeatureOptions features;
  HealthOptions health;
  StereoOptions stereo;
  // Empty if valid, else "section.field: expectation".
  std::string Validate() const;
};

// Strict loading: unknown keys are errors, an absent key keeps its value in `base` (the
// built-in defaults unless given; docs/design.md "Options files"), and the values must pass
// Validate(); throws InputError naming file, key, expectation.
FilterOptions LoadFilterOptions(const std::string& path, const FilterOptions& base = {});
FilterOptions ParseFilterOptions(const std::string& yaml_text, const std::string& source_name);
FilterOptions ReadFilterOptions(const YamlNode& root, const FilterOptions& base = {});
// The effective options as YAML (same layout as config/estimator.yaml), printed at start.
std::string FilterOptionsToYaml(const FilterOptions& options);

// Built-in option profiles (docs/estimator.md, "Options for real images"), each equal to a
// file in config/ (a test checks it):
//   "default": FilterOptions() = config/estimator.yaml, tuned on the simulated sets;
//   "euroc":   config/estimator_euroc.yaml, for real EuRoC VI-sensor images: feature bearing
//              random walk noise.bearing 0.005 rad/sqrt(s) (not 0.001) and 40 features (not 25).
// Throws InputError naming the profile for an unknown name.
FilterOptions FilterOptionsProfile(const std::string& name);
// The profile names, for help texts and errors: "default, euroc".
std::string FilterOptionsProfileNames();

}  // namespace vilma::estimator
