#include "vilma/drivers/aravis/frame_timing.h"

namespace vilma::aravis {

FrameIdTracker::Step FrameIdTracker::Next(uint64_t frame_id) {
  Step step;
  if (have_last_) {
    if (wraps_16bit_ && last_id_ <= 0xFFFF && frame_id <= 0xFFFF) {
      // Distance forward on the 16-bit circle without 0: ids 1..65535 (65535 values).
      const int64_t last = static_cast<int64_t>(last_id_ == 0 ? 65535 : last_id_);
      const int64_t now = static_cast<int64_t>(frame_id == 0 ? 65535 : frame_id);
      const int64_t forward = ((now - last) % 65535 + 65535) % 65535;
      if (forward == 0) {
        step.restarted = true;  // a repeated id
      } else if (forward > 32767) {
        // Half the circle backwards is a restart, not 32768 lost frames.
        step.restarted = true;
      } else {
        step.dropped = forward - 1;
      }
    } else if (frame_id > last_id_) {
      step.dropped = static_cast<int64_t>(frame_id - last_id_ - 1);
    } else {
      step.restarted = true;
    }
  }
  seq_ = have_seq_ ? seq_ + 1 + step.dropped : 0;
  have_seq_ = true;
  have_last_ = true;
  last_id_ = frame_id;
  step.seq = seq_;
  return step;
}

FrameStamper::FrameStamper(const FrameStampOptions& options, const ClockSyncOptions& sync_options)
    : options_(options), sync_(sync_options) {}

int64_t FrameStamper::Stamp(int64_t device_ns, int64_t host_arrival_ns, int64_t exposure_ns) {
  // Host time at which the exposure ended, if the arrival had no variable delay.
  const int64_t exposure_end_ns = host_arrival_ns - options_.transport_latency_ns;
  int64_t mid_exposure_ns;
  if (options_.use_device_clock && device_ns != 0) {
    const int64_t event_upper_bound_ns =
        options_.stamp_is_exposure_start ? exposure_end_ns - exposure_ns : exposure_end_ns;
    sync_.AddObservation(device_ns, event_upper_bound_ns);
    const int64_t event_ns = sync_.DeviceToHostNs(device_ns);
    mid_exposure_ns = options_.stamp_is_exposure_start ? event_ns + exposure_ns / 2
                                                       : event_ns - exposure_ns / 2;
  } else {
    if (options_.use_device_clock) ++frames_without_device_stamp_;
    mid_exposure_ns = exposure_end_ns - exposure_ns / 2;
  }
  return mid_exposure_ns + options_.time_offset_ns;
}

}  // namespace vilma::aravis
