// The minimum-delay clock filter of clock_sync.h: lower convex hull of (device, host - device)
// pairs over a sliding window, line fit of Zhang et al. (the hull edge over the mean device time).
#include "vilma/core/clock_sync.h"

#include <algorithm>
#include <cmath>
#include <ctime>

#include "vilma/core/error.h"
#include "vilma/core/validate.h"

namespace vilma {

std::string ClockSyncOptions::Validate() const {
  VILMA_RETURN_IF_ERROR(ValidatePositive("window_s", window_s));
  VILMA_RETURN_IF_ERROR(ValidateAtLeast("max_window_observations", max_window_observations, 2));
  VILMA_RETURN_IF_ERROR(ValidateAtLeast("min_observations", min_observations, 1));
  VILMA_RETURN_IF_ERROR(ValidateNonNegative("min_skew_span_s", min_skew_span_s));
  if (min_skew_span_s >= window_s) return "min_skew_span_s: expected < window_s";
  VILMA_RETURN_IF_ERROR(ValidateNonNegative("max_skew_ppm", max_skew_ppm));
  VILMA_RETURN_IF_ERROR(ValidatePositive("outlier_threshold_ms", outlier_threshold_ms));
  VILMA_RETURN_IF_ERROR(ValidatePositive("jump_below_threshold_ms", jump_below_threshold_ms));
  VILMA_RETURN_IF_ERROR(ValidatePositive("jump_confirm_s", jump_confirm_s));
  return "";
}

namespace {

// > 0 when o -> a -> b turns counter-clockwise (b left of the ray o->a). 128-bit: differences
// of a 10 s window in ns times offsets of seconds overflow 64 bits.
// GCC and clang extension; `__extension__` keeps -Wpedantic quiet about it.
__extension__ typedef __int128 Int128;

Int128 Cross(int64_t ox, int64_t oy, int64_t ax, int64_t ay, int64_t bx, int64_t by) {
  return static_cast<Int128>(ax - ox) * (by - oy) - static_cast<Int128>(ay - oy) * (bx - ox);
}

int64_t MsToNs(double ms) { return static_cast<int64_t>(std::llround(ms * 1e6)); }
int64_t SToNs(double s) { return static_cast<int64_t>(std::llround(s * 1e9)); }

}  // namespace

ClockSync::ClockSync(const ClockSyncOptions& options) : options_(options) {
  ThrowIfInvalid(options_.Validate(), "clock sync options");
}

void ClockSync::Reset() {
  started_ = false;
  window_.clear();
  hull_.clear();
  outlier_run_.clear();
  sum_x_ = 0.0;
  line_a_ = 0.0;
  line_b_ = 0.0;
}

void ClockSync::Restart(int64_t device_ns, int64_t host_arrival_ns) {
  Reset();
  started_ = true;
  device_ref_ns_ = device_ns;
  offset_ref_ns_ = host_arrival_ns - device_ns;
  Append(Point{0, 0});
  Refit();
}

bool ClockSync::IsValid() const {
  return started_ && static_cast<int64_t>(window_.size()) >= options_.min_observations;
}

void ClockSync::AddObservation(int64_t device_ns, int64_t host_arrival_ns) {
  ++observations_;
  if (!started_) {
    Restart(device_ns, host_arrival_ns);
    return;
  }
  const Point p{device_ns - device_ref_ns_, (host_arrival_ns - device_ns) - offset_ref_ns_};
  if (p.x < window_.back().x) {  // the device clock went backwards: it was reset
    ++resets_;
    Restart(device_ns, host_arrival_ns);
    return;
  }
  if (IsValid()) {
    // Above the line = more delay than the least delayed pairs; below = negative delay, which
    // only a clock step explains.
    const double residual_ns = static_cast<double>(p.y) - LineY(static_cast<double>(p.x));
    if (residual_ns < -static_cast<double>(MsToNs(options_.jump_below_threshold_ms))) {
      ++resets_;
      Restart(device_ns, host_arrival_ns);
      return;
    }
    if (residual_ns > static_cast<double>(MsToNs(options_.outlier_threshold_ms))) {
      ++outliers_;
      outlier_run_.push_back(p);
      // Persistent in device time, or so many that the device clock must be stuck (a frozen
      // clock would otherwise grow the run without bound).
      if (outlier_run_.back().x - outlier_run_.front().x >= SToNs(options_.jump_confirm_s) ||
          static_cast<int64_t>(outlier_run_.size()) >= options_.max_window_observations) {
        // Persistent: the host clock stepped forward (or the device clock back by less than
        // it ran since the last pair). Restart from the run, in absolute stamps.
        ++resets_;
        const std::vector<Point> run = outlier_run_;
        const int64_t device_ref = device_ref_ns_;
        const int64_t offset_ref = offset_ref_ns_;
        Restart(run.front().x + device_ref, run.front().x + device_ref + run.front().y + offset_ref);
        for (std::size_t i = 1; i < run.size(); ++i) {
          const int64_t device_i = run[i].x + device_ref;
          AddObservation(device_i, device_i + run[i].y + offset_ref);
          --observations_;  // counted when it first came
        }
      }
      return;
    }
  }
  outlier_run_.clear();
  Append(p);
  EvictOld();
  Refit();
}

void ClockSync::Append(const Point& p) {
  if (!window_.empty() && p.x == window_.back().x) {
    // A repeated device stamp: only its least delayed arrival matters.
    if (p.y < window_.back().y) {
      window_.back().y = p.y;
      RebuildHull();
    }
    return;
  }
  window_.push_back(p);
  sum_x_ += static_cast<double>(p.x);
  // Andrew's monotone chain, one point at a time (x increases): drop vertices that no longer
  // turn counter-clockwise.
  while (hull_.size() >= 2) {
    const Point& o = hull_[hull_.size() - 2];
    const Point& a = hull_.back();
    if (Cross(o.x, o.y, a.x, a.y, p.x, p.y) > 0) break;
    hull_.pop_back();
  }
  hull_.push_back(p);
}

void ClockSync::EvictOld() {
  // Evict in batches (10 % slack) so that the O(n) hull rebuild runs once per tenth of a window,
  // not once per pair (the oldest pair is always a hull vertex).
  const int64_t window_ns = SToNs(options_.window_s);
  const int64_t newest_x = window_.back().x;
  const auto max_size = static_cast<std::size_t>(options_.max_window_observations);
  const bool too_old = window_.front().x < newest_x - window_ns - window_ns / 10;
  const bool too_many = window_.size() > max_size + max_size / 10;
  if (!too_old && !too_many) return;
  while (window_.size() > 1 &&
         (window_.front().x < newest_x - window_ns || window_.size() > max_size)) {
    sum_x_ -= static_cast<double>(window_.front().x);
    window_.pop_front();
  }
  RebuildHull();
}

void ClockSync::RebuildHull() {
  hull_.clear();
  std::deque<Point> points;
  points.swap(window_);
  sum_x_ = 0.0;
  for (const Point& p : points) Append(p);
}

void ClockSync::Refit() {
  // Lowest vertex: the least delayed pair; an offset-only line through it when the window is
  // too short for a skew.
  const auto lowest =
      std::min_element(hull_.begin(), hull_.end(),
                       [](const Point& a, const Point& b) { return a.y < b.y; });
  const int64_t span_ns = window_.back().x - window_.front().x;
  if (hull_.size() < 2 || span_ns < SToNs(options_.min_skew_span_s)) {
    line_a_ = 0.0;
    line_b_ = static_cast<double>(lowest->y);
    return;
  }
  // Zhang et al.: minimise sum_i (y_i - a x_i - b) subject to y_i >= a x_i + b, i.e. maximise
  // the line at the mean x; the optimum is the lower-hull edge whose x-range holds the mean.
  const double mean_x = sum_x_ / static_cast<double>(window_.size());
  auto right = std::upper_bound(hull_.begin(), hull_.end(), mean_x,
                                [](double x, const Point& p) { return x < static_cast<double>(p.x); });
  if (right == hull_.begin()) ++right;
  if (right == hull_.end()) --right;
  const Point& l = *(right - 1);
  const Point& r = *right;
  double a = static_cast<double>(r.y - l.y) / static_cast<double>(r.x - l.x);
  const double max_a = options_.max_skew_ppm * 1e-6;
  if (std::abs(a) <= max_a) {
    line_a_ = a;
    line_b_ = static_cast<double>(l.y) - a * static_cast<double>(l.x);
    return;
  }
  // Implausible skew (a few pairs only, or huge jitter): clamp it and keep the line under all
  // vertices.
  a = std::clamp(a, -max_a, max_a);
  double b = static_cast<double>(hull_.front().y) - a * static_cast<double>(hull_.front().x);
  for (const Point& p : hull_) {
    b = std::min(b, static_cast<double>(p.y) - a * static_cast<double>(p.x));
  }
  line_a_ = a;
  line_b_ = b;
}

int64_t ClockSync::DeviceToHostNs(int64_t device_ns) const {
  if (!started_) return device_ns;
  const double x = static_cast<double>(device_ns - device_ref_ns_);
  return device_ns + offset_ref_ns_ + static_cast<int64_t>(std::llround(LineY(x)));
}

ClockSyncStats ClockSync::stats() const {
  ClockSyncStats s;
  s.observations = observations_;
  s.resets = resets_;
  s.outliers = outliers_;
  s.window_size = static_cast<int64_t>(window_.size());
  s.hull_size = static_cast<int64_t>(hull_.size());
  s.valid = IsValid();
  if (started_) {
    s.offset_ns = offset_ref_ns_ +
                  static_cast<int64_t>(std::llround(LineY(static_cast<double>(window_.back().x))));
  }
  s.skew_ppm = line_a_ * 1e6;
  return s;
}

int64_t MeasureRealtimeMinusMonotonicNs(int reads) {
  auto to_ns = [](const timespec& t) {
    return static_cast<int64_t>(t.tv_sec) * 1000000000 + static_cast<int64_t>(t.tv_nsec);
  };
  int64_t best_width = -1;
  int64_t best_offset = 0;
  for (int i = 0; i < std::max(1, reads); ++i) {
    timespec m0{}, r{}, m1{};
    clock_gettime(CLOCK_MONOTONIC, &m0);
    clock_gettime(CLOCK_REALTIME, &r);
    clock_gettime(CLOCK_MONOTONIC, &m1);
    const int64_t width = to_ns(m1) - to_ns(m0);
    if (best_width < 0 || width < best_width) {
      best_width = width;
      // The realtime read happened between the two monotonic reads: take their midpoint.
      best_offset = to_ns(r) - (to_ns(m0) + width / 2);
    }
  }
  return best_offset;
}

}  // namespace vilma
