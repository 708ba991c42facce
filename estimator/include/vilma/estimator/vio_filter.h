// The ROVIO-style visual-inertial filter (Bloesch et al., IJRR 2017): robocentric features
// with bearing + inverse distance in an iterated EKF, IMU propagation per sample, and one
// iterated photometric update per feature and frame. docs/estimator.md has the equations.
//
// Single-threaded and deterministic: the same sequence of AddImu / AddImage calls gives
// bit-identical states. Time: IMU clock in ns; an image stamped t_cam was taken at
// t_imu = t_cam + time_offset_ns (rig).
#pragma once

#include <Eigen/Core>
#include <array>
#include <cstdint>
#include <opencv2/core.hpp>
#include <string>
#include <utility>
#include <vector>

#include "vilma/core/geometry.h"
#include "vilma/core/imu.h"
#include "vilma/core/rig.h"
#include "vilma/estimator/filter_options.h"
#include "vilma/estimator/feature_detector.h"
#include "vilma/estimator/filter_state.h"
#include "vilma/estimator/image_pyramid.h"
#include "vilma/estimator/multilevel_patch.h"
#include "vilma/estimator/propagation.h"
#include "vilma/estimator/stereo.h"
#include "vilma/estimator/vi_initializer.h"

namespace vilma::estimator {

// What happened on one frame.
struct FrameResult {
  bool pose_valid = false;      // the filter is initialized and the pose below is its estimate
  int64_t t_ns = 0;             // IMU clock [ns]
  Transformation T_M_I;
  int num_features = 0;         // active after the frame
  int num_updated = 0;          // features whose update was accepted
  int num_rejected = 0;         // gated out / failed alignment
  int num_added = 0;
  int num_stereo_updated = 0;   // stereo: updates accepted in the second camera
  int num_stereo_initialized = 0;  // stereo: new features with rho from a stereo match
  bool initialized_now = false;
  bool reset = false;           // a health check failed; the filter re-initializes
  std::string reset_reason;
};

// Counters over the whole run (for the status channel and the runner's summary).
struct FilterStats {
  int64_t frames = 0;
  int64_t imu_samples = 0;
  int64_t imu_duplicates = 0;     // same or earlier time stamp as the previous: dropped
  int64_t imu_gaps = 0;           // spacing above 5 nominal periods: integrated across
  int64_t frames_without_imu = 0; // frames before enough IMU for initialization
  int64_t resets = 0;
  int64_t static_starts = 0;      // initializations classified static / moving
  int64_t moving_starts = 0;      // = dynamic_starts + fallback_starts
  int64_t dynamic_starts = 0;     // moving start by visual-inertial alignment
  int64_t fallback_starts = 0;    // moving start from the mean accelerometer (alignment off or
                                  // timed out: roll/pitch biased by the acceleration)
  int64_t given_starts = 0;       // StartFrom() states used
  InitializerStats dynamic_init;  // alignment attempts and their rejections
  int64_t updates = 0;
  int64_t rejections = 0;
  int64_t stereo_updates = 0;      // accepted updates in the second camera
  int64_t stereo_rejections = 0;   // tried there, gated out / failed
  int64_t stereo_matches = 0;      // new features with rho from a stereo match
  int64_t stereo_match_failures = 0;  // new features left at features.init_inverse_depth
  int64_t stereo_disagreement_removals = 0;  // removed after stereo.max_disagreements
  int64_t probation_removals = 0;  // stereo.probation_frames: depth disagreed with C1's flow
  int64_t probation_passes = 0;    // ... agreed: the second camera joined
  // features.median_depth_init: new features that started at the tracked features' median
  // inverse depth (before any stereo match of theirs).
  int64_t median_depth_inits = 0;
  int64_t patch_refreshes = 0;     // features.refresh_patch_every: templates re-extracted
  int64_t patch_refresh_rejections = 0;  // ... not re-extracted (outside, or score too low)
  // Features that started without a stereo depth and later took an accepted update in the
  // second camera (joint or alone), and the sum of their ages (accepted updates) at the first.
  int64_t unmatched_taking_c2 = 0;
  int64_t unmatched_c2_updates_before = 0;
  // stereo.candidates_per_slot: detector candidates passed over for want of a stereo match.
  int64_t stereo_candidates_skipped = 0;
  // stereo.deferred_match_frames: later matches applied as an update of rho, matches gated
  // out (rho too far from the filter's), tries without a match.
  int64_t deferred_matches = 0;
  int64_t deferred_match_gated = 0;
  int64_t deferred_match_failures = 0;
  // stereo_match_failures by reason, indexed by StereoMatchFailure (index 0 unused).
  std::array<int64_t, kNumStereoMatchFailures> stereo_match_failure_reasons{};
};

// A start from a known state (ground truth or a previous run: the usual way to evaluate VIO),
// in the filter's frame M (gravity along -z, g from the rig).
struct GivenState {
  int64_t t_ns = 0;  // IMU clock; the filter starts at the first frame at or after it
  Eigen::Quaterniond q_M_I = Eigen::Quaterniond::Identity();
  Eigen::Vector3d p_M_I = Eigen::Vector3d::Zero();  // [m]
  Eigen::Vector3d v_M = Eigen::Vector3d::Zero();    // [m/s]
  Eigen::Vector3d b_g = Eigen::Vector3d::Zero();    // [rad/s]
  Eigen::Vector3d b_a = Eigen::Vector3d::Zero();    // [m/s^2]
  // Standard deviations of the start (how far the given state is to be trusted).
  double sigma_velocity = 0.05;     // [m/s]
  double sigma_roll_pitch = 0.005;  // [rad]
  double sigma_yaw = 1e-3;          // [rad]
  double sigma_gyro_bias = 0.005;   // [rad/s]
  double sigma_accel_bias = 0.05;   // [m/s^2]
  // Empty if valid, else "field: expectation".
  std::string Validate() const;
};

class VioFilter {
 public:
  // Uses camera `camera_index` of the rig (with options.stereo.enabled also camera
  // options.stereo.camera). Throws InputError if options or rig are invalid.
  VioFilter(const SensorRig& rig, int camera_index, const FilterOptions& options);

