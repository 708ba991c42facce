// The capture loop of vilma-v4l2: one V4L2 camera, streaming into a ring of mmap buffers,
// each frame converted to gray, stamped on the robot's clock and handed to a callback
// (which publishes it), with drop detection and recovery from device loss.
//
//  - Open: QUERYCAP (a video capture node with streaming), format negotiation
//    (format_negotiation.h), controls (camera_controls.h), REQBUFS/QUERYBUF/mmap of
//    `buffers` buffers, all queued, STREAMON.
//  - Loop: poll, then dequeue every ready buffer, convert, stamp, call back, queue it again at
//    once (the kernel fills the others meanwhile). A gap in the buffers' `sequence` numbers
//    is frames the kernel or the camera lost (no free buffer, USB bandwidth): counted as
//    dropped. A buffer flagged V4L2_BUF_FLAG_ERROR, too short, or an MJPG frame that does not
//    decode is counted as malformed and not published.
//  - Recovery: ENODEV (unplugged) or any other failure of poll/ioctl closes everything and
//    re-opens with exponential backoff (reconnect_initial_s doubling up to reconnect_max_s);
//    no frame for frame_timeout_s while streaming restarts the stream the same way (a stalled
//    UVC camera). The re-open goes through the camera's /dev/v4l/by-id link when it has one,
//    found at the first open: after a replug the kernel may give the camera another
//    /dev/videoN. Sequence numbers restart at the new stream and are not counted as drops.
// Counters and metrics go to the DriverStatus (driver_status.h): published by the caller;
// dropped, malformed, reconnects, timestamp_resets (realtime clock steps) and the driver's own
// device_lost, stream_restarts, timestamp_fallbacks, frames_dequeued.
#pragma once

#include <atomic>
#include <cstdint>
#include <functional>
#include <opencv2/core.hpp>
#include <string>
#include <vector>

#include "vilma/drivers/driver_status.h"
#include "vilma/drivers/v4l2/camera_controls.h"
#include "vilma/drivers/v4l2/format_negotiation.h"
#include "vilma/drivers/v4l2/frame_timestamper.h"
#include "vilma/drivers/v4l2/v4l2_io.h"

struct v4l2_buffer;
struct v4l2_plane;

namespace vilma::v4l2 {

// Driver-specific counter names (besides the standard ones of driver_status.h).
constexpr const char kCounterDeviceLost[] = "device_lost";
constexpr const char kCounterStreamRestarts[] = "stream_restarts";
constexpr const char kCounterTimestampFallbacks[] = "timestamp_fallbacks";
constexpr const char kCounterFramesDequeued[] = "frames_dequeued";

struct CaptureOptions {
  std::string device = "/dev/video0";  // node or /dev/v4l/by-id/... link
  FormatRequest format;                // fourccs default: GREY, Y16, YUYV, MJPG
  bool keep_16_bit = false;            // Y16 published as GRAY16 (else GRAY8, high byte)
  int buffers = 4;                     // mmap ring size (2 .. 32)
  ControlOptions controls;
  TimestampOptions timestamps;
  double reconnect_initial_s = 0.1;  // first wait after a device loss [s]
  double reconnect_max_s = 2.0;      // the backoff's ceiling [s]
  double frame_timeout_s = 2.0;      // no frame for this long: restart the stream [s]
  double exposure_readback_s = 1.0;  // auto exposure: read the camera's exposure this often [s]

  CaptureOptions();
  // "" or "field: expectation".
  std::string Validate() const;
};

struct CapturedFrame {
  const cv::Mat* image = nullptr;         // CV_8UC1, or CV_16UC1 (keep_16_bit and Y16)
  int64_t sequence = 0;                   // the kernel's buffer sequence number
  int64_t robot_ns = 0;                   // mid-exposure on CLOCK_REALTIME [ns] (utime * 1000)
  int64_t buffer_monotonic_ns = 0;        // the buffer's stamp (or dequeue time on fallback)
  int64_t end_of_frame_monotonic_ns = 0;  // when the frame was complete (frame_timestamper.h)
  int64_t dequeue_monotonic_ns = 0;       // when the driver got it
  int64_t exposure_us = 0;                // 0 if unknown
};

class V4l2Capture {
 public:
  using FrameCallback = std::function<void(const CapturedFrame&)>;
  using LogFunction = std::function<void(const std::string&)>;

