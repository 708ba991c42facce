// ClockSyncOptions in the drivers' YAML option files (the `clock_sync:` section of
// config/aravis.yaml, config/usb_imu.yaml): one field list, read and written through
// core/options_fields.h by every driver (VisitClockSyncFields under InSection("clock_sync", v)).
#pragma once

#include "vilma/core/clock_sync.h"

namespace vilma {

// The field list (core/options_fields.h); Options = ClockSyncOptions or const ClockSyncOptions.
// Validation stays with ClockSyncOptions::Validate (the drivers' Validate prefixes
// "clock_sync.").
template <typename Options, typename Visitor>
void VisitClockSyncFields(Options& o, Visitor&& v) {
  v("", "window_s", o.window_s);
  v("", "max_window_observations", o.max_window_observations);
  v("", "min_observations", o.min_observations);
  v("", "min_skew_span_s", o.min_skew_span_s);
  v("", "max_skew_ppm", o.max_skew_ppm);
  v("", "outlier_threshold_ms", o.outlier_threshold_ms);
  v("", "jump_below_threshold_ms", o.jump_below_threshold_ms);
  v("", "jump_confirm_s", o.jump_confirm_s);
}

}  // namespace vilma
