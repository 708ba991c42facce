// A V4L2 camera emulated in the process, behind the V4l2Io interface: what `vilma-v4l2 --fake`
// runs, and what the tests drive the capture loop, the negotiation and `--list` against.
//
// It follows the kernel's semantics (videodev2.h, the vb2 buffer queue, uvcvideo), not just
// the happy path:
//  - QUERYCAP with device_caps; a second node of the same camera is a metadata node without
//    V4L2_CAP_VIDEO_CAPTURE, as uvcvideo creates one (/dev/video1 beside /dev/video0);
//  - ENUM_FMT / ENUM_FRAMESIZES (discrete) / ENUM_FRAMEINTERVALS; S_FMT / TRY_FMT adjust an
//    unsupported pixel format to the first one and a size to the nearest supported one, and
//    fill bytesperline / sizeimage; S_PARM picks the nearest frame interval; S_FMT with
//    buffers allocated is EBUSY;
//  - QUERYCTRL with V4L2_CTRL_FLAG_NEXT_CTRL, QUERYMENU, G_CTRL / S_CTRL with range checks
//    (ERANGE); exposure_time_absolute is inactive and refuses writes (EACCES) unless
//    auto_exposure is manual, as UVC cameras do;
//  - REQBUFS (MMAP only) / QUERYBUF / mmap / QBUF / DQBUF (EAGAIN when nothing is ready,
//    O_NONBLOCK) / STREAMON / STREAMOFF (returns every buffer to the application);
//  - frames are complete every frame interval on CLOCK_MONOTONIC; a frame that finds no queued
//    buffer is lost but still consumes a sequence number (so the application sees the gap);
//    buffers are stamped V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC | V4L2_BUF_FLAG_TSTAMP_SRC_SOE with
//    the start of exposure (the frame's completion minus the exposure control's time), or
//    with the completion time when the spec's flags say TSTAMP_SRC_EOF;
//  - unplugging: every call on an open descriptor fails with ENODEV, poll reports an error,
//    the node disappears (open: ENOENT) until the camera is plugged in again, possibly under
//    another /dev/videoN while its /dev/v4l/by-id link keeps its name.
// Thread-safe (one mutex): a test may unplug it while the capture loop runs.
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <mutex>
#include <opencv2/core.hpp>
#include <set>
#include <string>
#include <vector>

#include "vilma/drivers/v4l2/v4l2_io.h"

namespace vilma::v4l2 {

struct FakeFormat {
  uint32_t fourcc = 0;
  std::vector<std::pair<int, int>> sizes;  // (width, height) [px]
  std::vector<int> fps;                    // frame rates offered for every size [Hz]
};

struct FakeCameraSpec {
  std::string node = "/dev/video0";
  std::string metadata_node = "/dev/video1";  // "" = none
  std::string by_id_link = "/dev/v4l/by-id/usb-vilma_Fake_Camera_0001-video-index0";
  std::string driver = "vilma-fake";
  std::string card = "vilma fake camera";
  std::string bus_info = "usb-0000:00:14.0-1";
  std::vector<FakeFormat> formats;  // empty = DefaultFormats()
  // Timestamp flags of every buffer (V4L2_BUF_FLAG_TIMESTAMP_* | V4L2_BUF_FLAG_TSTAMP_SRC_*).
  uint32_t timestamp_flags = 0;  // 0 = MONOTONIC | SOE
  // With driver "uvcvideo": the module's hwtimestamps parameter. Off, the fake stamps a frame
  // as uvcvideo then does: the arrival of its first packet (= its end of exposure here, the
  // fake reading out instantly), still flagged SOE.
  bool uvc_hw_timestamps = false;
  // MJPG frames as UVC cameras send them: without Huffman tables (DHT), which decoders must
  // supply (the standard tables of JPEG Annex K.3).
  bool mjpg_without_huffman_tables = true;
  int max_buffers = 32;
  // The multi-planar API only (V4L2_CAP_VIDEO_CAPTURE_MPLANE, as many MIPI receivers): every
  // format has one plane.
  bool multiplanar = false;

  static std::vector<FakeFormat> DefaultFormats();
};

// What the fake did (for tests).
struct FakeCameraStats {
  int64_t frames_due = 0;        // sequence numbers handed out while streaming
  int64_t frames_delivered = 0;  // filled buffers
  int64_t frames_lost_no_buffer = 0;
  int64_t frames_dropped_scripted = 0;
  int64_t opens = 0;
  int64_t unplugs = 0;
};

// The picture of frame `sequence` (CV_8UC1): a diagonal ramp moving 2 grey levels per frame,
// smooth enough for JPEG. YUYV carries it as Y, Y16 as (value << 8) | (x & 0xff).
cv::Mat FakeFramePattern(int64_t sequence, int width, int height);

class FakeV4l2Io : public V4l2Io {
 public:
  explicit FakeV4l2Io(FakeCameraSpec spec = {});
  ~FakeV4l2Io() override;

  int Open(const std::string& path) override;
  void Close(int fd) override;
  int Ioctl(int fd, unsigned long request, void* arg) override;
  void* Map(int fd, std::size_t length, int64_t offset) override;
  void Unmap(void* address, std::size_t length) override;
  int Poll(int fd, int timeout_ms) override;
  std::vector<std::string> ListDeviceNodes() override;
  std::vector<std::pair<std::string, std::string>> ListDeviceLinks() override;
  std::string ResolveNode(const std::string& path) override;
  int64_t MonotonicNowNs() override;
  int UvcHardwareTimestamps() override;

  // Scripted faults. Sequence numbers count from STREAMON.
  void DropSequences(const std::set<int64_t>& sequences);     // lost in the "sensor"
  void CorruptSequences(const std::set<int64_t>& sequences);  // delivered with FLAG_ERROR
  // Unplug now; plug in again after `down_s` seconds as `new_node` ("" = the same node).
  void Unplug(double down_s, const std::string& new_node = "");
  // Unplug when `frames` more frames have come due (counted over streams), then as Unplug().
  void UnplugAfterFrames(int64_t frames, double down_s, const std::string& new_node = "");
  // A fixed latency between a frame's stamp and its buffer being ready [ns] (default 0).
  void SetDeliveryDelayNs(int64_t delay_ns);

  FakeCameraStats stats() const;
  // Current control value by V4L2 id (for tests).
  int32_t ControlValue(uint32_t id) const;
  // The node the camera is at now ("" while unplugged).
  std::string CurrentNode() const;

 private:
  struct State;
  std::unique_ptr<State> state_;
  mutable std::mutex mutex_;
};

}  // namespace vilma::v4l2
