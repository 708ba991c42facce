// One estimator path (issue 19): the camera-IMU synchronizer (core's SensorSynchronizer) and
// the VioFilter behind one single-threaded interface, used by `vilma vio`, the daemon's filter
// stage and the tests. No LCM, no threads. docs/estimator.md, "One estimator path".
//
// Two layers:
// - VioFilterStage: what runs after synchronization. IMU samples and synchronized frames (per
//   camera a stamp and an image) go into the filter; each frame gives a VioFrameOutput with the
//   pose in the form every consumer publishes (status, T_M_I, v_M, omega_I, the 6x6
//   covariance). A caller that synchronizes on another thread (vilma-estimatord: sync stage ->
//   queue -> filter stage) drives this layer directly.
// - VioPipeline: SensorSynchronizer + VioFilterStage for input in arrival order (a dataset
//   merged by time, an LCM log): it forwards every released frame as the daemon's sync stage
//   does (time jump -> Restart, each IMU sample once, frames without the VIO camera counted).
//
// Time: IMU clock in ns; camera i's image stamped t_cam was taken at t_cam + time_offset_ns(i).
#pragma once

#include <Eigen/Core>
#include <cstdint>
#include <memory>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "vilma/core/geometry.h"
#include "vilma/core/imu.h"
#include "vilma/core/rig.h"
#include "vilma/core/sensor_sync.h"
#include "vilma/estimator/filter_options.h"
#include "vilma/estimator/vio_filter.h"

namespace vilma::estimator {

// The values are those of vilma.pose_t's status (INITIALIZING 1, TRACKING 2, LOST 4).
enum class TrackingStatus : int32_t { kInitializing = 1, kTracking = 2, kLost = 4 };

// One frame's estimate as published (VILMA_ODOM) and written (vilma vio's TUM file): the one
// FilterState -> pose conversion.
struct VioPose {
  // Tracking: the state time; otherwise the frame's IMU-clock time t_cam + time_offset_ns.
  int64_t t_ns = 0;
  TrackingStatus status = TrackingStatus::kInitializing;
  Transformation T_M_I;                                // valid when tracking
  Eigen::Vector3d v_M = Eigen::Vector3d::Zero();       // [m/s]
  Eigen::Vector3d omega_I = Eigen::Vector3d::Zero();   // last gyro sample - b_g [rad/s]
  Eigen::Vector3d gyro_bias = Eigen::Vector3d::Zero();   // [rad/s]
  Eigen::Vector3d accel_bias = Eigen::Vector3d::Zero();  // [m/s^2]
  // Covariance of (position [m], rotation [rad]) with the GLOBAL (left) rotation error
  // R_M_I' = Exp(delta) R_M_I, as pose_t. The filter's attitude error is right-perturbed
  // (q = q Exp(dtheta)), delta = R dtheta, so with R = R_M_I:
  //   C = [P_pp, P_pt R^T; R P_tp, R P_tt R^T].
  Matrix6d covariance = Matrix6d::Zero();
  bool tracking() const { return status == TrackingStatus::kTracking; }
};

// What one frame did.
struct VioFrameOutput {
  VioPose pose;
  FrameResult filter;             // the filter's per-frame result (counts, reset and reason)
  // The filter restarted before this frame (a time jump): a new M frame begins here, as after
  // a reset (filter.reset). Consumers end their mission / T_G_M estimate on either. Also set
  // when a jump resumed the pre-jump filter (`resumed`): its M is not the one of the frames
  // just before (those of the filter that ran on the jumped stamps).
  bool restarted = false;
  bool resumed = false;  // the jump resumed the filter an earlier jump had left (see OnTimeJump)
  double filter_ms = 0.0;         // wall time of the filter on this frame [ms]
  // VioPipeline only (the stage leaves them empty): the synchronized frame, per rig camera a
  // stamp (0) and an image (empty) when the camera is not in it, and the IMU samples given to
  // the filter since the previous output (each sample once, in order) - what a map builder fed
  // alongside needs.
  std::vector<int64_t> t_cam_ns;
  std::vector<cv::Mat> images;
  std::vector<ImuSample> imu;
};

// Counters over the whole run, across restarts.
struct VioStageCounters {
  int64_t frames = 0;                    // frames given to the filter
  int64_t restarts = 0;                  // time jumps that restarted the filter
  int64_t resumes = 0;                   // time jumps that resumed the pre-jump filter
  int64_t imu_restamped = 0;             // jumped IMU samples re-stamped into a resume's gap
  int64_t resets = 0;                    // filter resets (health checks), all filters summed
  int64_t frames_without_vio_camera = 0; // synchronized frames without the VIO camera: skipped
  int64_t frames_without_stereo = 0;     // stereo on, frame without the second camera: mono
};

// What a timestamp jump does to the filter (docs/daemon.md, "Clock jumps").
struct TimeJumpOptions {
  // A jump whose new stamps continue the timeline of the filter that an earlier jump left,
  // at most this long [s] after that filter's last IMU sample, resumes that filter (the gap is
  // bridged as an IMU gap: propagation interpolates across it) instead of starting a new one.
  // 0: every jump restarts.
  double resume_max_gap_s = 2.0;
  std::string Validate() const;  // empty if valid, else "field: expectation"
};

class VioFilterStage {
 public:
  // `vio_camera`: the filter's camera (the anchor of its features). With
  // options.stereo.enabled, options.stereo.camera is the second camera. Throws InputError for
  // invalid options or rig.
  VioFilterStage(const SensorRig& rig, int vio_camera, const FilterOptions& options,
                 const TimeJumpOptions& jump = TimeJumpOptions());

