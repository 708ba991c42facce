// The fake camera (fake_v4l2_io.h): its timeline, buffers, plugging and the public calls; the
// ioctls are in fake_v4l2_ioctl.cpp, the shared state in fake_v4l2_state.h.
#include "vilma/drivers/v4l2/fake_v4l2_io.h"

#include <cerrno>
#include <chrono>
#include <thread>

#include "fake_v4l2_state.h"

namespace vilma::v4l2 {
namespace fake_detail {

FakeControl MakeControl(uint32_t id, uint32_t type, const char* name, int32_t minimum,
                        int32_t maximum, int32_t step, int32_t default_value) {
  FakeControl c;
  c.query.id = id;
  c.query.type = type;
  CopyName(name, c.query.name, sizeof(c.query.name));
  c.query.minimum = minimum;
  c.query.maximum = maximum;
  c.query.step = step;
  c.query.default_value = default_value;
  c.value = default_value;
  return c;
}

std::vector<uint8_t> StripHuffmanTables(const std::vector<uint8_t>& jpeg) {
  std::vector<uint8_t> out(jpeg.begin(), jpeg.begin() + 2);  // SOI
  std::size_t i = 2;
  while (i + 4 <= jpeg.size() && jpeg[i] == 0xFF) {
    const int marker = jpeg[i + 1];
    const std::size_t length = (static_cast<std::size_t>(jpeg[i + 2]) << 8) | jpeg[i + 3];
    if (length < 2 || i + 2 + length > jpeg.size()) break;  // not a JPEG we understand
    if (marker == 0xDA) {  // start of scan: the rest is entropy-coded data
      out.insert(out.end(), jpeg.begin() + static_cast<std::ptrdiff_t>(i), jpeg.end());
      return out;
    }
    if (marker != 0xC4) {
      out.insert(out.end(), jpeg.begin() + static_cast<std::ptrdiff_t>(i),
                 jpeg.begin() + static_cast<std::ptrdiff_t>(i + 2 + length));
    }
    i += 2 + length;
  }
  return jpeg;  // not a JPEG we understand: unchanged
}

}  // namespace fake_detail

using fake_detail::FakeControl;
using fake_detail::kNsPerS;
using fake_detail::kOffsetStride;
using fake_detail::MakeControl;
using fake_detail::SystemMonotonicNs;

std::vector<FakeFormat> FakeCameraSpec::DefaultFormats() {
  return {
      {V4L2_PIX_FMT_GREY, {{640, 480}, {752, 480}, {320, 240}}, {60, 30, 20, 15}},
      {V4L2_PIX_FMT_Y16, {{640, 480}, {320, 240}}, {30, 15}},
      {V4L2_PIX_FMT_YUYV, {{640, 480}, {320, 240}}, {30, 15}},
      {V4L2_PIX_FMT_MJPEG, {{1280, 720}, {640, 480}}, {30, 15}},
  };
}

cv::Mat FakeFramePattern(int64_t sequence, int width, int height) {
  cv::Mat image(height, width, CV_8UC1);
  const int shift = static_cast<int>((sequence * 2) % 256);
  for (int y = 0; y < height; ++y) {
    uint8_t* row = image.ptr<uint8_t>(y);
    for (int x = 0; x < width; ++x) row[x] = static_cast<uint8_t>((x / 4 + y / 4 + shift) & 0xff);
  }
  return image;
}

FakeV4l2Io::FakeV4l2Io(FakeCameraSpec spec) : state_(std::make_unique<State>()) {
  State& s = *state_;
  if (spec.formats.empty()) spec.formats = FakeCameraSpec::DefaultFormats();
  if (spec.timestamp_flags == 0) {
    spec.timestamp_flags = V4L2_BUF_FLAG_TIMESTAMP_MONOTONIC | V4L2_BUF_FLAG_TSTAMP_SRC_SOE;
  }
  s.spec = std::move(spec);
  s.current_node = s.spec.node;
  s.format.pixelformat = s.spec.formats.front().fourcc;
  s.format.width = static_cast<uint32_t>(s.spec.formats.front().sizes.front().first);
  s.format.height = static_cast<uint32_t>(s.spec.formats.front().sizes.front().second);
  s.Adjust(&s.format);
  s.default_format = s.format;
  s.interval_denominator = static_cast<uint32_t>(s.spec.formats.front().fps.front());
  // The controls of a typical UVC camera, with its defaults (aperture-priority auto exposure).
  FakeControl exposure_auto =
      MakeControl(V4L2_CID_EXPOSURE_AUTO, V4L2_CTRL_TYPE_MENU, "Auto Exposure", 0, 3, 1,
                  V4L2_EXPOSURE_APERTURE_PRIORITY);
  exposure_auto.menu = {{V4L2_EXPOSURE_MANUAL, "Manual Mode"},
                        {V4L2_EXPOSURE_APERTURE_PRIORITY, "Aperture Priority Mode"}};
  s.controls.push_back(
      MakeControl(V4L2_CID_BRIGHTNESS, V4L2_CTRL_TYPE_INTEGER, "Brightness", -64, 64, 1, 0));
  s.controls.push_back(MakeControl(V4L2_CID_GAIN, V4L2_CTRL_TYPE_INTEGER, "Gain", 0, 100, 1, 32));
  s.controls.push_back(exposure_auto);
  s.controls.push_back(MakeControl(V4L2_CID_EXPOSURE_ABSOLUTE, V4L2_CTRL_TYPE_INTEGER,
                                   "Exposure Time, Absolute", 1, 5000, 1, 156));
}

FakeV4l2Io::~FakeV4l2Io() = default;

int FakeV4l2Io::Open(const std::string& path) {
  std::lock_guard<std::mutex> lock(mutex_);
  State& s = *state_;
  s.MaybeReplug(SystemMonotonicNs());
  if (s.current_node.empty()) return -ENOENT;
  const bool is_link = path == s.spec.by_id_link;
  const bool is_node = path == s.current_node;
  const bool is_metadata = !s.spec.metadata_node.empty() && path == s.spec.metadata_node &&
                           s.current_node == s.spec.node;
  if (!is_link && !is_node && !is_metadata) return -ENOENT;
  const int fd = s.next_fd++;
  s.files[fd] = State::OpenFile{s.generation, is_metadata};
  ++s.stats.opens;
  return fd;
}

void FakeV4l2Io::Close(int fd) {
  std::lock_guard<std::mutex> lock(mutex_);
  State& s = *state_;
  if (s.files.erase(fd) == 0) return;
  // Closing the queue owner stops streaming and frees the buffers (vb2_fop_release).
  if (fd == s.owner_fd) s.FreeBuffers();
}

int FakeV4l2Io::Ioctl(int fd, unsigned long request, void* arg) {
  std::lock_guard<std::mutex> lock(mutex_);
  State& s = *state_;
  const auto it = s.files.find(fd);
  if (it == s.files.end()) return -EBADF;
  if (it->second.generation != s.generation) return -ENODEV;
  const int64_t now_ns = SystemMonotonicNs();
  return s.DoIoctl(fd, it->second, request, arg, now_ns);
}

void* FakeV4l2Io::Map(int fd, std::size_t length, int64_t offset) {
  std::lock_guard<std::mutex> lock(mutex_);
  State& s = *state_;
  const auto it = s.files.find(fd);
  if (it == s.files.end() || it->second.generation != s.generation || fd != s.owner_fd) {
    return nullptr;
  }
  if (offset % kOffsetStride != 0) return nullptr;
  const std::size_t index = static_cast<std::size_t>(offset / kOffsetStride);
  if (index >= s.buffers.size() || length > s.buffers[index].memory.size()) return nullptr;
  ++s.buffers[index].mappings;
  return s.buffers[index].memory.data();
}

void FakeV4l2Io::Unmap(void* address, std::size_t) {
  std::lock_guard<std::mutex> lock(mutex_);
  for (State::Buffer& b : state_->buffers) {
    if (b.memory.data() == address && b.mappings > 0) --b.mappings;
  }
}

int FakeV4l2Io::Poll(int fd, int timeout_ms) {
  const int64_t deadline_ns = SystemMonotonicNs() + static_cast<int64_t>(timeout_ms) * 1000000;
  while (true) {
    int64_t wake_ns = deadline_ns;
    {
      std::lock_guard<std::mutex> lock(mutex_);
      State& s = *state_;
      const auto it = s.files.find(fd);
      if (it == s.files.end()) return -EBADF;
      if (it->second.generation != s.generation) return -ENODEV;
      const int64_t now_ns = SystemMonotonicNs();
      // vb2_poll: an error when not streaming or nothing is queued or done.
      if (!s.streaming || (s.incoming.empty() && s.done.empty())) return -ENODEV;
      s.Produce(now_ns);
      if (it->second.generation != s.generation) return -ENODEV;
      if (!s.done.empty()) return 1;
      if (now_ns >= deadline_ns) return 0;
      const int64_t next_due =
          s.stream_start_ns + s.next_sequence * s.IntervalNs() + s.delivery_delay_ns;
      wake_ns = std::min(deadline_ns, next_due);
    }
    const int64_t sleep_ns = std::max<int64_t>(0, wake_ns - SystemMonotonicNs());
    std::this_thread::sleep_for(std::chrono::nanoseconds(sleep_ns));
  }
}

std::vector<std::string> FakeV4l2Io::ListDeviceNodes() {
  std::lock_guard<std::mutex> lock(mutex_);
  State& s = *state_;
  s.MaybeReplug(SystemMonotonicNs());
  std::vector<std::string> nodes;
  if (s.current_node.empty()) return nodes;
  nodes.push_back(s.current_node);
  if (!s.spec.metadata_node.empty() && s.current_node == s.spec.node) {
    nodes.push_back(s.spec.metadata_node);
  }
  return nodes;
}

std::vector<std::pair<std::string, std::string>> FakeV4l2Io::ListDeviceLinks() {
  std::lock_guard<std::mutex> lock(mutex_);
  State& s = *state_;
  s.MaybeReplug(SystemMonotonicNs());
  if (s.current_node.empty() || s.spec.by_id_link.empty()) return {};
  return {{s.spec.by_id_link, s.current_node}};
}

std::string FakeV4l2Io::ResolveNode(const std::string& path) {
  std::lock_guard<std::mutex> lock(mutex_);
  State& s = *state_;
  s.MaybeReplug(SystemMonotonicNs());
  if (s.current_node.empty()) return "";
  if (path == s.spec.by_id_link || path == s.current_node) return s.current_node;
  if (path == s.spec.metadata_node && s.current_node == s.spec.node) return path;
  return "";
}

int64_t FakeV4l2Io::MonotonicNowNs() { return SystemMonotonicNs(); }

int FakeV4l2Io::UvcHardwareTimestamps() {
  std::lock_guard<std::mutex> lock(mutex_);
  if (state_->spec.driver != "uvcvideo") return -1;
  return state_->spec.uvc_hw_timestamps ? 1 : 0;
}

void FakeV4l2Io::DropSequences(const std::set<int64_t>& sequences) {
  std::lock_guard<std::mutex> lock(mutex_);
  state_->drop_sequences = sequences;
}

void FakeV4l2Io::CorruptSequences(const std::set<int64_t>& sequences) {
  std::lock_guard<std::mutex> lock(mutex_);
  state_->corrupt_sequences = sequences;
}

void FakeV4l2Io::Unplug(double down_s, const std::string& new_node) {
  std::lock_guard<std::mutex> lock(mutex_);
  state_->DoUnplug(down_s, new_node, SystemMonotonicNs());
}

void FakeV4l2Io::UnplugAfterFrames(int64_t frames, double down_s, const std::string& new_node) {
  std::lock_guard<std::mutex> lock(mutex_);
  state_->unplug_after_frames = state_->stats.frames_due + frames;
  state_->unplug_down_s = down_s;
  state_->unplug_new_node = new_node;
}

void FakeV4l2Io::SetDeliveryDelayNs(int64_t delay_ns) {
  std::lock_guard<std::mutex> lock(mutex_);
  state_->delivery_delay_ns = delay_ns;
}

FakeCameraStats FakeV4l2Io::stats() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return state_->stats;
}

int32_t FakeV4l2Io::ControlValue(uint32_t id) const {
  std::lock_guard<std::mutex> lock(mutex_);
  const FakeControl* c = state_->FindControl(id);
  return c == nullptr ? 0 : c->value;
}

std::string FakeV4l2Io::CurrentNode() const {
  std::lock_guard<std::mutex> lock(mutex_);
  return state_->current_node;
}

}  // namespace vilma::v4l2
