// A GenICam camera through Aravis 0.8: discovery, opening by id or serial, configuration from
// AravisOptions, a stream with a ring of buffers, and the buffers' frames (docs/drivers.md).
// The only file of vilma that includes <arv.h>; no LCM here.
#pragma once

#include <atomic>
#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "vilma/drivers/aravis/aravis_options.h"
#include "vilma/drivers/aravis/pixel_convert.h"

// Aravis's types, declared so that users of this header need not include <arv.h>.
typedef struct _ArvCamera ArvCamera;
typedef struct _ArvStream ArvStream;
typedef struct _ArvBuffer ArvBuffer;

namespace vilma::aravis {

struct CameraInfo {
  std::string id;           // Aravis device id (what --device takes)
  std::string vendor;
  std::string model;
  std::string serial;
  std::string protocol;     // "GigEVision", "USB3Vision", "Fake"
  std::string physical_id;  // MAC address (GigE) or USB path
  std::string address;      // IP address (GigE)
};

// Cameras visible now: GigE Vision and USB3 Vision ones, or with `fake` only Aravis's
// in-process fake camera (Fake_1).
std::vector<CameraInfo> DiscoverCameras(bool fake);

// The camera that `device` names (id, serial, physical id or address; "" = the first), or an
// error listing what was found.
std::string FindCamera(const std::vector<CameraInfo>& cameras, const std::string& device,
                       CameraInfo* found);

// One frame popped from the stream; give it back with AravisCamera::Requeue.
struct CameraFrame {
  ArvBuffer* buffer = nullptr;
  bool ok = false;          // ARV_BUFFER_STATUS_SUCCESS with an image payload
  std::string status;       // Aravis buffer status name ("SUCCESS", "MISSING_PACKETS", ...)
  uint64_t frame_id = 0;
  int64_t device_ns = 0;       // camera timestamp [ns of the camera clock] (Aravis scales ticks)
  int64_t host_arrival_ns = 0; // first packet's arrival [ns, CLOCK_REALTIME]
  RawFrame raw;             // valid while the buffer is held
  bool format_known = false;
};

class AravisCamera {
 public:
  // Opens and configures the camera (all settings of `options` that concern it). Throws
  // std::runtime_error naming the setting the camera refused.
  AravisCamera(const CameraInfo& info, const AravisOptions& options);
  ~AravisCamera();
  AravisCamera(const AravisCamera&) = delete;
  AravisCamera& operator=(const AravisCamera&) = delete;

  // Creates the stream with options.buffers buffers and starts acquisition.
  void Start();
  // Stops acquisition (idempotent).
  void Stop();

  // Waits up to `timeout_us` for a frame; false on timeout.
  bool Pop(uint64_t timeout_us, CameraFrame* frame);
  void Requeue(CameraFrame* frame);

  // Fires a software trigger (trigger_source Software).
  void SoftwareTrigger();

  // Heartbeat lost (Aravis's "control-lost" signal, from its own thread).
  bool control_lost() const { return control_lost_.load(); }

  // Current exposure time [us] (0 if the camera has none); reads the camera.
  double ReadExposureUs();

  // The stream's unsigned counters (n_completed_buffers, n_failures, n_underruns,
  // n_missing_packets, n_resend_requests, ...; which ones depends on GigE / USB3 / fake).
  std::vector<std::pair<std::string, uint64_t>> StreamCounters() const;

  const CameraInfo& info() const { return info_; }
  // GigE Vision (and the fake camera) number frames with 16-bit ids that skip 0.
  bool frame_ids_wrap_16bit() const { return frame_ids_wrap_16bit_; }
  // What the camera runs at after configuration.
  int width() const { return width_; }
  int height() const { return height_; }
  double frame_rate_hz() const { return frame_rate_hz_; }
  std::string pixel_format() const { return pixel_format_; }

 private:
  void Configure(const AravisOptions& options);

  CameraInfo info_;
  AravisOptions options_;
  ArvCamera* camera_ = nullptr;
  ArvStream* stream_ = nullptr;
  bool acquiring_ = false;
  bool frame_ids_wrap_16bit_ = false;
  int width_ = 0;
  int height_ = 0;
  double frame_rate_hz_ = 0.0;
  std::string pixel_format_;
  unsigned long control_lost_handler_ = 0;
  std::atomic<bool> control_lost_{false};
};

// The text of `vilma-aravis --list` for one camera: identity, sensor, region and binning
// bounds, pixel formats, frame rate / exposure / gain bounds and auto modes, trigger sources,
// and GigE packet size. Throws std::runtime_error if the camera cannot be opened.
std::string DescribeCamera(const CameraInfo& info);

}  // namespace vilma::aravis