  // IMU samples in time order.
  void AddImu(const ImuSample& sample);
  // One synchronized frame: t_cam_ns[i] and images[i] per rig camera index (an empty image for
  // a camera not in the frame; both vectors may be shorter than the rig). The VIO camera's
  // image must be there. Returns the output of the frame.
  VioFrameOutput AddFrame(const std::vector<int64_t>& t_cam_ns, const std::vector<cv::Mat>& images);
  // Mono convenience: only the VIO camera's image.
  VioFrameOutput AddFrame(int64_t t_cam_ns, const cv::Mat& image);
  // A timestamp jump (the synchronizer cleared its history); `t_next_ns` is the first IMU
  // stamp on the new time base. Either
  // - resume: the filter that an earlier jump left (kept as a snapshot) ran until t_s, and
  //   t_s < t_next_ns <= t_s + jump.resume_max_gap_s: the stamps came back onto its timeline.
  //   It becomes the filter again, the one that ran on the jumped stamps is discarded; the
  //   next output has restarted = resumed = true and status TRACKING if the filter survives
  //   the gap. Returns true. The gap (t_s, t_next_ns) is bridged with the IMU samples that
  //   came on the jumped stamps when they fit into it (see RestampJumpedImu): they are the
  //   missing samples with wrong stamps. Otherwise propagation interpolates across it.
  // - restart: a new filter; the current one is kept as the snapshot if it is initialized
  //   (otherwise an older snapshot stays). The next output has restarted = true and status
  //   INITIALIZING until the new filter starts. Returns false.
  bool OnTimeJump(int64_t t_next_ns);
  // The jumped samples re-stamped into the gap (t_s, t_next_ns) given to the resumed filter;
  // returns how many (0: they do not fit, the gap is interpolated).
  int64_t RestampJumpedImu(int64_t t_next_ns);
  // Only one snapshot is kept (the newest initialized filter a jump left): bounded memory.
  bool has_snapshot() const { return snapshot_ != nullptr; }
  // See VioFilter::StartFrom / RequestReset (applied to the current filter).
  void StartFrom(const GivenState& state) { filter_->StartFrom(state); }
  void RequestReset(const std::string& reason) { filter_->RequestReset(reason); }
  // A synchronized frame without the VIO camera's image was skipped (counted only).
  void CountFrameWithoutVioCamera() { ++counters_.frames_without_vio_camera; }

