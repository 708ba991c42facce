// vilma-estimatord's pipeline (architecture.md section 3, docs/daemon.md):
//
//   input thread --[spsc]--> sync thread --[spsc]--> filter thread --[spsc]--> publisher thread
//   (LCM handlers                (SensorSynchronizer)    (VioFilter)             (VILMA_ODOM,
//    or an LCM log file)                                                          VILMA_STATUS)
//
// Each stage owns its state; data moves through bounded lock-free single-producer
// single-consumer rings (boost::lockfree::spsc_queue); images are decoded into a pool of
// preallocated slots (ImagePool). No mutex on the per-frame path. A consumer with nothing to do
// sleeps on a semaphore that its producer posts.
//
// Live (LCM) input: IMU samples are never dropped on purpose (a full queue drops and counts
// them: a bug to be reported); frames are thinned when the filter is behind; every drop is
// counted and published on VILMA_STATUS. Log input (--input-log): no pacing and blocking
// backpressure instead of drops, so the output is the same on every run.
#pragma once

#include <cstdint>
#include <memory>
#include <string>

#include "vilma/core/rig.h"
#include "vilma/daemon/daemon_options.h"

namespace vilma::daemon {

struct DaemonSummary {
  int64_t frames_filtered = 0;
  int64_t poses_published = 0;
  int64_t malformed_messages = 0;
  int64_t drops = 0;  // every message or frame dropped by the daemon (not the synchronizer)
  std::string report;  // the final counters, one "name value" per line
  // Map building (mapping.enabled).
  bool mapping = false;
  bool map_saved = false;        // mapping.save_dir given and the map was written
  std::string map_error;         // why the map could not be saved ("" if it was or not asked)
  bool stream_finished = false;  // mapstored acknowledged the END of the mission
  std::string map_report;        // one line: vertices, landmarks, stream, save

  // "N frames, P poses published, M malformed messages, D drops" (core/report.h's shape).
  std::string BriefReport() const;
  // "stopped: " + BriefReport(), the final counters ("name value" lines), and the map's line
  // when mapping; `program` ("vilma-estimatord: ") goes before the first and the map line.
  std::string FullReport(const std::string& program = "") const;
};

class EstimatorDaemon {
 public:
  // Opens LCM (or the input log) and subscribes. Throws InputError for a bad rig / camera
  // combination, an LCM URL that does not open, or an unreadable log.
  EstimatorDaemon(const DaemonOptions& options, const SensorRig& rig);
  ~EstimatorDaemon();
  EstimatorDaemon(const EstimatorDaemon&) = delete;
  EstimatorDaemon& operator=(const EstimatorDaemon&) = delete;

  // Runs the pipeline until RequestStop() or, with an input log, the end of the log; then
  // flushes every stage, with map building finishes the mission (streams its end to
  // mapstored, saves it into mapping.save_dir: this can take seconds for a large map; statuses
  // keep coming at status_period_s meanwhile), publishes a last status (STOPPING) and returns. Messages about bad
  // input and faults (rate limited) go to stderr, one line each. Call once.
  DaemonSummary Run();

  // Thread-safe and async-signal-safe (one atomic store).
  void RequestStop();

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace vilma::daemon