  // IMU samples in time order (duplicates and out-of-order samples are dropped and counted).
  void AddImu(const ImuSample& sample);
  // One 8-bit grayscale image stamped in the camera clock. Initializes on the first frame
  // that has enough IMU data before it.
  FrameResult AddImage(int64_t t_cam_ns, const cv::Mat& image_gray8);
  // Stereo (options.stereo.enabled): the VIO camera's image and the second camera's image of
  // the same (hardware-synchronized) frame; the second stamp is taken to be the first's.
  FrameResult AddImage(int64_t t_cam_ns, const cv::Mat& image_gray8, const cv::Mat& second_gray8);
  // Makes the next frame that would pass the health checks fail them with `reason` instead:
  // the same reset as a failed check (FrameResult::reset, re-initialization from the last
  // pose). For fault injection and tests (vilma-estimatord --fault-reset-filter-at).
  void RequestReset(const std::string& reason) { requested_reset_ = reason; }
  // Starts (or restarts) the filter from `state` instead of the IMU-based initialization: the
  // first frame at or after state.t_ns initializes, with the state carried to the frame time by
  // the buffered IMU. Throws InputError if the state is invalid.
  void StartFrom(const GivenState& state);

  bool initialized() const { return initialized_; }
  const FilterState& state() const { return x_; }
  const Eigen::MatrixXd& covariance() const { return P_; }
  const FilterStats& stats() const { return stats_; }
  Transformation T_M_I() const { return Transformation(x_.q_M_I, x_.p_M_I); }
  // A number given to the feature in `slot` when it was detected (1, 2, ... in order of
  // detection, never reused, also across resets; 0 for a slot that held none since the last
  // (re)start): tells a new feature in a reused slot from the old one (diagnostics, tests).
  int64_t feature_id(int slot) const { return tracks_[static_cast<std::size_t>(slot)].id; }

 private:
  struct Track {  // photometric bookkeeping of one slot
    MultilevelPatch patch;
    Eigen::Matrix2d A = Eigen::Matrix2d::Identity();  // d tangent(now) / d tangent(extraction)
    Eigen::Matrix2d D = Eigen::Matrix2d::Identity();  // d tangent / d pixel at extraction
    int failures = 0;
    int age = 0;
    int disagreements = 0;  // consecutive frames: C1 updated, C2 in view but rejected
    int64_t id = 0;         // feature_id()
    double score = 0.0;     // Shi-Tomasi score of the patch
    int template_updates = 0;  // accepted updates with the current patch (since extraction)
    bool updated = false;      // an update was accepted in the current frame
    int probation = 0;         // stereo.probation_frames: C1-only updates still to make
    double probation_nis = 0.0;  // sum of C1's normalized innovations during the probation
    bool depth_matched = false;  // rho from a stereo match (at detection or deferred)
    int c2_updates = 0;          // accepted updates in the second camera
    int deferred_tries = 0;      // stereo.deferred_match_frames: match tries left
  };

