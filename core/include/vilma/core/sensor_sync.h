// Camera-IMU synchronization for the online pipeline (architecture.md section 3, "sync"):
// groups the images of N cameras into frames, holds each frame until the IMU covers its time,
// and hands out frames in time order with the IMU samples that lead up to them. It detects and
// counts what real sensors do: late, out-of-order and duplicate samples, IMU gaps, timestamp
// jumps, a camera that falls silent. No LCM, no threads: the daemon's sync stage owns one.
//
// Time: every stamp is t_ns on the sensor clock. Camera i's image stamped t_cam was taken at
// t_imu = t_cam + camera_time_offsets_ns[i] (rig, Kalibr's sign); frames are ordered by that
// IMU-clock time.
//
// Semantics (docs/design.md, "Synchronization", has the reasoning):
// - Frames. An image joins the pending frame whose time is within frame_grouping_tolerance_ns
//   of its IMU-clock time and that has no image of that camera yet; otherwise it opens a new
//   frame. A frame's time t_imu_ns is that of its lowest-index camera present (cam0 for a
//   complete frame), so it does not depend on arrival order. Frames are released strictly in
//   increasing t_imu_ns, oldest first (head of line: a younger complete frame waits for an
//   older one).
// - "Newer camera data": the timeouts below are measured against the newest image stamp of any
//   camera (IMU clock), not against the IMU and not against wall time: cameras usually reach us
//   later than the IMU, so the IMU clock would time out a frame whose partner image is merely in
//   transit. A mono rig has no incomplete frames (a frame is created by its only camera).
// - A frame is released when it is complete (or incomplete for more than
//   incomplete_frame_timeout_ns of newer camera data) AND the IMU has a sample at or after its
//   time. A frame that waited more than max_imu_wait_ns of newer camera data for the IMU is
//   dropped (its IMU samples are not: they go to the next released frame).
// - IMU of a frame: let c be the first sample with t_ns >= t_imu_ns. frame.imu = [b, ..., c],
//   where b is the previous released frame's c (repeated, imu_overlaps_previous = true) so that
//   the consumer can interpolate across the boundary; the samples between b and c are each
//   handed out exactly once. If b is already >= t_imu_ns (two frames between two IMU samples),
//   frame.imu = [b]. The first frame (and the first after a time jump or a prune) has
//   imu_overlaps_previous = false and carries every buffered sample up to c (at most
//   imu_history_ns of history, which the consumer may use for initialization or skip). Concatenating all frames' imu, minus imu[0] of each frame with
//   imu_overlaps_previous, gives the accepted IMU stream without loss or repetition.
// - Rejected input never throws: it is dropped and counted. Per stream (IMU, each camera):
//   same stamp as the newest = duplicate, older = out of order. An image at or before the last
//   released or dropped frame (+ tolerance) is late. An IMU spacing above imu_gap_threshold_ns is
//   a gap (counted, samples forwarded).
// - Time jumps. A sample more than time_jump_threshold_ns away from both its own stream's
//   previous stamp and the newest stamp of all streams ("epoch reference") is a jump: pending
//   frames and buffered IMU are dropped, the other streams must rejoin the new time base (their
//   samples still on the old base are dropped as stale; their own jump is counted when they
//   rejoin), and the next released frame has time_jump_before = true. A stream that was merely
//   silent (camera unplugged 2 s, IMU stalled) resumes consistent with the other streams and is
//   not a jump; if every stream is silent longer than the threshold, the restart is a jump.
// - Backpressure: more than max_pending_frames pending frames -> the oldest is dropped.
#pragma once

#include <cstdint>
#include <deque>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "vilma/core/imu.h"

namespace vilma {

struct SensorSyncOptions {
  // Images of one frame may differ in stamp by at most this [ns] (hardware-triggered stereo:
  // ~0; free-running cameras: half a frame period).
  int64_t frame_grouping_tolerance_ns = 2000000;
  // A frame whose cameras are not all there after this much newer data [ns] is released
  // with the images it has (a camera dropped a frame or fell silent).
  int64_t incomplete_frame_timeout_ns = 100000000;
  // A frame waits at most this long [ns of newer camera data] for the IMU to cover it;
  // then it is dropped and counted (IMU stalled or late).
  int64_t max_imu_wait_ns = 200000000;
  // IMU spacing above this [ns] counts as a gap (samples still forwarded).
  int64_t imu_gap_threshold_ns = 25000000;
  // A stamp this far [ns] from the previous one of the same stream (either direction) is a
  // timestamp jump: the stream's history is cleared and the jump reported, so that the
  // consumer (the filter) can reset.
  int64_t time_jump_threshold_ns = 1000000000;
  // Frames held at most; beyond, the oldest is dropped and counted (backpressure).
  int max_pending_frames = 8;
  // (added) IMU samples are kept at most this long [ns behind the newest IMU sample] while no
  // frame takes them (before the first image, a silent camera): the buffer holds the samples
  // of that window plus the one before it. Older ones are discarded (counted as imu_discarded,
  // and the next frame has imu_overlaps_previous = false). Bounds memory (5 s at 200 Hz: 1000
  // samples); longer than time_jump_threshold_ns so that a camera silent for less than a jump
  // keeps the IMU contiguous.
  int64_t imu_history_ns = 5000000000;

