// vilma-aravis's run loop: camera frames -> image_t on LCM, status on VILMA_STATUS_<CHANNEL>,
// reconnect when the camera is lost (docs/drivers.md, "vilma-aravis").
#pragma once

#include <atomic>
#include <cstdint>
#include <iosfwd>
#include <string>

#include "vilma/drivers/aravis/aravis_options.h"

namespace lcm {
class LCM;
}

namespace vilma::aravis {

// What a run did, in the one shape of core/report.h.
struct AravisRunSummary {
  int64_t published = 0;
  int64_t dropped = 0;         // frame id gaps
  int64_t failed_buffers = 0;  // buffers Aravis delivered incomplete (missing packets, timeout)
  int64_t reconnects = 0;
  double latency_p50_ms = 0.0;  // buffer arrival -> LCM publish, last 512 frames
  double latency_p99_ms = 0.0;
  std::string stream;          // the stream's own totals (Aravis's counters), one line
  std::string error;           // why the run failed ("" = clean stop)

  // "N frames published, D dropped, I incomplete, R reconnects" (+ "; error: ...").
  std::string BriefReport() const;
  // "<program>: stopped: <brief>; latency to publish p50 .. ms, p99 .. ms (...)\n" and
  // "<program>: stream: <stream>\n": what the driver prints when it stops.
  std::string FullReport(const std::string& program = "vilma-aravis") const;
};

// Opens the camera (options.device / options.fake), streams until `stop` becomes true,
// options.seconds or options.frames is reached, publishing every complete frame on
// options.DataChannel() through `lcm` and a status every options.status_period_s. A camera
// that cannot be opened at the start is an error; one lost later is reopened every
// options.reconnect_interval_s (counted in `reconnects`). `log` gets one line per event.
AravisRunSummary RunAravisDriver(const AravisOptions& options, lcm::LCM* lcm,
                                 const std::atomic<bool>* stop, std::ostream* log);

// --list: the cameras found and the chosen one's features; `error` says why none was chosen
// (no camera, or none matches options.device). Throws std::runtime_error if the chosen camera
// cannot be opened.
std::string ListCameras(const AravisOptions& options, std::string* error);

}  // namespace vilma::aravis