  bool Initialize(int64_t t_ns, const cv::Mat& image, std::string* why_not);
  bool InitializeFromGiven(int64_t t_ns, std::string* why_not);
  // Sets the state and the core covariance; cov12 is over (dv, dtheta, db_g, db_a), yaw_sigma
  // is added about M's z axis.
  void Start(int64_t t_ns, const Eigen::Quaterniond& q_M_I, const Eigen::Vector3d& p_M_I,
             const Eigen::Vector3d& v_M, const Eigen::Vector3d& b_g, const Eigen::Vector3d& b_a,
             const Eigen::Matrix<double, 12, 12>& cov12, double yaw_sigma);
  void Propagate(int64_t t_ns);
  bool UpdateFeature(int slot);
  // Stereo (vio_filter_stereo.cpp): the photometric update of a feature in the second camera,
  // and the initial inverse distance of a new feature from a stereo match.
  bool UpdateFeatureInSecond(int slot);
  // stereo.joint_update: the slot's feature in both cameras, each camera alone where the other
  // fails (result's counts updated). Without the joint update: every feature once more in the
  // second camera after all C1 updates.
  void UpdateFeatureInBoth(int slot, FrameResult* result);
  void UpdateFeaturesInSecond(FrameResult* result);
  // A new feature's initial depth at its detection pixel (a match made by ProbeStereoCandidate
  // for that pixel in this detection, else a new one).
  void InitializeDepthFromStereo(int slot, const Eigen::Vector2d& pixel);
  // stereo.candidates_per_slot: whether a detector candidate has a stereo match (kept in
  // probed_matches_); candidates that cannot become features are not refused here.
  bool ProbeStereoCandidate(const FeatureCandidate& candidate);
  // The stereo match (MatchInOtherCamera with the stereo options) of a C1 template with
  // tangent-from-pixel D (A D for a tracked feature) at bearing mu in the second image.
  StereoMatch MatchInSecond(const MultilevelPatch& patch, const Eigen::Matrix2d& D,
                            const Eigen::Vector3d& mu) const;
  // A new feature's initial depth from a match (counted; the rho state and its variance set).
  void ApplyInitialStereoMatch(int slot, const StereoMatch& match);
  // stereo.deferred_match_frames: features without a stereo depth try the match again; a
  // match is an EKF update of rho (vio_filter_stereo.cpp).
  void DeferredStereoMatches();
  // Bookkeeping of an accepted second-camera update of the slot's feature.
  void NoteSecondCameraUpdate(int slot);
  // stereo.joint_update: C1 and C2 of one feature in one 4-row iterated update with the
  // correlated model error of StereoJointNoise. kC1Failed / kC2Failed: that camera's
  // prediction, alignment or gate failed (or the joint step did not converge); nothing was
  // changed and the caller updates with the camera(s) left. kC2Rejected: predicted inside
  // C2's image, but the alignment there failed or was gated out (a disagreement).
  enum class JointUpdate { kDone, kC1Failed, kC2Failed, kC2Rejected };
  JointUpdate UpdateFeatureJoint(int slot);
  // The feature's pixel in the second camera at the image time and d pixel / d (tangent at
  // mu_basis_at, rho, td). False if it does not project into the second image.
  bool PredictInSecond(const FilterState& x, int slot, const Eigen::Vector3d& mu_basis_at,
                       OtherCameraPrediction* prediction, Eigen::Matrix<double, 2, 4>* J) const;
  void AddFeatures();
  void RemoveFeature(int slot);
  // features.refresh_patch_every: re-extracts the slot's patch at its current pixel estimate
  // (ROVIO's template refresh after a tracked frame) if the new patch is good enough.
  void RefreshPatch(int slot);
  // update.persistent_pixel_sigma^2 x (updates made with the slot's template + 1) [px^2].
  double PersistentPixelVariance(int slot) const;
  // stereo.persistent_disparity_sigma^2 x (updates made with the slot's template + 1) [px^2]:
  // added to the second camera's rows only (vio_filter_stereo.cpp).
  double PersistentDisparityVariance(int slot) const;
  // stereo.probation_frames: one C1-only update of a stereo-matched feature was accepted with
  // normalized innovation nis; at the end of the probation, removes a feature whose depth
  // disagreed with C1's flow (marks it for removal).
  void ProbationStep(int slot, double nis);
  std::string CheckHealth() const;
  Eigen::Matrix2d Warp(int slot, const Eigen::Matrix<double, 2, 3>& J_pixel_p_C) const;
  // d mu / dt of a feature from the camera's current rates.
  Eigen::Vector3d BearingRate(const FilterState& x, int slot) const;
  // The feature's pixel at the image time (state time + td), d pixel / d p_C there and
  // d pixel / d td. False if it does not project into the image.
  bool PredictPixel(const FilterState& x, int slot, Eigen::Vector2d* pixel,
                    Eigen::Matrix<double, 2, 3>* J_pixel_mu, Eigen::Vector2d* J_pixel_td) const;

