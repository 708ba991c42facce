#include "filter_stage.h"

#include <algorithm>
#include <cstdio>
#include <thread>

#include "vilma/estimator/filter_state.h"

namespace vilma::daemon {

namespace {

PoseStatus ToPoseStatus(estimator::TrackingStatus s) {
  switch (s) {
    case estimator::TrackingStatus::kInitializing: return kPoseInitializing;
    case estimator::TrackingStatus::kTracking: return kPoseTracking;
    case estimator::TrackingStatus::kLost: return kPoseLost;
  }
  return kPoseInvalid;
}

}  // namespace

FilterStage::FilterStage(const FilterStageOptions& options, const SensorRig& rig,
                         Pipeline* pipeline, Spsc<OutputItem>* output)
    : options_(options),
      rig_(rig),
      p_(*pipeline),
      queue_(static_cast<std::size_t>(options.queue_capacity)),
      output_(*output),
      vio_(rig, options.vio_camera, options.estimator, options.time_jump) {
  int cameras = options.vio_camera + 1;
  if (options.estimator.stereo.enabled) cameras = std::max(cameras, options.estimator.stereo.camera + 1);
  frame_t_cam_ns_.assign(static_cast<std::size_t>(cameras), 0);
  frame_images_.resize(static_cast<std::size_t>(cameras));
}

void FilterStage::ConnectMap(const MappingOptions& options, MapStage* stage) {
  map_ = std::make_unique<MapFeeder>(options, &p_, stage);
}

void FilterStage::ConnectLoc(const LocalizationOptions& options, LocStage* stage) {
  const double camera_rate = rig_.cameras[static_cast<std::size_t>(options_.vio_camera)].rate_hz;
  loc_ = std::make_unique<LocClient>(options, camera_rate, &p_, stage, &output_);
}

void FilterStage::OnFrame(FilterItem& item) {
  if (options_.fault_stall_after >= 0 && frames_ >= options_.fault_stall_after) {
    // Fault injection (--fault-stall-filter-after): the filter stops making progress, so the
    // watchdog is no longer petted. Only a stop request ends the stall.
    if (!p_.filter_stalled.exchange(true)) {
      std::fprintf(stderr, "vilma-estimatord: fault injection: filter stalled after %lld frames\n",
                   static_cast<long long>(frames_));
    }
    while (!p_.stop.load()) std::this_thread::sleep_for(std::chrono::milliseconds(10));
  }
  if (frames_ == options_.fault_reset_at) {
    // Fault injection (--fault-reset-filter-at): the filter resets as on a failed health check
    // (at this frame, or at the first initialized one after it).
    vio_.RequestReset("fault injection (--fault-reset-filter-at)");
    std::fprintf(stderr, "vilma-estimatord: fault injection: filter reset at frame %lld\n",
                 static_cast<long long>(frames_));
  }
  OutputItem out;
  out.filter_start_ns = SteadyNs();
  // The synchronized frame: the VIO camera's image, and with stereo the second camera's (or
  // none: VioFilterStage then updates with the VIO camera only and counts the frame).
  const std::size_t vio = static_cast<std::size_t>(options_.vio_camera);
  frame_t_cam_ns_[vio] = item.t_cam_ns;
  frame_images_[vio] = item.image;
  if (options_.estimator.stereo.enabled) {
    const std::size_t s = static_cast<std::size_t>(options_.estimator.stereo.camera);
    frame_t_cam_ns_[s] = item.stereo_t_cam_ns;
    frame_images_[s] = item.stereo_image;
  }
  const estimator::VioFrameOutput o = vio_.AddFrame(frame_t_cam_ns_, frame_images_);
  out.filtered_steady_ns = SteadyNs();
  for (cv::Mat& m : frame_images_) m.release();
  item.stereo_image.release();  // back to the pool
  const estimator::FrameResult& r = o.filter;
  const estimator::VioPose& pose = o.pose;
  cv::Mat loc_image;  // LOC mode: the image may go to the localizer
  if (loc_) loc_image = item.image;
  item.image.release();  // back to the pool
  frames_in_flight_.fetch_sub(1);
  ++frames_;
  p_.counters.Add(kFramesFiltered);
  p_.counters.Set(kFilterResets, vio_.counters().resets);
  p_.counters.Set(kFramesWithoutStereo, vio_.counters().frames_without_stereo);
  if (r.reset) p_.log(10, "filter reset: %s", r.reset_reason.c_str());
  const bool tracked = r.pose_valid && !r.reset;
  if (map_) {
    if (r.reset) map_->EndMission();  // the filter re-initializes: a new M frame
    if (tracked) {
      mapping::FrameState state;
      state.t_ns = pose.t_ns;
      state.T_M_I = pose.T_M_I;
      state.v_M = pose.v_M;
      state.gyro_bias = pose.gyro_bias;
      state.accel_bias = pose.accel_bias;
      map_->OfferFrame(state, &item.map_images);
    }
  }
  for (cv::Mat& m : item.map_images) m.release();  // back to the pool
  if (loc_) {
    if (r.reset) loc_->NewMFrame();  // the filter re-initializes: a new M frame
    loc_->ApplyResults();            // live: results that came back since the last frame
    if (tracked) loc_->OnTrackedFrame(pose.t_ns, pose.T_M_I, loc_image);
    loc_image.release();
    // VILMA_POSE: T_G_I = T_G_M T_M_I (its covariance below).
    if (tracked && loc_->initialized()) loc_->FillGlobalPose(pose.T_M_I, pose.v_M, &out);
  }
  out.status = ToPoseStatus(pose.status);
  p_.filter_state.store(out.status, std::memory_order_relaxed);
  p_.features.store(r.num_features, std::memory_order_relaxed);
  out.t_ns = pose.t_ns;
  out.features = r.num_features;
  out.recv_steady_ns = item.recv_steady_ns;
  out.recv_latency_us = item.recv_latency_us;
  out.synced_steady_ns = item.synced_steady_ns;
  if (r.pose_valid) {
    const Eigen::Vector3d& p = pose.T_M_I.translation();
    const Eigen::Quaterniond& q = pose.T_M_I.rotation();
    for (int i = 0; i < 3; ++i) {
      out.position[i] = p[i];
      out.velocity[i] = pose.v_M[i];
      out.angular_velocity[i] = pose.omega_I[i];
    }
    out.orientation[0] = q.w();
    out.orientation[1] = q.x();
    out.orientation[2] = q.y();
    out.orientation[3] = q.z();
    // pose.covariance: (position, rotation) with the global (left) rotation error, as pose_t
    // (VioPose). Only once the filter has its attitude block.
    if (vio_.filter().covariance().rows() >= estimator::kIdxQ + 3) {
      CopyRowMajor(pose.covariance, out.covariance);
      if (out.global) loc_->FillGlobalCovariance(pose.covariance, &out);
    }
  }
  if (!Push(p_, output_, out)) {
    p_.counters.Add(kPosesDroppedOutput);
  } else {
    p_.output_wake.Notify();
  }
}

void FilterStage::Run() {
  FilterItem item;
  while (true) {
    bool any = false;
    const int depth = static_cast<int>(queue_.read_available());
    if (depth > p_.filter_depth_max.load()) p_.filter_depth_max.store(depth);
    while (queue_.pop(item)) {
      any = true;
      if (item.kind == FilterItem::Kind::kImu) {
        vio_.AddImu(item.imu);
        if (map_) map_->PushImu(item.imu);
      } else if (item.kind == FilterItem::Kind::kRestart) {
        // A time jump: a new filter, or the pre-jump filter resumed when the stamps came back
        // onto its timeline (item.imu.t_ns: the first stamp on the new time base). Either way
        // the M frame of the frames just before ends (a new mission, T_G_M unknown again).
        if (vio_.OnTimeJump(item.imu.t_ns)) {
          p_.log(8, "timestamps back on the pre-jump timeline: the pre-jump filter resumes");
        } else {
          p_.log(8, "timestamp jump: the filter restarts");
        }
        p_.counters.Set(kTimeJumpRestarts, vio_.counters().restarts);
        p_.counters.Set(kTimeJumpResumes, vio_.counters().resumes);
        p_.counters.Set(kTimeJumpImuRestamped, vio_.counters().imu_restamped);
        if (map_) map_->EndMission();
        if (loc_) loc_->NewMFrame();
      } else {
        OnFrame(item);
      }
      // Petted while the filter makes progress (here) or waits for data (below); a stalled
      // filter stops petting and systemd restarts the service.
      p_.notifier.PetWatchdog(SteadyNs());
    }
    if (!any) {
      if (p_.sync_done.load() && queue_.read_available() == 0) break;
      p_.notifier.PetWatchdog(SteadyNs());
      p_.filter_wake.Wait(50 * kMs);
    }
  }
  if (loc_) loc_->Drain();
  p_.filter_done.store(true);
  p_.output_wake.Notify();
  p_.map_wake.Notify();
  p_.loc_wake.Notify();
}

}  // namespace vilma::daemon
