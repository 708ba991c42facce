#include "vilma/estimator/vio_pipeline.h"

#include <algorithm>
#include <chrono>
#include <limits>

#include "vilma/core/error.h"

namespace vilma::estimator {

// ---------------------------------------------------------------- filter stage

VioFilterStage::VioFilterStage(const SensorRig& rig, int vio_camera, const FilterOptions& options)
    : rig_(rig), vio_camera_(vio_camera), options_(options) {
  filter_ = std::make_unique<VioFilter>(rig_, vio_camera_, options_);  // validates
  time_offset_ns_ = rig_.cameras[static_cast<std::size_t>(vio_camera_)].time_offset_ns;
}

void VioFilterStage::AddImu(const ImuSample& sample) {
  filter_->AddImu(sample);
  last_omega_m_ = sample.omega_I;
}

void VioFilterStage::Restart() {
  resets_before_restart_ += filter_->stats().resets;
  filter_ = std::make_unique<VioFilter>(rig_, vio_camera_, options_);
  ever_initialized_ = false;
  restart_pending_ = true;
  ++counters_.restarts;
}

VioFrameOutput VioFilterStage::AddFrame(int64_t t_cam_ns, const cv::Mat& image) {
  std::vector<int64_t> stamps(static_cast<std::size_t>(vio_camera_) + 1, 0);
  std::vector<cv::Mat> images(static_cast<std::size_t>(vio_camera_) + 1);
  stamps.back() = t_cam_ns;
  images.back() = image;
  return AddFrame(stamps, images);
}

VioFrameOutput VioFilterStage::AddFrame(const std::vector<int64_t>& t_cam_ns,
                                        const std::vector<cv::Mat>& images) {
  const std::size_t vio = static_cast<std::size_t>(vio_camera_);
  if (vio >= images.size() || vio >= t_cam_ns.size() || images[vio].empty()) {
    throw std::invalid_argument("VioFilterStage::AddFrame: no image of the VIO camera");
  }
  VioFrameOutput out;
  out.restarted = restart_pending_;
  restart_pending_ = false;
  const cv::Mat* second = nullptr;
  if (options_.stereo.enabled) {
    const std::size_t s = static_cast<std::size_t>(options_.stereo.camera);
    if (s < images.size() && !images[s].empty()) {
      second = &images[s];
    } else {
      ++counters_.frames_without_stereo;
    }
  }
  const auto t0 = std::chrono::steady_clock::now();
  out.filter = second != nullptr ? filter_->AddImage(t_cam_ns[vio], images[vio], *second)
                                 : filter_->AddImage(t_cam_ns[vio], images[vio]);
  out.filter_ms =
      std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  ++counters_.frames;
  counters_.resets = resets_before_restart_ + filter_->stats().resets;

  const FrameResult& r = out.filter;
  VioPose& pose = out.pose;
  if (r.pose_valid) ever_initialized_ = true;
  pose.status = TrackingStatus::kInitializing;
  if (r.reset || (!r.pose_valid && ever_initialized_)) {
    pose.status = TrackingStatus::kLost;
  } else if (r.pose_valid) {
    pose.status = TrackingStatus::kTracking;
  }
  pose.t_ns = r.pose_valid ? r.t_ns : t_cam_ns[vio] + time_offset_ns_;
  if (!r.pose_valid) return out;
  const FilterState& x = filter_->state();
  pose.T_M_I = r.T_M_I;
  pose.v_M = x.v_M;  // the filter's world frame W is the mission frame M
  pose.omega_I = last_omega_m_ - x.b_g;
  pose.gyro_bias = x.b_g;
  pose.accel_bias = x.b_a;
  // Right-perturbed attitude error dtheta -> global error R dtheta (see VioPose::covariance).
  const Eigen::MatrixXd& P = filter_->covariance();
  if (P.rows() >= kIdxQ + 3) {
    const Eigen::Matrix3d R = r.T_M_I.rotation().toRotationMatrix();
    Matrix6d& C = pose.covariance;
    C.block<3, 3>(0, 0) = P.block<3, 3>(kIdxP, kIdxP);
    C.block<3, 3>(0, 3) = P.block<3, 3>(kIdxP, kIdxQ) * R.transpose();
    C.block<3, 3>(3, 0) = C.block<3, 3>(0, 3).transpose();
    C.block<3, 3>(3, 3) = R * P.block<3, 3>(kIdxQ, kIdxQ) * R.transpose();
  }
  return out;
}

// ---------------------------------------------------------------- pipeline

std::string VioPipelineOptions::Validate(int rig_cameras) const {
  if (vio_camera < 0 || vio_camera >= rig_cameras) {
    return "vio_camera: expected a camera of the rig (0.." + std::to_string(rig_cameras - 1) + ")";
  }
  for (int c : cameras) {
    if (c < 0 || c >= rig_cameras) return "cameras: expected rig camera indices";
  }
  std::vector<int> sorted = cameras;
  std::sort(sorted.begin(), sorted.end());
  if (std::adjacent_find(sorted.begin(), sorted.end()) != sorted.end()) {
    return "cameras: expected each camera once";
  }
  auto listed = [&](int c) {
    return cameras.empty() || std::find(cameras.begin(), cameras.end(), c) != cameras.end();
  };
  if (!listed(vio_camera)) return "cameras: expected to include vio_camera";
  if (filter.stereo.enabled) {
    if (filter.stereo.camera >= rig_cameras) {
      return "filter.stereo.camera: expected a camera of the rig";
    }
    if (filter.stereo.camera == vio_camera) {
      return "filter.stereo.camera: expected a camera other than vio_camera";
    }
    if (!listed(filter.stereo.camera)) return "cameras: expected to include stereo.camera";
  }
  const std::string e = sync.Validate();
  if (!e.empty()) return "sync." + e;
  return "";
}

namespace {

std::vector<int> SyncedCameras(const VioPipelineOptions& o, int rig_cameras) {
  std::vector<int> cameras = o.cameras;
  if (cameras.empty()) {
    for (int c = 0; c < rig_cameras; ++c) cameras.push_back(c);
  }
  std::sort(cameras.begin(), cameras.end());
  return cameras;
}

std::vector<int64_t> SyncOffsets(const SensorRig& rig, const VioPipelineOptions& o) {
  const std::string e = o.Validate(static_cast<int>(rig.cameras.size()));
  if (!e.empty()) throw InputError(FormatInputError("VIO pipeline options", "", e));
  std::vector<int64_t> offsets;
  for (int c : SyncedCameras(o, static_cast<int>(rig.cameras.size()))) {
    offsets.push_back(rig.cameras[static_cast<std::size_t>(c)].time_offset_ns);
  }
  return offsets;
}

}  // namespace

VioPipeline::VioPipeline(const SensorRig& rig, const VioPipelineOptions& options)
    : options_(options),
      rig_cameras_(static_cast<int>(rig.cameras.size())),
      sync_(options.sync, SyncOffsets(rig, options)),
      stage_(rig, options.vio_camera, options.filter),
      last_forwarded_imu_ns_(std::numeric_limits<int64_t>::min()) {
  sync_index_.assign(static_cast<std::size_t>(rig_cameras_), -1);
  const std::vector<int> cameras = SyncedCameras(options_, rig_cameras_);
  for (std::size_t k = 0; k < cameras.size(); ++k) {
    sync_index_[static_cast<std::size_t>(cameras[k])] = static_cast<int>(k);
  }
}

void VioPipeline::AddImu(const ImuSample& sample) { sync_.AddImu(sample); }

void VioPipeline::AddImage(int camera, int64_t t_cam_ns, const cv::Mat& image_gray8) {
  if (camera < 0 || camera >= rig_cameras_) return;
  const int k = sync_index_[static_cast<std::size_t>(camera)];
  if (k < 0) return;
  sync_.AddImage(k, t_cam_ns, image_gray8);
}

bool VioPipeline::NextOutput(VioFrameOutput* output) {
  while (sync_.PopFrame(&frame_)) {
    // As the daemon's sync stage forwards a frame: a time jump restarts the filter (it cannot
    // go back in time); consecutive frames share their boundary IMU sample, each is given once.
    if (frame_.time_jump_before) {
      stage_.Restart();
      last_forwarded_imu_ns_ = std::numeric_limits<int64_t>::min();
    }
    for (const ImuSample& s : frame_.imu) {
      if (s.t_ns <= last_forwarded_imu_ns_) continue;
      stage_.AddImu(s);
      pending_imu_.push_back(s);
      last_forwarded_imu_ns_ = s.t_ns;
    }
    t_cam_ns_.assign(static_cast<std::size_t>(rig_cameras_), 0);
    images_.assign(static_cast<std::size_t>(rig_cameras_), cv::Mat());
    for (int c = 0; c < rig_cameras_; ++c) {
      const int k = sync_index_[static_cast<std::size_t>(c)];
      if (k < 0) continue;
      t_cam_ns_[static_cast<std::size_t>(c)] = frame_.t_cam_ns[static_cast<std::size_t>(k)];
      images_[static_cast<std::size_t>(c)] = frame_.images[static_cast<std::size_t>(k)];
    }
    for (cv::Mat& m : frame_.images) m.release();
    if (images_[static_cast<std::size_t>(options_.vio_camera)].empty()) {
      stage_.CountFrameWithoutVioCamera();
      continue;
    }
    *output = stage_.AddFrame(t_cam_ns_, images_);
    output->t_cam_ns = t_cam_ns_;
    output->images = images_;
    output->imu.swap(pending_imu_);
    pending_imu_.clear();
    return true;
  }
  return false;
}

}  // namespace vilma::estimator
