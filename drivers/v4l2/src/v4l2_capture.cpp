#include "vilma/drivers/v4l2/v4l2_capture.h"

#include <linux/videodev2.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <sstream>
#include <thread>

#include "vilma/core/error.h"
#include "vilma/drivers/v4l2/pixel_convert.h"

namespace vilma::v4l2 {
namespace {

constexpr int64_t kNsPerS = 1000000000;

int64_t SecondsToNsRounded(double s) { return static_cast<int64_t>(std::llround(s * 1e9)); }

}  // namespace

CaptureOptions::CaptureOptions() {
  format.fourccs = {V4L2_PIX_FMT_GREY, V4L2_PIX_FMT_Y16, V4L2_PIX_FMT_YUYV, V4L2_PIX_FMT_MJPEG};
}

std::string CaptureOptions::Validate() const {
  if (device.empty()) return "device: expected a /dev/video* node or a /dev/v4l/by-id link";
  if (format.fourccs.empty()) return "formats: expected at least one of GREY, Y16, YUYV, MJPG";
  for (uint32_t f : format.fourccs) {
    if (!IsSupportedFourcc(f)) {
      return "formats: '" + FourccName(f) + "' is not one of GREY, Y16, YUYV, MJPG";
    }
  }
  if (format.width < 0 || format.height < 0 || (format.width == 0) != (format.height == 0)) {
    return "width: expected width and height both > 0, or both 0 (the camera's current size)";
  }
  if (!(std::isfinite(format.fps) && format.fps >= 0.0 && format.fps <= 10000.0)) {
    return "fps: expected 0 (the camera's current rate) .. 10000 [Hz]";
  }
  if (format.require_size && format.width == 0) return "require_size: expected width and height";
  if (format.require_fps && format.fps == 0.0) return "require_fps: expected fps > 0";
  if (buffers < 2 || buffers > 32) return "buffers: expected 2 .. 32";
  const std::string controls_error = controls.Validate();
  if (!controls_error.empty()) return controls_error;
  const std::string timestamps_error = timestamps.Validate();
  if (!timestamps_error.empty()) return "timestamps." + timestamps_error;
  if (!(std::isfinite(reconnect_initial_s) && reconnect_initial_s >= 0.001)) {
    return "reconnect_initial_s: expected >= 0.001 [s]";
  }
  if (!(std::isfinite(reconnect_max_s) && reconnect_max_s >= reconnect_initial_s)) {
    return "reconnect_max_s: expected >= reconnect_initial_s [s]";
  }
  if (!(std::isfinite(frame_timeout_s) && frame_timeout_s >= 0.05)) {
    return "frame_timeout_s: expected >= 0.05 [s]";
  }
  if (!(std::isfinite(exposure_readback_s) && exposure_readback_s > 0.0)) {
    return "exposure_readback_s: expected > 0 [s]";
  }
  return "";
}

V4l2Capture::V4l2Capture(V4l2Io* io, const CaptureOptions& options, DriverStatus* status,
                         std::function<int64_t()> measure_offset_ns, LogFunction log)
    : io_(io),
      options_(options),
      status_(status),
      log_(std::move(log)),
      timestamper_(options.timestamps, std::move(measure_offset_ns)) {
  ThrowIfInvalid(options_.Validate(), "v4l2 options");
  for (const char* name : {kCounterFramesDequeued, kCounterDeviceLost, kCounterStreamRestarts,
                           kCounterTimestampFallbacks}) {
    status_->SetCounter(name, 0);
  }
}

V4l2Capture::~V4l2Capture() { Close(); }

void V4l2Capture::Log(const std::string& message) const {
  if (log_) log_(message);
}

void V4l2Capture::Open() {
  if (io_->ResolveNode(options_.device).empty()) {
    throw InputError(FormatInputError(options_.device, "",
                                      "an existing V4L2 device (vilma-v4l2 --list shows them)"));
  }
  const std::string error = OpenDevice(options_.device);
  if (!error.empty()) throw InputError(FormatInputError(options_.device, "", error));
  // The stable name of this camera, for re-opening it after a replug.
  for (const auto& link : io_->ListDeviceLinks()) {
    if (link.second == node_ && link.first.find("/by-id/") != std::string::npos) {
      by_id_link_ = link.first;
      break;
    }
  }
  status_->SetState(status_t::OK, "streaming " + node_);
}

std::string V4l2Capture::OpenDevice(const std::string& path) {
  Close();
  const int fd = io_->Open(path);
  if (fd < 0) return "cannot open: " + ErrnoText(fd);
  fd_ = fd;
  node_ = io_->ResolveNode(path);
  if (node_.empty()) node_ = path;

  v4l2_capability cap{};
  int result = io_->Ioctl(fd_, VIDIOC_QUERYCAP, &cap);
  if (result != 0) {
    Close();
    return "VIDIOC_QUERYCAP failed (" + ErrnoText(result) + "): not a V4L2 device?";
  }
  const uint32_t caps =
      (cap.capabilities & V4L2_CAP_DEVICE_CAPS) != 0 ? cap.device_caps : cap.capabilities;
  // Devices with the multi-planar API only (many MIPI receivers: rkisp1, mxc-isi) stream the
  // same one-plane formats through V4L2_BUF_TYPE_VIDEO_CAPTURE_MPLANE.
  buffer_type_ = (caps & V4L2_CAP_VIDEO_CAPTURE) == 0 && (caps & V4L2_CAP_VIDEO_CAPTURE_MPLANE) != 0
                     ? V4L2_BUF_TYPE_VIDEO_CAPTURE_MPLANE
                     : V4L2_BUF_TYPE_VIDEO_CAPTURE;
  if ((caps & (V4L2_CAP_VIDEO_CAPTURE | V4L2_CAP_VIDEO_CAPTURE_MPLANE)) == 0) {
    Close();
    return "not a video capture node (uvcvideo makes a metadata node beside each camera's "
           "capture node; vilma-v4l2 --list shows which is which)";
  }
  if ((caps & V4L2_CAP_STREAMING) == 0) {
    Close();
    return "the device cannot stream (no V4L2_CAP_STREAMING); read() I/O is not supported";
  }

  // uvcvideo flags every buffer SOE, but without its hardware timestamps (the default) the
  // stamp is the arrival of the frame's first packet: the end of exposure (frame_timestamper.h).
  const std::string driver = FieldText(cap.driver);
  const bool uvc_host_stamps = driver == "uvcvideo" && io_->UvcHardwareTimestamps() != 1;
  timestamper_.SetDeviceStampPoint(uvc_host_stamps ? StampPoint::kEndOfExposure
                                                   : StampPoint::kFromFlags);
  if (uvc_host_stamps && options_.timestamps.stamp_source == StampPoint::kFromFlags) {
    Log(node_ +
        ": uvcvideo without hardware timestamps: buffer stamps are taken as the end of "
        "exposure (first packet)");
  }

  FormatRequest format_request = options_.format;
  format_request.buffer_type = buffer_type_;
  std::string error = NegotiateFormat(io_, fd_, format_request, &format_);
  if (!error.empty()) {
    Close();
    return error;
  }
  for (const std::string& note : format_.notes) Log(node_ + ": " + note);

  ControlReport controls;
  error = ApplyControls(io_, fd_, options_.controls, &controls);
  if (!error.empty()) {
    Close();
    return error;
  }
  for (const std::string& warning : controls.warnings) Log(node_ + ": warning: " + warning);
  fixed_exposure_ = options_.controls.exposure_us > 0.0;
  exposure_us_ = fixed_exposure_ ? controls.exposure_us : ReadExposureUs(io_, fd_);
  exposure_read_at_ns_ = io_->MonotonicNowNs();

  v4l2_requestbuffers request{};
  request.count = static_cast<uint32_t>(options_.buffers);
  request.type = buffer_type_;
  request.memory = V4L2_MEMORY_MMAP;
  result = io_->Ioctl(fd_, VIDIOC_REQBUFS, &request);
  if (result != 0 || request.count < 2) {
    Close();
    return result != 0 ? "VIDIOC_REQBUFS failed: " + ErrnoText(result)
                       : "VIDIOC_REQBUFS gave " + std::to_string(request.count) + " buffers";
  }
  for (uint32_t i = 0; i < request.count; ++i) {
    v4l2_buffer buffer{};
    v4l2_plane planes[VIDEO_MAX_PLANES]{};
    PrepareBuffer(&buffer, planes);
    buffer.index = i;
    result = io_->Ioctl(fd_, VIDIOC_QUERYBUF, &buffer);
    if (result != 0) {
      Close();
      return "VIDIOC_QUERYBUF failed: " + ErrnoText(result);
    }
    const bool mplane = buffer_type_ == V4L2_BUF_TYPE_VIDEO_CAPTURE_MPLANE;
    MappedBuffer mapped;
    mapped.length = mplane ? planes[0].length : buffer.length;
    mapped.address =
        io_->Map(fd_, mapped.length, mplane ? planes[0].m.mem_offset : buffer.m.offset);
    if (mapped.address == nullptr) {
      Close();
      return "mmap of buffer " + std::to_string(i) + " failed";
    }
    buffers_.push_back(mapped);
    result = io_->Ioctl(fd_, VIDIOC_QBUF, &buffer);
    if (result != 0) {
      Close();
      return "VIDIOC_QBUF failed: " + ErrnoText(result);
    }
  }
  int type = static_cast<int>(buffer_type_);
  result = io_->Ioctl(fd_, VIDIOC_STREAMON, &type);
  if (result != 0) {
    Close();
    // uvcvideo: not enough isochronous USB bandwidth for this format, size and rate.
    const std::string hint = result == -ENOSPC
                                 ? " (USB bandwidth: fewer cameras on this controller, a smaller "
                                   "size or rate, or MJPG)"
                                 : "";
    return "VIDIOC_STREAMON failed: " + ErrnoText(result) + hint;
  }
  streaming_ = true;
  last_sequence_ = -1;
  last_frame_ns_ = io_->MonotonicNowNs();
  status_->SetMetric("fps_negotiated", format_.fps);
  status_->SetMetric("width", format_.width);
  status_->SetMetric("height", format_.height);
  status_->SetMetric("exposure_us", static_cast<double>(exposure_us_));
  std::ostringstream text;
  text << "streaming " << node_ << ": " << FourccName(format_.fourcc) << " " << format_.width << "x"
       << format_.height << " at " << format_.fps << " fps, " << buffers_.size() << " buffers, "
       << (fixed_exposure_ ? "exposure " + std::to_string(exposure_us_) + " us" : "auto exposure");
  Log(text.str());
  return "";
}

void V4l2Capture::Close() {
  if (fd_ < 0) return;
  if (streaming_) {
    int type = static_cast<int>(buffer_type_);
    io_->Ioctl(fd_, VIDIOC_STREAMOFF, &type);  // fails with ENODEV after an unplug: fine
    streaming_ = false;
  }
  for (const MappedBuffer& b : buffers_) io_->Unmap(b.address, b.length);
  buffers_.clear();
  v4l2_requestbuffers request{};
  request.type = buffer_type_;
  request.memory = V4L2_MEMORY_MMAP;
  io_->Ioctl(fd_, VIDIOC_REQBUFS, &request);  // count 0: free the buffers
  io_->Close(fd_);
  fd_ = -1;
  node_.clear();
}

void V4l2Capture::PrepareBuffer(v4l2_buffer* buffer, v4l2_plane* planes) const {
  buffer->type = buffer_type_;
  buffer->memory = V4L2_MEMORY_MMAP;
  if (buffer_type_ == V4L2_BUF_TYPE_VIDEO_CAPTURE_MPLANE) {
    buffer->m.planes = planes;
    buffer->length = VIDEO_MAX_PLANES;  // the size of the array
  }
}

V4l2Capture::Outcome V4l2Capture::Classify() {
  v4l2_capability cap{};
  return io_->Ioctl(fd_, VIDIOC_QUERYCAP, &cap) != 0 ? Outcome::kLost : Outcome::kFailed;
}

void V4l2Capture::Lose(Outcome outcome, const std::string& why) {
  Close();
  lost_ = true;
  counted_lost_ = true;
  backoff_s_ = options_.reconnect_initial_s;
  reconnect_attempts_ = 0;
  status_->Increment(outcome == Outcome::kLost ? kCounterDeviceLost : kCounterStreamRestarts);
  status_->SetState(status_t::DEGRADED, why + "; reconnecting");
  Log(why + "; reconnecting");
}

void V4l2Capture::HandleBuffer(const uint8_t* data, std::size_t bytes_used, uint32_t flags,
                               int64_t buffer_ns, int64_t sequence, const FrameCallback& on_frame) {
  const int64_t dequeue_ns = io_->MonotonicNowNs();
  last_frame_ns_ = dequeue_ns;
  status_->Increment(kCounterFramesDequeued);
  // Sequence gaps: frames the camera or the kernel lost. A smaller number is a restart of the
  // counter (or its 32-bit wrap), not a loss.
  if (last_sequence_ >= 0 && sequence > last_sequence_ + 1) {
    status_->Increment(kStatusDropped, sequence - last_sequence_ - 1);
  }
  last_sequence_ = sequence;

  if ((flags & V4L2_BUF_FLAG_ERROR) != 0 || bytes_used == 0) {
    status_->Increment(kStatusMalformed);
    return;
  }
  FrameLayout layout;
  layout.fourcc = format_.fourcc;
  layout.width = format_.width;
  layout.height = format_.height;
  layout.bytes_per_line = format_.bytes_per_line;
  const std::string error = ConvertToGray(data, bytes_used, layout, options_.keep_16_bit, &image_);
  if (!error.empty()) {
    status_->Increment(kStatusMalformed);
    if (status_->Counter(kStatusMalformed) <= 5) Log(node_ + ": frame dropped: " + error);
    return;
  }

  if (!fixed_exposure_ &&
      dequeue_ns - exposure_read_at_ns_ >= SecondsToNsRounded(options_.exposure_readback_s)) {
    exposure_us_ = ReadExposureUs(io_, fd_);
    exposure_read_at_ns_ = dequeue_ns;
    status_->SetMetric("exposure_us", static_cast<double>(exposure_us_));
  }
  const StampedFrame stamp = timestamper_.Stamp(flags, buffer_ns, dequeue_ns, exposure_us_ * 1000);
  status_->SetCounter(kCounterTimestampFallbacks, timestamper_.fallbacks());
  status_->SetCounter(kStatusTimestampResets, timestamper_.steps());

  CapturedFrame frame;
  frame.image = &image_;
  frame.sequence = sequence;
  frame.robot_ns = stamp.robot_ns;
  frame.buffer_monotonic_ns = stamp.fallback ? dequeue_ns : buffer_ns;
  frame.end_of_frame_monotonic_ns = stamp.end_of_frame_monotonic_ns;
  frame.dequeue_monotonic_ns = dequeue_ns;
  frame.exposure_us = exposure_us_;
  on_frame(frame);
}

V4l2Capture::Outcome V4l2Capture::DrainBuffers(const FrameCallback& on_frame) {
  // At most one ring's worth per call: a consumer slower than the camera would otherwise
  // always find another buffer done and never get back to the stop and time-out checks.
  for (std::size_t n = 0; n < buffers_.size(); ++n) {
    v4l2_buffer buffer{};
    v4l2_plane planes[VIDEO_MAX_PLANES]{};
    PrepareBuffer(&buffer, planes);
    int result = io_->Ioctl(fd_, VIDIOC_DQBUF, &buffer);
    if (result == -EAGAIN) return Outcome::kOk;
    if (result != 0) {
      return result == -ENODEV ? Outcome::kLost : Outcome::kFailed;
    }
    if (buffer.index >= buffers_.size()) return Outcome::kFailed;
    const MappedBuffer& mapped = buffers_[buffer.index];
    const int64_t buffer_ns = static_cast<int64_t>(buffer.timestamp.tv_sec) * kNsPerS +
                              static_cast<int64_t>(buffer.timestamp.tv_usec) * 1000;
    // Multi-planar: the plane's data may start data_offset bytes in (bytesused counts them).
    const bool mplane = buffer_type_ == V4L2_BUF_TYPE_VIDEO_CAPTURE_MPLANE;
    const std::size_t offset =
        mplane ? std::min<std::size_t>(planes[0].data_offset, mapped.length) : 0;
    const std::size_t end =
        std::min<std::size_t>(mplane ? planes[0].bytesused : buffer.bytesused, mapped.length);
    const std::size_t used = end > offset ? end - offset : 0;
    HandleBuffer(static_cast<const uint8_t*>(mapped.address) + offset, used, buffer.flags,
                 buffer_ns, buffer.sequence, on_frame);
    // Back to the kernel at once: the ring stays full.
    result = io_->Ioctl(fd_, VIDIOC_QBUF, &buffer);
    if (result != 0) return result == -ENODEV ? Outcome::kLost : Outcome::kFailed;
  }
  return Outcome::kOk;
}

void V4l2Capture::Run(const std::atomic<bool>* stop, double seconds,
                      const FrameCallback& on_frame) {
  const int64_t start_ns = io_->MonotonicNowNs();
  const int64_t end_ns = seconds > 0.0 ? start_ns + SecondsToNsRounded(seconds) : INT64_MAX;
  const int64_t frame_timeout_ns = SecondsToNsRounded(options_.frame_timeout_s);
  int64_t next_attempt_ns = 0;
  auto stopped = [&] {
    return (stop != nullptr && stop->load()) || io_->MonotonicNowNs() >= end_ns;
  };

  while (!stopped()) {
    const int64_t now_ns = io_->MonotonicNowNs();
    if (fd_ < 0) {
      if (!lost_) {  // Run() without Open(), or after Close()
        lost_ = true;
        backoff_s_ = options_.reconnect_initial_s;
        next_attempt_ns = now_ns;
      }
      if (now_ns < next_attempt_ns) {
        const int64_t wait_ns =
            std::min<int64_t>({next_attempt_ns - now_ns, 50000000, end_ns - now_ns});
        std::this_thread::sleep_for(std::chrono::nanoseconds(std::max<int64_t>(wait_ns, 0)));
        continue;
      }
      // After a replug the camera may be another /dev/videoN: its by-id link follows it.
      const std::string path = by_id_link_.empty() ? options_.device : by_id_link_;
      const std::string error =
          io_->ResolveNode(path).empty() ? std::string("not present") : OpenDevice(path);
      ++reconnect_attempts_;
      if (!error.empty()) {
        if (reconnect_attempts_ == 1 || reconnect_attempts_ % 10 == 0) {
          Log(path + ": reconnect attempt " + std::to_string(reconnect_attempts_) + ": " + error);
        }
        // A camera that is there but cannot be configured is an error, not a wait.
        if (error != "not present") status_->SetState(status_t::ERROR, path + ": " + error);
        next_attempt_ns = io_->MonotonicNowNs() + SecondsToNsRounded(backoff_s_);
        backoff_s_ = std::min(2.0 * backoff_s_, options_.reconnect_max_s);
        continue;
      }
      if (counted_lost_) status_->Increment(kStatusReconnects);
      Log("reconnected to " + node_ + " after " + std::to_string(reconnect_attempts_) +
          " attempt(s)");
      lost_ = false;
      counted_lost_ = false;
      status_->SetState(status_t::OK, "streaming " + node_);
      continue;
    }

    const int64_t poll_ms = std::clamp<int64_t>((end_ns - now_ns) / 1000000, 0, 100);
    const int ready = io_->Poll(fd_, static_cast<int>(poll_ms));
    if (ready < 0) {
      // POLLERR: unplugged, or the stream broke.
      const Outcome outcome = Classify();
      Lose(outcome,
           node_ + (outcome == Outcome::kLost ? ": device lost (unplugged?)" : ": stream error"));
      next_attempt_ns = io_->MonotonicNowNs() + SecondsToNsRounded(options_.reconnect_initial_s);
      continue;
    }
    if (ready > 0) {
      Outcome outcome = DrainBuffers(on_frame);
      if (outcome == Outcome::kFailed) outcome = Classify();
      if (outcome != Outcome::kOk) {
        Lose(outcome, node_ + (outcome == Outcome::kLost ? ": device lost (unplugged?)"
                                                         : ": buffer queue error"));
        next_attempt_ns = io_->MonotonicNowNs() + SecondsToNsRounded(options_.reconnect_initial_s);
      }
      continue;
    }
    if (io_->MonotonicNowNs() - last_frame_ns_ > frame_timeout_ns) {
      Lose(Outcome::kFailed,
           node_ + ": no frame for " + std::to_string(options_.frame_timeout_s) + " s (stalled)");
      next_attempt_ns = io_->MonotonicNowNs() + SecondsToNsRounded(options_.reconnect_initial_s);
    }
  }
}

}  // namespace vilma::v4l2