  const VioFilter& filter() const { return *filter_; }
  const VioStageCounters& counters() const { return counters_; }
  int vio_camera() const { return vio_camera_; }
  int64_t camera_time_offset_ns() const { return time_offset_ns_; }

 private:
  SensorRig rig_;
  int vio_camera_;
  FilterOptions options_;
  int64_t time_offset_ns_ = 0;
  TimeJumpOptions jump_;
  std::unique_ptr<VioFilter> filter_;
  // The filter a jump left (initialized), its last IMU stamp and whether it had been
  // initialized; resumed when the stamps come back onto its timeline.
  std::unique_ptr<VioFilter> snapshot_;
  int64_t snapshot_last_imu_ns_ = 0;
  // IMU samples given to filter_ since the jump that made the snapshot (the candidates for
  // the gap at a resume); at most max_jumped_imu_ (then the window is too long to resume).
  std::vector<ImuSample> jumped_imu_;
  std::size_t max_jumped_imu_ = 0;
  bool jumped_imu_overflow_ = false;
  int64_t last_imu_ns_ = 0;        // newest sample given to filter_
  bool have_imu_ = false;          // last_imu_ns_ is valid
  VioStageCounters counters_;
  int64_t resets_discarded_ = 0;   // resets of the filters discarded (restarts, resumes)
  bool ever_initialized_ = false;  // since the last restart: LOST vs INITIALIZING
  bool restart_pending_ = false;
  bool resume_pending_ = false;
  Eigen::Vector3d last_omega_m_ = Eigen::Vector3d::Zero();  // last gyro sample [rad/s]
};

struct VioPipelineOptions {
  int vio_camera = 0;  // the filter's camera (rig index)
  // Rig cameras synchronized into frames (empty: every camera of the rig). The VIO camera
  // (and the stereo camera when stereo is on) must be among them. A camera listed here whose
  // images never come makes every frame wait sync.incomplete_frame_timeout_ns.
  std::vector<int> cameras;
  FilterOptions filter;
  SensorSyncOptions sync;
  TimeJumpOptions time_jump;
  std::string Validate(int rig_cameras) const;  // empty if valid, else "field: expectation"
};

class VioPipeline {
 public:
  // Throws InputError for invalid options or rig.
  VioPipeline(const SensorRig& rig, const VioPipelineOptions& options);

  // Input in arrival order (as from a sensor or a log). Images of cameras not in
  // options.cameras are ignored.
  void AddImu(const ImuSample& sample);
  void AddImage(int camera, int64_t t_cam_ns, const cv::Mat& image_gray8);
  // Runs the filter on the next frame the synchronizer releases; false when none is ready.
  bool NextOutput(VioFrameOutput* output);

  VioFilterStage& stage() { return stage_; }
  const VioFilterStage& stage() const { return stage_; }
  const SensorSyncCounters& sync_counters() const { return sync_.counters(); }
  // The newest IMU stamp given to the filter (samples after it are still in the synchronizer).
  int64_t last_forwarded_imu_ns() const { return last_forwarded_imu_ns_; }

 private:
  VioPipelineOptions options_;
  int rig_cameras_ = 0;
  std::vector<int> sync_index_;  // rig camera -> synchronizer camera (-1: not synchronized)
  SensorSynchronizer sync_;
  VioFilterStage stage_;
  SyncedFrame frame_;
  int64_t last_forwarded_imu_ns_;
  std::vector<int64_t> t_cam_ns_;
  std::vector<cv::Mat> images_;
  std::vector<ImuSample> pending_imu_;  // given to the filter, not yet in an output
};

}  // namespace vilma::estimator