  SensorRig rig_;
  CameraConfig camera_;
  bool stereo_ = false;           // options.stereo.enabled
  CameraConfig second_camera_;    // stereo: the second camera (extrinsics fixed from the rig)
  // stereo: C1 in C2 from the rig, T_I_C2^-1 T_I_C1: a calibrated stereo pair is rigid, so the
  // C2 measurement does not depend on the (possibly estimated) T_I_C1 of the state.
  Transformation T_C2_C1_;
  ImagePyramid pyramid2_;         // stereo: the second image of the current frame
  MultilevelPatch probe_patch_;   // stereo.candidates_per_slot: a candidate's patch
  Eigen::VectorXd deferred_gain_;  // stereo.deferred_match_frames: the gain of one rho update
  // stereo.candidates_per_slot: the detector candidates matched in this detection (pixel, match).
  std::vector<std::pair<Eigen::Vector2d, StereoMatch>> probed_matches_;
  bool have_second_image_ = false;
  FilterOptions options_;
  PropagationNoise noise_;

  bool initialized_ = false;
  FilterState x_;
  Eigen::MatrixXd P_;
  std::vector<Track> tracks_;
  int64_t next_feature_id_ = 1;
  std::vector<ImuSample> imu_;  // samples not yet consumed (plus the last one before x_.t_ns)
  FilterStats stats_;
  int frames_without_updates_ = 0;
  bool have_previous_reset_pose_ = false;
  Transformation reset_pose_;
  std::string requested_reset_;  // RequestReset(): applied at the next health check
  VisualInertialInitializer initializer_;
  bool have_given_state_ = false;
  GivenState given_state_;

  // Preallocated work (hot loops are allocation-free after the first frames).
  ImagePyramid pyramid_;
  PropagationJacobians jacobians_;
  PropagationWorkspace workspace_;
  FilterState x0_, x_iter_;
  Eigen::VectorXd dx_;
  Eigen::Matrix<double, Eigen::Dynamic, 2> PHt_, K_, KS_;
  Eigen::Matrix<double, Eigen::Dynamic, 3> Pcols_;  // P columns of (dmu, dtd) of one feature
  Eigen::Matrix<double, Eigen::Dynamic, 4> Pcols4_;  // stereo: (dmu, drho, dtd)
  Eigen::Matrix<double, Eigen::Dynamic, 4> PHt4_, K4_, KS4_;  // stereo: the joint update
  Eigen::VectorXd residual2_;                         // stereo: the joint update's C2 residual
  Eigen::Matrix<double, Eigen::Dynamic, 2> J_residual_pixel2_;
  Eigen::Vector3d last_omega_m_ = Eigen::Vector3d::Zero();  // last gyro measurement [rad/s]
  // yaw_observability_constraint: position, velocity and attitude of the state from which the
  // covariance's yaw null direction was propagated (the state before the last update).
  Eigen::Vector3d yaw_anchor_p_ = Eigen::Vector3d::Zero();
  Eigen::Vector3d yaw_anchor_v_ = Eigen::Vector3d::Zero();
  Eigen::Quaterniond yaw_anchor_q_ = Eigen::Quaterniond::Identity();
  Eigen::VectorXd residual_;
  Eigen::Matrix<double, Eigen::Dynamic, 2> J_residual_pixel_;
  std::vector<Eigen::Vector2d> occupied_;
  MultilevelPatch refreshed_patch_;  // RefreshPatch's candidate
  double last_nis_ = 0.0;  // UpdateFeature: e^T S^-1 e of the aligned pixel (2 DoF)
};

}  // namespace vilma::estimator
