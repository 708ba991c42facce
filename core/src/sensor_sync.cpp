// Camera-IMU synchronization; the semantics are stated in sensor_sync.h and reasoned in
// docs/design.md ("Synchronization").
#include "vilma/core/sensor_sync.h"

#include <algorithm>
#include <stdexcept>
#include <utility>

namespace vilma {
namespace {

// |a - b| > threshold without signed overflow (stamps come off the wire and can be anything):
// the true difference always fits in uint64, and unsigned arithmetic is modular.
bool Far(int64_t a, int64_t b, int64_t threshold) {
  const uint64_t diff = a > b ? static_cast<uint64_t>(a) - static_cast<uint64_t>(b)
                              : static_cast<uint64_t>(b) - static_cast<uint64_t>(a);
  return diff > static_cast<uint64_t>(threshold);
}

// a - b saturated to int64 (timeouts compare "how much newer" against small thresholds).
int64_t Newer(int64_t a, int64_t b) {
  int64_t d = 0;
  if (__builtin_sub_overflow(a, b, &d)) return a > b ? INT64_MAX : INT64_MIN;
  return d;
}

bool Finite(const ImuSample& s) { return s.omega_I.allFinite() && s.a_I.allFinite(); }

int PresentCameras(const SyncedFrame& f) {
  int n = 0;
  for (const cv::Mat& m : f.images) n += m.empty() ? 0 : 1;
  return n;
}

}  // namespace

std::string SensorSyncOptions::Validate() const {
  if (frame_grouping_tolerance_ns < 0) return "frame_grouping_tolerance_ns: expected >= 0";
  if (incomplete_frame_timeout_ns < 0) return "incomplete_frame_timeout_ns: expected >= 0";
  if (max_imu_wait_ns < 0) return "max_imu_wait_ns: expected >= 0";
  if (imu_gap_threshold_ns <= 0) return "imu_gap_threshold_ns: expected > 0";
  if (max_pending_frames < 1) return "max_pending_frames: expected >= 1";
  if (imu_history_ns <= 0) return "imu_history_ns: expected > 0";
  // A jump must be told apart from the ordinary waits, or waiting would look like a jump.
  if (time_jump_threshold_ns <= std::max({frame_grouping_tolerance_ns,
                                          incomplete_frame_timeout_ns, max_imu_wait_ns})) {
    return "time_jump_threshold_ns: expected more than the grouping tolerance, "
           "incomplete_frame_timeout_ns and max_imu_wait_ns";
  }
  return "";
}

SensorSynchronizer::SensorSynchronizer(const SensorSyncOptions& options,
                                       std::vector<int64_t> camera_time_offsets_ns)
    : options_(options), offsets_ns_(std::move(camera_time_offsets_ns)) {
  const std::string problem = options_.Validate();
  if (!problem.empty()) throw std::invalid_argument("SensorSyncOptions: " + problem);
  if (offsets_ns_.empty()) throw std::invalid_argument("SensorSynchronizer: no cameras");
  const std::size_t n = offsets_ns_.size();
  newest_image_ns_.assign(n, 0);
  camera_seen_.assign(n, 0);
  camera_in_epoch_.assign(n, 0);
}

// Decides whether a sample at t_ns of a stream (own previous stamp last_ns if seen) belongs to
// the current time base. See "Time jumps" in the header.
SensorSynchronizer::Admit SensorSynchronizer::CheckTimeBase(bool* in_epoch, bool seen,
                                                            int64_t last_ns, int64_t t_ns) {
  const int64_t thr = options_.time_jump_threshold_ns;
  if (!has_epoch_) {  // the very first sample of any stream defines the time base
    has_epoch_ = true;
    epoch_ref_ns_ = t_ns;
    *in_epoch = true;
    return Admit::kJoin;
  }
  if (*in_epoch) {
    if ((seen && !Far(t_ns, last_ns, thr)) || !Far(t_ns, epoch_ref_ns_, thr)) {
      return Admit::kAccept;
    }
    return Admit::kJump;
  }
  // Not yet on the current base (another stream jumped, or the stream is new).
  if (!Far(t_ns, epoch_ref_ns_, thr)) {
    *in_epoch = true;
    return Admit::kJoin;
  }
  if (seen && !Far(t_ns, last_ns, thr)) return Admit::kStale;
  return Admit::kJump;
}

void SensorSynchronizer::ResetTimeBase(int64_t t_ns) {
  counters_.frames_dropped_time_jump += static_cast<int64_t>(pending_.size());
  pending_.clear();
  imu_.clear();
  imu_front_handed_out_ = false;
  has_closed_ = false;
  any_camera_ = false;
  imu_in_epoch_ = false;
  std::fill(camera_in_epoch_.begin(), camera_in_epoch_.end(), 0);
  epoch_ref_ns_ = t_ns;
  jump_pending_ = true;
}

void SensorSynchronizer::AddImu(const ImuSample& sample) {
  ++counters_.imu_received;
  if (!Finite(sample)) {
    ++counters_.imu_invalid;
    return;
  }
  const int64_t t = sample.t_ns;
  bool joined_after_jump = false;
  switch (CheckTimeBase(&imu_in_epoch_, imu_seen_, newest_imu_ns_, t)) {
    case Admit::kStale:
      ++counters_.imu_stale;
      return;
    case Admit::kJump:
      ++counters_.imu_time_jumps;
      ResetTimeBase(t);
      imu_in_epoch_ = true;
      joined_after_jump = true;
      break;
    case Admit::kJoin:
      // Rejoining after another stream's jump: this stream jumped too.
      if (imu_seen_ && Far(t, newest_imu_ns_, options_.time_jump_threshold_ns)) {
        ++counters_.imu_time_jumps;
      }
      joined_after_jump = true;
      break;
    case Admit::kAccept:
      break;
  }
  if (!joined_after_jump && imu_seen_) {
    if (t == newest_imu_ns_) {
      ++counters_.imu_duplicates;
      return;
    }
    if (t < newest_imu_ns_) {
      ++counters_.imu_out_of_order;
      return;
    }
    if (Newer(t, newest_imu_ns_) > options_.imu_gap_threshold_ns) ++counters_.imu_gaps;
  }
  imu_seen_ = true;
  newest_imu_ns_ = t;
  epoch_ref_ns_ = std::max(epoch_ref_ns_, t);
  imu_.push_back(sample);
  // Bound the buffer: drop the front while the sample after it is older than the history
  // window, so the front is always the last sample at or before (newest - history).
  while (imu_.size() >= 2 && Newer(t, imu_[1].t_ns) > options_.imu_history_ns) {
    if (!imu_front_handed_out_) ++counters_.imu_discarded;
    imu_front_handed_out_ = false;
    imu_.pop_front();
  }
}

void SensorSynchronizer::AddImage(int camera_index, int64_t t_cam_ns, const cv::Mat& image) {
  ++counters_.images_received;
  if (camera_index < 0 || camera_index >= num_cameras() || image.empty()) {
    ++counters_.images_invalid;
    return;
  }
  const std::size_t i = static_cast<std::size_t>(camera_index);
  int64_t t = 0;
  if (__builtin_add_overflow(t_cam_ns, offsets_ns_[i], &t)) {
    ++counters_.images_invalid;
    return;
  }
  bool in_epoch = camera_in_epoch_[i] != 0;
  bool joined_after_jump = false;
  switch (CheckTimeBase(&in_epoch, camera_seen_[i] != 0, newest_image_ns_[i], t)) {
    case Admit::kStale:
      ++counters_.images_stale;
      return;
    case Admit::kJump:
      ++counters_.image_time_jumps;
      ResetTimeBase(t);
      in_epoch = true;
      joined_after_jump = true;
      break;
    case Admit::kJoin:
      if (camera_seen_[i] && Far(t, newest_image_ns_[i], options_.time_jump_threshold_ns)) {
        ++counters_.image_time_jumps;
      }
      joined_after_jump = true;
      break;
    case Admit::kAccept:
      break;
  }
  camera_in_epoch_[i] = in_epoch ? 1 : 0;
  if (!joined_after_jump && camera_seen_[i]) {
    if (t == newest_image_ns_[i]) {
      ++counters_.images_duplicate;
      return;
    }
    if (t < newest_image_ns_[i]) {
      ++counters_.images_out_of_order;
      return;
    }
  }
  camera_seen_[i] = 1;
  newest_image_ns_[i] = t;
  epoch_ref_ns_ = std::max(epoch_ref_ns_, t);
  if (!any_camera_ || t > newest_camera_ns_) newest_camera_ns_ = t;
  any_camera_ = true;

  const int64_t tol = options_.frame_grouping_tolerance_ns;
  if (has_closed_ && Newer(t, last_released_ns_) <= tol) {
    ++counters_.images_late;  // its frame was already released or dropped
    return;
  }
  // Join the nearest pending frame within tolerance (pending_ is short: linear scan).
  std::size_t best = pending_.size();
  uint64_t best_diff = 0;
  for (std::size_t k = 0; k < pending_.size(); ++k) {
    const int64_t tf = pending_[k].t_imu_ns;
    if (Far(t, tf, tol)) continue;
    const uint64_t diff = t > tf ? static_cast<uint64_t>(t) - static_cast<uint64_t>(tf)
                                 : static_cast<uint64_t>(tf) - static_cast<uint64_t>(t);
    if (best == pending_.size() || diff < best_diff) {
      best = k;
      best_diff = diff;
    }
  }
  if (best < pending_.size()) {
    SyncedFrame& f = pending_[best];
    if (!f.images[i].empty()) {
      ++counters_.images_duplicate;  // a second image of this camera for one frame
      return;
    }
    f.images[i] = image;  // shared, not copied
    f.t_cam_ns[i] = t_cam_ns;
    // The frame time is that of its lowest-index camera present.
    bool lowest = true;
    for (std::size_t j = 0; j < i; ++j) lowest = lowest && f.images[j].empty();
    if (lowest) {
      f.t_imu_ns = t;
      // Keep pending_ sorted (the time moved by at most the tolerance).
      std::size_t k = best;
      while (k > 0 && pending_[k - 1].t_imu_ns > pending_[k].t_imu_ns) {
        std::swap(pending_[k - 1], pending_[k]);
        --k;
      }
      while (k + 1 < pending_.size() && pending_[k + 1].t_imu_ns < pending_[k].t_imu_ns) {
        std::swap(pending_[k + 1], pending_[k]);
        ++k;
      }
    }
    return;
  }
  SyncedFrame f;
  f.t_imu_ns = t;
  f.t_cam_ns.assign(offsets_ns_.size(), 0);
  f.images.resize(offsets_ns_.size());
  f.images[i] = image;
  f.t_cam_ns[i] = t_cam_ns;
  auto pos = std::upper_bound(pending_.begin(), pending_.end(), t,
                              [](int64_t v, const SyncedFrame& p) { return v < p.t_imu_ns; });
  pending_.insert(pos, std::move(f));
  while (static_cast<int>(pending_.size()) > options_.max_pending_frames) {
    DropFront(&counters_.frames_dropped_overflow);
  }
}

void SensorSynchronizer::DropFront(int64_t* counter) {
  ++*counter;
  if (!has_closed_ || pending_.front().t_imu_ns > last_released_ns_) {
    last_released_ns_ = pending_.front().t_imu_ns;
  }
  has_closed_ = true;
  pending_.pop_front();
}

bool SensorSynchronizer::PopFrame(SyncedFrame* frame) {
  while (!pending_.empty()) {
    SyncedFrame& f = pending_.front();
    const int64_t waited = any_camera_ ? Newer(newest_camera_ns_, f.t_imu_ns) : 0;
    const bool complete = PresentCameras(f) == num_cameras();
    if (!complete && waited <= options_.incomplete_frame_timeout_ns) return false;
    const bool covered = !imu_.empty() && imu_.back().t_ns >= f.t_imu_ns;
    if (!covered) {
      if (waited > options_.max_imu_wait_ns) {
        DropFront(&counters_.frames_dropped_no_imu);
        continue;
      }
      return false;
    }
    // c = first sample at or after the frame time (imu_ is sorted; usually a few samples).
    std::size_t c = 0;
    while (imu_[c].t_ns < f.t_imu_ns) ++c;
    frame->t_imu_ns = f.t_imu_ns;
    frame->t_cam_ns = std::move(f.t_cam_ns);
    frame->images = std::move(f.images);
    frame->imu.clear();
    frame->imu.insert(frame->imu.end(), imu_.begin(), imu_.begin() + static_cast<long>(c) + 1);
    frame->imu_overlaps_previous = imu_front_handed_out_;
    frame->time_jump_before = jump_pending_;
    jump_pending_ = false;
    imu_.erase(imu_.begin(), imu_.begin() + static_cast<long>(c));
    imu_front_handed_out_ = true;
    ++counters_.frames_released;
    if (!complete) ++counters_.frames_incomplete;
    last_released_ns_ = frame->t_imu_ns;
    has_closed_ = true;
    pending_.pop_front();
    return true;
  }
  return false;
}

}  // namespace vilma
