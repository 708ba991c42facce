// Frame ids -> drops, and camera timestamps -> utime (docs/drivers.md, "vilma-aravis").
// Independent of Aravis: unit-tested on synthetic ids and clocks.
#pragma once

#include <cstdint>
#include <string>

#include "vilma/core/clock_sync.h"

namespace vilma::aravis {

// Counts frames lost between consecutive frame ids (GenICam block ids) and numbers the frames
// that arrive with a gap-preserving sequence (image_t.seq: +1 per frame the camera made).
//
// GigE Vision 1.x block ids are 16 bit and skip 0 (..., 65534, 65535, 1, 2, ...); GigE Vision
// 2 extended ids and USB3 Vision ids are 64 bit. An id that does not advance (equal or, for 64
// bit ids, smaller) means the camera restarted its count: no drop is counted, the sequence
// goes on by one.
class FrameIdTracker {
 public:
  explicit FrameIdTracker(bool wraps_16bit) : wraps_16bit_(wraps_16bit) {}

  struct Step {
    int64_t dropped = 0;     // frames missing before this one
    bool restarted = false;  // the id went backwards / repeated (camera restart)
    int64_t seq = 0;         // this frame's sequence number (first frame: 0)
  };
  Step Next(uint64_t frame_id);

  // The camera was reopened: its ids start over; the sequence continues (+1, no drops known).
  void Reconnected() { have_last_ = false; }

 private:
  bool wraps_16bit_;
  bool have_last_ = false;
  bool have_seq_ = false;
  uint64_t last_id_ = 0;
  int64_t seq_ = 0;
};

struct FrameStampOptions {
  bool use_device_clock = true;         // false: from the host arrival time only
  bool stamp_is_exposure_start = true;  // false: the device stamp marks the end of exposure
  int64_t time_offset_ns = 0;           // added to every result
  // Least time from the end of exposure to the buffer's arrival stamp (readout + transfer of
  // the first packet) [ns]: the constant part of the delay that arrival times cannot reveal.
  int64_t transport_latency_ns = 0;
};

// Mid-exposure time on the host clock of each frame, from the camera's stamp and the buffer's
// host arrival time.
//
// Model: a frame's first packet arrives (host clock) at exposure end + transport latency +
// a variable delay >= 0 (queuing, interrupt moderation, scheduling). In device mode the pairs
// (device stamp, arrival - transport latency - [exposure, if the stamp marks its start]) go
// through a ClockSync (minimum-delay filter): the least delayed frames pin the device->host
// line, the jittered ones do not move it. A camera that sends no stamp (0) falls back to host
// mode for that frame: exposure end = arrival - transport latency.
class FrameStamper {
 public:
  FrameStamper(const FrameStampOptions& options, const ClockSyncOptions& sync_options);

  // `device_ns`: the camera's stamp [ns of its clock], 0 if none; `host_arrival_ns`: when the
  // buffer arrived [ns, CLOCK_REALTIME]; `exposure_ns`: the exposure time [ns].
  int64_t Stamp(int64_t device_ns, int64_t host_arrival_ns, int64_t exposure_ns);

  // The camera was reopened: its clock may have restarted.
  void Reconnected() { sync_.Reset(); }

  const ClockSync& clock_sync() const { return sync_; }
  int64_t frames_without_device_stamp() const { return frames_without_device_stamp_; }

 private:
  FrameStampOptions options_;
  ClockSync sync_;
  int64_t frames_without_device_stamp_ = 0;
};

}  // namespace vilma::aravis
