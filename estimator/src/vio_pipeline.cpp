#include "vilma/estimator/vio_pipeline.h"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <limits>

#include "vilma/core/error.h"

namespace vilma::estimator {

// ---------------------------------------------------------------- filter stage

std::string TimeJumpOptions::Validate() const {
  // Above ~5 s the bridged propagation is dead reckoning without IMU: not worth resuming.
  if (!(std::isfinite(resume_max_gap_s) && resume_max_gap_s >= 0.0 && resume_max_gap_s <= 5.0)) {
    return "resume_max_gap_s: expected 0 .. 5 [s]";
  }
  return "";
}

VioFilterStage::VioFilterStage(const SensorRig& rig, int vio_camera, const FilterOptions& options,
                               const TimeJumpOptions& jump)
    : rig_(rig), vio_camera_(vio_camera), options_(options), jump_(jump) {
  const std::string e = jump_.Validate();
  if (!e.empty()) throw InputError(FormatInputError("time jump options", "", e));
  filter_ = std::make_unique<VioFilter>(rig_, vio_camera_, options_);  // validates
  time_offset_ns_ = rig_.cameras[static_cast<std::size_t>(vio_camera_)].time_offset_ns;
  // Samples of a window up to resume_max_gap_s long, with 50 % margin for rate error.
  max_jumped_imu_ = static_cast<std::size_t>(1.5 * jump_.resume_max_gap_s * rig_.imu.rate_hz) + 16;
}

void VioFilterStage::AddImu(const ImuSample& sample) {
  filter_->AddImu(sample);
  last_omega_m_ = sample.omega_I;
  if (!have_imu_ || sample.t_ns > last_imu_ns_) last_imu_ns_ = sample.t_ns;
  have_imu_ = true;
  if (snapshot_ != nullptr && !jumped_imu_overflow_) {
    if (jumped_imu_.size() < max_jumped_imu_) {
      jumped_imu_.push_back(sample);
    } else {
      jumped_imu_overflow_ = true;  // longer than any gap a resume bridges
      jumped_imu_.clear();
    }
  }
}

int64_t VioFilterStage::RestampJumpedImu(int64_t t_next_ns) {
  // The jumped stretch: n samples b_1..b_n at the IMU's period dt (stamps + an unknown offset
  // D). If they are the samples missing from the resumed timeline between its last sample a
  // and the return's first c, they fit: a < b_1 - D, b_n - D < c. The synchronizer drops
  // samples it had not handed out at each jump (up to about a frame period at both ends), so
  // the stretch is shorter than the gap by slack = (c - a) - (n + 1) dt >= 0 and its place in
  // the gap is known only within slack: it is centred, b_1 - D = a + dt + slack / 2 (a time
  // error of at most slack / 2). It is not used when it does not fit (slack < -dt / 2), when
  // its own spacing is not the IMU's (a stretch with gaps or another rate: span off by more
  // than 5 %), or when slack > 0.25 s (too little of the gap would be covered to be sure).
  const std::size_t n = jumped_imu_.size();
  if (jumped_imu_overflow_ || n < 2) return 0;
  const double dt_ns = 1e9 / rig_.imu.rate_hz;
  const double a = static_cast<double>(snapshot_last_imu_ns_);
  const double c = static_cast<double>(t_next_ns);
  const double span = static_cast<double>(jumped_imu_.back().t_ns - jumped_imu_.front().t_ns);
  const double expected_span = static_cast<double>(n - 1) * dt_ns;
  if (std::abs(span - expected_span) > 0.05 * expected_span + dt_ns) return 0;
  const double slack = (c - a) - span - 2.0 * dt_ns;
  if (slack < -0.5 * dt_ns || slack > 0.25e9) return 0;
  const double first = a + dt_ns + std::max(0.0, slack) * 0.5;
  const int64_t offset_ns = jumped_imu_.front().t_ns - static_cast<int64_t>(std::llround(first));
  int64_t given = 0;
  for (ImuSample s : jumped_imu_) {
    s.t_ns -= offset_ns;
    if (s.t_ns <= snapshot_last_imu_ns_ || s.t_ns >= t_next_ns) continue;
    filter_->AddImu(s);
    last_omega_m_ = s.omega_I;
    ++given;
  }
  return given;
}

bool VioFilterStage::OnTimeJump(int64_t t_next_ns) {
  const int64_t max_gap_ns = static_cast<int64_t>(jump_.resume_max_gap_s * 1e9);
  restart_pending_ = true;
  if (snapshot_ != nullptr && t_next_ns > snapshot_last_imu_ns_ &&
      t_next_ns - snapshot_last_imu_ns_ <= max_gap_ns) {
    // Back on the snapshot's timeline: the samples between its last one and t_next_ns came on
    // the jumped time base; re-stamped into the gap when they fit, else the filter takes the
    // gap as an IMU gap (propagation interpolates across it).
    resets_discarded_ += filter_->stats().resets;
    filter_ = std::move(snapshot_);
    counters_.imu_restamped += RestampJumpedImu(t_next_ns);
    jumped_imu_.clear();
    jumped_imu_overflow_ = false;
    last_imu_ns_ = snapshot_last_imu_ns_;
    have_imu_ = true;
    ever_initialized_ = true;
    resume_pending_ = true;
    ++counters_.resumes;
    return true;
  }
  if (filter_->initialized() && have_imu_ && max_gap_ns > 0) {
    if (snapshot_ != nullptr) resets_discarded_ += snapshot_->stats().resets;
    snapshot_ = std::move(filter_);
    snapshot_last_imu_ns_ = last_imu_ns_;
  } else {
    // An older snapshot stays; the samples of this filter are not the ones missing from
    // its timeline (a jump came between them).
    resets_discarded_ += filter_->stats().resets;
  }
  jumped_imu_.clear();
  jumped_imu_overflow_ = false;
  filter_ = std::make_unique<VioFilter>(rig_, vio_camera_, options_);
  have_imu_ = false;
  ever_initialized_ = false;
  ++counters_.restarts;
  return false;
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
  out.resumed = resume_pending_;
  restart_pending_ = false;
  resume_pending_ = false;
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
  counters_.resets = resets_discarded_ + filter_->stats().resets +
                     (snapshot_ != nullptr ? snapshot_->stats().resets : 0);

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
  const std::string j = time_jump.Validate();
  if (!j.empty()) return "time_jump." + j;
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
      stage_(rig, options.vio_camera, options.filter, options.time_jump),
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
      stage_.OnTimeJump(frame_.imu.empty() ? frame_.t_imu_ns : frame_.imu.front().t_ns);
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
