// Device clock -> host clock mapping for the drivers (docs/drivers.md, "Clock
// synchronization").
//
// A sensor stamps each sample with its own clock (`device_ns`); the host sees the sample arrive
// a transport delay later (`host_arrival_ns`, on the host clock the driver publishes, normally
// CLOCK_REALTIME: the robot's `utime`). Model (Zhang, Liu and Xia, "Clock synchronization
// algorithms for network measurements", INFOCOM 2002):
//
//   host_arrival_i = device_i + offset + skew * (device_i - device_ref) + delay_i,  delay_i >= 0
//
// Every pair (x_i = device_i, y_i = host_arrival_i - device_i) lies on or above the line
// y = offset + skew * x, so the filter keeps the lower convex hull of the pairs of a sliding
// window and fits the line that lies under all of them and is highest at the window's mean x
// (the linear programme of Zhang et al.; its solution is the hull edge that spans the mean).
// Only the least delayed samples shape that line: jitter and delay spikes above it do not move
// it. The fixed part of the delay (the smallest delay the transport ever has, e.g. the time a
// serial packet takes on the wire) cannot be seen this way; the caller subtracts it from the
// arrival stamp before AddObservation.
//
// A device clock that goes backwards or steps, or a host clock step (NTP), shows up as pairs
// far below the line (impossible: negative delay) or persistently far above it; the filter
// then restarts from the new pairs and counts a reset.
#pragma once

#include <cstdint>
#include <deque>
#include <string>
#include <vector>

namespace vilma {

struct ClockSyncOptions {
  // Length of the sliding window of pairs [s of device time]. Longer averages the skew better;
  // shorter follows temperature-driven drift faster.
  double window_s = 10.0;
  // Most pairs kept in the window (the oldest go first); bounds memory and the refit cost.
  int max_window_observations = 20000;
  // Pairs needed before DeviceToHostNs is trusted (IsValid()).
  int min_observations = 10;
  // Below this span of device time the skew is not estimated (offset only): a short baseline
  // turns delay jitter into a large skew error [s].
  double min_skew_span_s = 1.0;
  // Largest plausible |skew| of a device crystal against the host [ppm]; fits beyond it are
  // clamped. Typical crystals: < 100 ppm.
  double max_skew_ppm = 1000.0;
  // A pair above the line by more than this is a delay outlier (not used for the fit) [ms].
  double outlier_threshold_ms = 10.0;
  // A pair below the line by more than this cannot be a delay (negative): a clock jump, the
  // filter restarts at once [ms].
  double jump_below_threshold_ms = 10.0;
  // Outliers that persist this long (device time, no inlier between) are a clock jump, not a
  // delay spike: the filter restarts from them [s].
  double jump_confirm_s = 0.5;

  // "" when valid, else "field: expectation".
  std::string Validate() const;
};

struct ClockSyncStats {
  int64_t observations = 0;    // pairs given to AddObservation since construction
  int64_t resets = 0;          // restarts after a detected clock jump (not Reset() calls)
  int64_t outliers = 0;        // pairs above the line by more than outlier_threshold_ms
  int64_t window_size = 0;     // pairs in the window now
  int64_t hull_size = 0;       // vertices of the window's lower hull now
  bool valid = false;          // IsValid()
  int64_t offset_ns = 0;       // host - device at the newest device stamp [ns]
  double skew_ppm = 0.0;       // d(host - device)/d(device) [ppm]
};

class ClockSync {
 public:
  // Throws InputError when `options` are invalid.
  explicit ClockSync(const ClockSyncOptions& options = {});

  // One pair: the sample's device stamp and the host time it arrived (minus any known fixed
  // transport latency). Pairs come in device-time order; a device stamp that goes backwards is a
  // device clock reset.
  void AddObservation(int64_t device_ns, int64_t host_arrival_ns);

  // Enough pairs since the last (re)start to map.
  bool IsValid() const;

  // The host time of the event stamped `device_ns` by the device. Before IsValid() the best
  // guess so far (the newest pair's host - device, or `device_ns` itself with no pair at all).
  int64_t DeviceToHostNs(int64_t device_ns) const;

  ClockSyncStats stats() const;

  // Forgets all pairs (e.g. the device was replugged); counters are kept.
  void Reset();

  const ClockSyncOptions& options() const { return options_; }

 private:
  // A pair relative to the reference of the current run: x = device - device_ref,
  // y = (host - device) - offset_ref (both ns; small enough for exact doubles).
  struct Point {
    int64_t x;
    int64_t y;
  };

  void Restart(int64_t device_ns, int64_t host_arrival_ns);
  void Append(const Point& p);
  void EvictOld();
  void RebuildHull();
  void Refit();
  double LineY(double x) const { return line_b_ + line_a_ * x; }

  ClockSyncOptions options_;
  bool started_ = false;
  int64_t device_ref_ns_ = 0;  // device stamp of the first pair of this run
  int64_t offset_ref_ns_ = 0;  // host - device of the first pair of this run
  std::deque<Point> window_;   // pairs in device-time order
  std::vector<Point> hull_;    // lower convex hull of window_, x increasing
  double sum_x_ = 0.0;         // of window_, for its mean
  double line_a_ = 0.0;        // fitted skew [ns/ns]
  double line_b_ = 0.0;        // fitted y at x = 0 [ns]
  std::vector<Point> outlier_run_;  // consecutive outliers (a jump, if they persist)
  int64_t observations_ = 0;
  int64_t resets_ = 0;
  int64_t outliers_ = 0;
};

// CLOCK_REALTIME - CLOCK_MONOTONIC [ns], from the tightest of `reads` brackets
// (monotonic, realtime, monotonic): for drivers whose kernel stamps are CLOCK_MONOTONIC (V4L2
// buffers) to put them on the robot's clock. Re-measure now and then: NTP slews REALTIME.
int64_t MeasureRealtimeMinusMonotonicNs(int reads = 16);

}  // namespace vilma