  // `io` and `status` must outlive the capture. `measure_offset_ns` gives
  // REALTIME - MONOTONIC (MeasureRealtimeMinusMonotonicNs).
  V4l2Capture(V4l2Io* io, const CaptureOptions& options, DriverStatus* status,
              std::function<int64_t()> measure_offset_ns, LogFunction log);
  ~V4l2Capture();
  V4l2Capture(const V4l2Capture&) = delete;
  V4l2Capture& operator=(const V4l2Capture&) = delete;

  // First open. Throws InputError when the device is absent or cannot deliver what the
  // options ask (the message names the device and what it offers).
  void Open();

  // Streams until *stop is true or `seconds` (> 0) have passed, recovering from device loss.
  // Calls `on_frame` for every good frame, from this thread.
  void Run(const std::atomic<bool>* stop, double seconds, const FrameCallback& on_frame);

  // Stops streaming and closes the device (also done by the destructor).
  void Close();

  const NegotiatedFormat& format() const { return format_; }
  // The node open now (a by-id link resolved), "" when closed.
  const std::string& node() const { return node_; }
  // The /dev/v4l/by-id link of the camera, if it has one.
  const std::string& by_id_link() const { return by_id_link_; }

 private:
  struct MappedBuffer {
    void* address = nullptr;
    std::size_t length = 0;
  };
  enum class Outcome { kOk, kLost, kFailed };

  std::string OpenDevice(const std::string& path);
  // Dequeues and handles every ready buffer; kLost/kFailed on device errors.
  Outcome DrainBuffers(const FrameCallback& on_frame);
  void HandleBuffer(const uint8_t* data, std::size_t bytes_used, uint32_t flags, int64_t buffer_ns,
                    int64_t sequence, const FrameCallback& on_frame);
  void Lose(Outcome outcome, const std::string& why);
  // After a failed poll or ioctl: kLost when the device is gone (QUERYCAP fails: uvcvideo
  // first fails DQBUF with EIO, then every ioctl with ENODEV), else kFailed.
  Outcome Classify();
  // Type and memory of a buffer struct; for the multi-planar API, `planes` (VIDEO_MAX_PLANES
  // entries) as its plane array.
  void PrepareBuffer(v4l2_buffer* buffer, v4l2_plane* planes) const;
  void Log(const std::string& message) const;

  V4l2Io* io_;
  CaptureOptions options_;
  DriverStatus* status_;
  LogFunction log_;
  FrameTimestamper timestamper_;

  int fd_ = -1;
  uint32_t buffer_type_ = 1;  // V4L2_BUF_TYPE_VIDEO_CAPTURE or _MPLANE, from QUERYCAP
  bool streaming_ = false;
  std::vector<MappedBuffer> buffers_;
  NegotiatedFormat format_;
  std::string node_;
  std::string by_id_link_;
  cv::Mat image_;  // conversion target, reused

  int64_t last_sequence_ = -1;  // of the current stream
  int64_t last_frame_ns_ = 0;   // monotonic time of the last dequeue (or stream start)
  int64_t exposure_us_ = 0;     // fixed, or the last auto readback
  int64_t exposure_read_at_ns_ = 0;
  bool fixed_exposure_ = false;
  double backoff_s_ = 0.0;
  int64_t reconnect_attempts_ = 0;
  bool lost_ = false;  // waiting to reconnect
  bool counted_lost_ = false;
};

}  // namespace vilma::v4l2