  std::string Validate() const;  // empty if valid, else "field: expectation"
};

// Everything the synchronizer saw go wrong, as monotonic counters (for VILMA_STATUS).
struct SensorSyncCounters {
  int64_t imu_received = 0;
  int64_t imu_duplicates = 0;        // same stamp as an earlier sample: dropped
  int64_t imu_out_of_order = 0;      // older than the newest sample: dropped
  int64_t imu_gaps = 0;              // spacing above imu_gap_threshold_ns
  int64_t imu_time_jumps = 0;
  int64_t imu_invalid = 0;           // (added) non-finite values: dropped
  int64_t imu_stale = 0;             // (added) still on the time base before a jump: dropped
  int64_t imu_discarded = 0;         // (added) accepted but pruned by imu_history_ns unused
  int64_t images_received = 0;
  int64_t images_duplicate = 0;      // same camera and stamp as an earlier image: dropped
  int64_t images_out_of_order = 0;   // older than that camera's newest image: dropped
  int64_t images_late = 0;           // older than the last frame released: dropped
  int64_t image_time_jumps = 0;
  int64_t images_invalid = 0;        // (added) bad camera index, empty image, stamp overflow
  int64_t images_stale = 0;          // (added) still on the time base before a jump: dropped
  int64_t frames_released = 0;
  int64_t frames_incomplete = 0;     // released without every camera
  int64_t frames_dropped_no_imu = 0; // waited max_imu_wait_ns for the IMU
  int64_t frames_dropped_overflow = 0;
  int64_t frames_dropped_time_jump = 0;  // (added) pending when a time jump cleared history
};

// A synchronized frame: the images (one per camera; an empty cv::Mat for a missing camera)
// and the IMU samples from the previous frame's last sample up to and including the first
// sample at or after t_imu_ns.
struct SyncedFrame {
  int64_t t_imu_ns = 0;                 // frame time on the IMU clock
  std::vector<int64_t> t_cam_ns;        // per camera, its own stamp (0 if missing)
  std::vector<cv::Mat> images;          // per camera
  std::vector<ImuSample> imu;
  bool time_jump_before = false;        // a timestamp jump happened since the last frame
  // (added) imu[0] is the previous released frame's last sample, repeated (see top of file).
  bool imu_overlaps_previous = false;
};

class SensorSynchronizer {
 public:
  // `camera_time_offsets_ns` has one entry per camera (its size is the camera count).
  // Throws std::invalid_argument for invalid options or no cameras.
  SensorSynchronizer(const SensorSyncOptions& options, std::vector<int64_t> camera_time_offsets_ns);

  void AddImu(const ImuSample& sample);
  // `image` is shared, not copied (cv::Mat reference counting).
  void AddImage(int camera_index, int64_t t_cam_ns, const cv::Mat& image);

  // The next frame that is complete (or timed out) and covered by the IMU, oldest first.
  // Overwrites *frame (reusing its imu capacity); false if no frame is ready. Frames that
  // timed out waiting for the IMU are dropped (and counted) on the way.
  bool PopFrame(SyncedFrame* frame);

  const SensorSyncCounters& counters() const { return counters_; }
  int pending_frames() const { return static_cast<int>(pending_.size()); }
  int num_cameras() const { return static_cast<int>(offsets_ns_.size()); }

 private:
  SensorSyncOptions options_;
  std::vector<int64_t> offsets_ns_;
  SensorSyncCounters counters_;
  std::deque<ImuSample> imu_;           // samples not yet handed out (plus the last one given)
  std::deque<SyncedFrame> pending_;     // frames being assembled, by t_imu_ns
  std::vector<int64_t> newest_image_ns_;  // per camera, on the IMU clock
  int64_t newest_imu_ns_ = -1;
  int64_t last_released_ns_ = -1;
  bool jump_pending_ = false;
  // (added) implementation state; see sensor_sync.cpp.
  std::vector<char> camera_seen_;        // newest_image_ns_[i] is valid
  std::vector<char> camera_in_epoch_;    // camera i is on the current time base
  bool imu_seen_ = false;                // newest_imu_ns_ is valid
  bool imu_in_epoch_ = false;
  bool has_epoch_ = false;
  int64_t epoch_ref_ns_ = 0;             // newest stamp of any stream on the current time base
  bool has_closed_ = false;              // last_released_ns_ is valid (released or dropped)
  bool imu_front_handed_out_ = false;    // imu_.front() was the last sample of a released frame
  int64_t newest_camera_ns_ = 0;         // newest image of any camera (IMU clock), if any_camera_
  bool any_camera_ = false;

  enum class Admit { kAccept, kJoin, kStale, kJump };
  Admit CheckTimeBase(bool* in_epoch, bool seen, int64_t last_ns, int64_t t_ns);
  void ResetTimeBase(int64_t t_ns);
  void DropFront(int64_t* counter);
};

}  // namespace vilma
