#include "vilma/drivers/v4l2/fake_v4l2_io.h"

#include <linux/videodev2.h>
#include <sys/time.h>
#include <time.h>

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cstring>
#include <deque>
#include <opencv2/imgcodecs.hpp>
#include <thread>

namespace vilma::v4l2 {
namespace {

constexpr int64_t kNsPerS = 1000000000;
// Buffer offsets for mmap are cookies, as the kernel's (vb2 uses index << PAGE_SHIFT).
constexpr int64_t kOffsetStride = int64_t{1} << 24;

int64_t SystemMonotonicNs() {
  timespec ts{};
  ::clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<int64_t>(ts.tv_sec) * kNsPerS + ts.tv_nsec;
}

void CopyName(const std::string& text, uint8_t* out, std::size_t size) {
  std::memset(out, 0, size);
  std::memcpy(out, text.data(), std::min(text.size(), size - 1));
}

struct FakeControl {
  v4l2_queryctrl query{};
  std::vector<std::pair<int32_t, std::string>> menu;  // (value, name) of menu controls
  int32_t value = 0;
};

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

// JPEG without its DHT segments (what UVC cameras send; decoders use the Annex K tables).
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

}  // namespace

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

struct FakeV4l2Io::State {
  struct Buffer {
    std::vector<uint8_t> memory;
    bool queued = false;
    bool done = false;
    v4l2_buffer info{};
    int mappings = 0;
  };
  struct OpenFile {
    int generation = 0;  // the plug-in generation it was opened in
    bool metadata = false;
  };

  FakeCameraSpec spec;
  std::string current_node;  // "" while unplugged
  int generation = 0;
  int64_t replug_at_ns = 0;
  std::string replug_node;
  int64_t unplug_after_frames = -1;
  double unplug_down_s = 0.0;
  std::string unplug_new_node;
  int64_t delivery_delay_ns = 0;

  std::map<int, OpenFile> files;
  int next_fd = 100;
  int owner_fd = -1;  // the descriptor that allocated the buffers (vb2's queue owner)

  // Format and streaming state.
  v4l2_pix_format format{};
  uint32_t interval_numerator = 1;
  uint32_t interval_denominator = 30;
  std::vector<Buffer> buffers;
  // Buffers of a freed queue that may still be mapped: their memory stays valid, as the
  // kernel keeps a mapped buffer until munmap.
  std::vector<std::vector<Buffer>> orphaned;
  v4l2_pix_format default_format{};
  std::deque<int> incoming;  // queued buffer indices, in order
  std::deque<int> done;      // filled, waiting for DQBUF
  bool streaming = false;
  int64_t stream_start_ns = 0;
  int64_t next_sequence = 0;  // of the next due frame
  std::set<int64_t> drop_sequences;
  std::set<int64_t> corrupt_sequences;
  std::vector<FakeControl> controls;
  FakeCameraStats stats;

  const FakeFormat* FindFormat(uint32_t fourcc) const {
    for (const FakeFormat& f : spec.formats) {
      if (f.fourcc == fourcc) return &f;
    }
    return nullptr;
  }
  FakeControl* FindControl(uint32_t id) {
    for (FakeControl& c : controls) {
      if (c.query.id == id) return &c;
    }
    return nullptr;
  }

  // The kernel's S_FMT: adjust to what the camera can do.
  void Adjust(v4l2_pix_format* pix) const {
    const FakeFormat* format = FindFormat(pix->pixelformat);
    if (format == nullptr) format = &spec.formats.front();
    std::pair<int, int> best = format->sizes.front();
    int64_t best_cost = -1;
    for (const auto& size : format->sizes) {
      const int64_t cost = std::abs(static_cast<int64_t>(size.first) - pix->width) +
                           std::abs(static_cast<int64_t>(size.second) - pix->height);
      if (best_cost < 0 || cost < best_cost) {
        best_cost = cost;
        best = size;
      }
    }
    pix->pixelformat = format->fourcc;
    pix->width = static_cast<uint32_t>(best.first);
    pix->height = static_cast<uint32_t>(best.second);
    pix->field = V4L2_FIELD_NONE;
    switch (format->fourcc) {
      case V4L2_PIX_FMT_Y16:
      case V4L2_PIX_FMT_YUYV:
        pix->bytesperline = pix->width * 2;
        break;
      case V4L2_PIX_FMT_MJPEG:
        pix->bytesperline = 0;
        break;
      default:
        pix->bytesperline = pix->width;
    }
    pix->sizeimage = format->fourcc == V4L2_PIX_FMT_MJPEG ? pix->width * pix->height
                                                          : pix->bytesperline * pix->height;
    pix->colorspace = V4L2_COLORSPACE_SRGB;
  }

  // The exposure time now: the manual value, or the control's value under auto exposure
  // (the fake's auto exposure does not adapt); at most one frame interval.
  int64_t ExposureNs() const {
    const FakeControl* exposure = nullptr;
    for (const FakeControl& c : controls) {
      if (c.query.id == V4L2_CID_EXPOSURE_ABSOLUTE) exposure = &c;
    }
    const int64_t ns = exposure == nullptr ? 0 : int64_t{exposure->value} * 100000;
    return std::min(ns, IntervalNs());
  }

  int64_t IntervalNs() const {
    return static_cast<int64_t>(interval_numerator) * kNsPerS / interval_denominator;
  }

  void DoUnplug(double down_s, const std::string& new_node, int64_t now_ns) {
    if (current_node.empty()) return;
    current_node.clear();
    ++generation;
    ++stats.unplugs;
    replug_at_ns = now_ns + static_cast<int64_t>(down_s * 1e9);
    replug_node = new_node.empty() ? spec.node : new_node;
    FreeBuffers();
  }

  void MaybeReplug(int64_t now_ns) {
    if (current_node.empty() && now_ns >= replug_at_ns) {
      current_node = replug_node;
      // A re-enumerated camera starts from its defaults; buffers die with the old files.
      for (FakeControl& c : controls) c.value = c.query.default_value;
      format = default_format;
      interval_numerator = 1;
      interval_denominator = static_cast<uint32_t>(spec.formats.front().fps.front());
    }
  }

  std::vector<std::vector<uint8_t>> jpeg_cache;  // encoded MJPG frames by pattern phase
  uint32_t jpeg_cache_width = 0;
  uint32_t jpeg_cache_height = 0;

  // The encoded MJPG frame of `sequence`. A camera encodes in hardware: the fake encodes each
  // of the pattern's 128 phases once (WarmJpegCache at STREAMON), so that its own encoding
  // time does not show up as the driver's latency.
  const std::vector<uint8_t>& Jpeg(int64_t sequence) {
    if (jpeg_cache_width != format.width || jpeg_cache_height != format.height) {
      jpeg_cache.assign(128, {});
      jpeg_cache_width = format.width;
      jpeg_cache_height = format.height;
    }
    std::vector<uint8_t>& jpeg = jpeg_cache[static_cast<std::size_t>(sequence % 128)];
    if (jpeg.empty()) {
      const cv::Mat pattern = FakeFramePattern(sequence, static_cast<int>(format.width),
                                               static_cast<int>(format.height));
      cv::imencode(".jpg", pattern, jpeg, {cv::IMWRITE_JPEG_QUALITY, 90});
      if (spec.mjpg_without_huffman_tables) jpeg = StripHuffmanTables(jpeg);
    }
    return jpeg;
  }
  void WarmJpegCache() {
    if (format.pixelformat != V4L2_PIX_FMT_MJPEG) return;
    for (int64_t phase = 0; phase < 128; ++phase) Jpeg(phase);
  }

  void FillBuffer(Buffer* buffer, int64_t sequence) {
    uint8_t* out = buffer->memory.data();
    if (format.pixelformat == V4L2_PIX_FMT_MJPEG) {
      const std::vector<uint8_t>& jpeg = Jpeg(sequence);
      const std::size_t used = std::min(jpeg.size(), buffer->memory.size());
      std::memcpy(out, jpeg.data(), used);
      buffer->info.bytesused = static_cast<uint32_t>(used);
      return;
    }
    // FakeFramePattern's ramp, written straight into the format's layout.
    const int shift = static_cast<int>((sequence * 2) % 256);
    const int w = static_cast<int>(format.width);
    for (int y = 0; y < static_cast<int>(format.height); ++y) {
      uint8_t* line = out + static_cast<std::size_t>(y) * format.bytesperline;
      for (int x = 0; x < w; ++x) {
        const auto value = static_cast<uint8_t>((x / 4 + y / 4 + shift) & 0xff);
        switch (format.pixelformat) {
          case V4L2_PIX_FMT_Y16:  // little endian
            line[2 * x] = static_cast<uint8_t>(x & 0xff);
            line[2 * x + 1] = value;
            break;
          case V4L2_PIX_FMT_YUYV:  // Y0 U Y1 V: chroma that a gray conversion must ignore
            line[2 * x] = value;
            line[2 * x + 1] = (x % 2 == 0) ? 0x40 : 0xC0;
            break;
          default:
            line[x] = value;
        }
      }
    }
    buffer->info.bytesused = format.sizeimage;
  }

  // Hands out every frame that is due by `now_ns`.
  void Produce(int64_t now_ns) {
    if (!streaming) return;
    const int64_t interval = IntervalNs();
    while (true) {
      // Frame k is complete (end of frame) at ready_ns; its exposure started `exposure` before
      // (the fake reads out instantly), which is what a start-of-exposure stamp says.
      const int64_t ready_ns = stream_start_ns + next_sequence * interval;
      if (ready_ns + delivery_delay_ns > now_ns) return;
      const bool soe =
          (spec.timestamp_flags & V4L2_BUF_FLAG_TSTAMP_SRC_MASK) == V4L2_BUF_FLAG_TSTAMP_SRC_SOE;
      const int64_t stamp_ns = soe ? ready_ns - ExposureNs() : ready_ns;
      const int64_t sequence = next_sequence++;
      ++stats.frames_due;
      if (unplug_after_frames >= 0 && stats.frames_due >= unplug_after_frames) {
        unplug_after_frames = -1;
        DoUnplug(unplug_down_s, unplug_new_node, now_ns);
        return;
      }
      if (drop_sequences.count(sequence) != 0) {
        ++stats.frames_dropped_scripted;
        continue;
      }
      if (incoming.empty()) {
        ++stats.frames_lost_no_buffer;
        continue;
      }
      const int index = incoming.front();
      incoming.pop_front();
      Buffer& buffer = buffers[static_cast<std::size_t>(index)];
      FillBuffer(&buffer, sequence);
      buffer.queued = false;
      buffer.done = true;
      buffer.info.sequence = static_cast<uint32_t>(sequence);
      buffer.info.timestamp.tv_sec = static_cast<time_t>(stamp_ns / kNsPerS);
      buffer.info.timestamp.tv_usec = static_cast<suseconds_t>((stamp_ns % kNsPerS) / 1000);
      buffer.info.flags = spec.timestamp_flags | V4L2_BUF_FLAG_MAPPED | V4L2_BUF_FLAG_DONE;
      if (corrupt_sequences.count(sequence) != 0) buffer.info.flags |= V4L2_BUF_FLAG_ERROR;
      buffer.info.field = V4L2_FIELD_NONE;
      done.push_back(index);
      ++stats.frames_delivered;
    }
  }

  void FreeBuffers() {
    streaming = false;
    incoming.clear();
    done.clear();
    if (!buffers.empty()) orphaned.push_back(std::move(buffers));
    buffers.clear();
    owner_fd = -1;
  }

  int DoIoctl(int fd, const OpenFile& file, unsigned long request, void* arg, int64_t now_ns);
};

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

int FakeV4l2Io::State::DoIoctl(int fd, const OpenFile& file, unsigned long request, void* arg,
                               int64_t now_ns) {
  const bool capture = !file.metadata;
  switch (request) {
    case VIDIOC_QUERYCAP: {
      auto* cap = static_cast<v4l2_capability*>(arg);
      std::memset(cap, 0, sizeof(*cap));
      CopyName(spec.driver, cap->driver, sizeof(cap->driver));
      CopyName(spec.card, cap->card, sizeof(cap->card));
      CopyName(spec.bus_info, cap->bus_info, sizeof(cap->bus_info));
      cap->version = (6u << 16) | (1u << 8);
      cap->device_caps = capture ? (V4L2_CAP_VIDEO_CAPTURE | V4L2_CAP_STREAMING)
                                 : (V4L2_CAP_META_CAPTURE | V4L2_CAP_STREAMING);
      cap->capabilities = V4L2_CAP_VIDEO_CAPTURE | V4L2_CAP_META_CAPTURE | V4L2_CAP_STREAMING |
                          V4L2_CAP_DEVICE_CAPS;
      return 0;
    }
    case VIDIOC_QUERYCTRL: {
      auto* q = static_cast<v4l2_queryctrl*>(arg);
      if (!capture) return -EINVAL;
      if ((q->id & V4L2_CTRL_FLAG_NEXT_CTRL) != 0) {
        const uint32_t after = q->id & ~V4L2_CTRL_FLAG_NEXT_CTRL;
        const FakeControl* next = nullptr;
        for (const FakeControl& c : controls) {
          if (c.query.id > after && (next == nullptr || c.query.id < next->query.id)) next = &c;
        }
        if (next == nullptr) return -EINVAL;
        *q = next->query;
      } else {
        const FakeControl* c = FindControl(q->id);
        if (c == nullptr) return -EINVAL;
        *q = c->query;
      }
      if (q->id == V4L2_CID_EXPOSURE_ABSOLUTE &&
          FindControl(V4L2_CID_EXPOSURE_AUTO)->value != V4L2_EXPOSURE_MANUAL) {
        q->flags |= V4L2_CTRL_FLAG_INACTIVE;
      }
      return 0;
    }
    case VIDIOC_QUERYMENU: {
      auto* m = static_cast<v4l2_querymenu*>(arg);
      const FakeControl* c = FindControl(m->id);
      if (c == nullptr) return -EINVAL;
      for (const auto& item : c->menu) {
        if (static_cast<uint32_t>(item.first) == m->index) {
          CopyName(item.second, m->name, sizeof(m->name));
          return 0;
        }
      }
      return -EINVAL;
    }
    case VIDIOC_G_CTRL: {
      auto* c = static_cast<v4l2_control*>(arg);
      const FakeControl* control = FindControl(c->id);
      if (control == nullptr) return -EINVAL;
      c->value = control->value;
      return 0;
    }
    case VIDIOC_S_CTRL: {
      auto* c = static_cast<v4l2_control*>(arg);
      FakeControl* control = FindControl(c->id);
      if (control == nullptr) return -EINVAL;
      if (c->value < control->query.minimum || c->value > control->query.maximum) return -ERANGE;
      if (!control->menu.empty()) {
        const bool listed = std::any_of(control->menu.begin(), control->menu.end(),
                                        [&](const auto& item) { return item.first == c->value; });
        if (!listed) return -EINVAL;
      }
      if (c->id == V4L2_CID_EXPOSURE_ABSOLUTE &&
          FindControl(V4L2_CID_EXPOSURE_AUTO)->value != V4L2_EXPOSURE_MANUAL) {
        return -EACCES;
      }
      control->value = c->value;
      return 0;
    }
    default:
      break;
  }
  if (!capture) return -ENOTTY;  // the metadata node: none of the video capture ioctls

  switch (request) {
    case VIDIOC_ENUM_FMT: {
      auto* d = static_cast<v4l2_fmtdesc*>(arg);
      if (d->type != V4L2_BUF_TYPE_VIDEO_CAPTURE || d->index >= spec.formats.size()) return -EINVAL;
      const FakeFormat& f = spec.formats[d->index];
      d->pixelformat = f.fourcc;
      d->flags = f.fourcc == V4L2_PIX_FMT_MJPEG ? V4L2_FMT_FLAG_COMPRESSED : 0;
      const std::string description =
          f.fourcc == V4L2_PIX_FMT_MJPEG ? "Motion-JPEG" : "fake " + FourccName(f.fourcc);
      CopyName(description, d->description, sizeof(d->description));
      return 0;
    }
    case VIDIOC_ENUM_FRAMESIZES: {
      auto* e = static_cast<v4l2_frmsizeenum*>(arg);
      const FakeFormat* f = FindFormat(e->pixel_format);
      if (f == nullptr || e->index >= f->sizes.size()) return -EINVAL;
      e->type = V4L2_FRMSIZE_TYPE_DISCRETE;
      e->discrete.width = static_cast<uint32_t>(f->sizes[e->index].first);
      e->discrete.height = static_cast<uint32_t>(f->sizes[e->index].second);
      return 0;
    }
    case VIDIOC_ENUM_FRAMEINTERVALS: {
      auto* e = static_cast<v4l2_frmivalenum*>(arg);
      const FakeFormat* f = FindFormat(e->pixel_format);
      if (f == nullptr || e->index >= f->fps.size()) return -EINVAL;
      const bool size_ok = std::any_of(f->sizes.begin(), f->sizes.end(), [&](const auto& s) {
        return static_cast<uint32_t>(s.first) == e->width &&
               static_cast<uint32_t>(s.second) == e->height;
      });
      if (!size_ok) return -EINVAL;
      e->type = V4L2_FRMIVAL_TYPE_DISCRETE;
      e->discrete.numerator = 1;
      e->discrete.denominator = static_cast<uint32_t>(f->fps[e->index]);
      return 0;
    }
    case VIDIOC_G_FMT:
    case VIDIOC_S_FMT:
    case VIDIOC_TRY_FMT: {
      auto* f = static_cast<v4l2_format*>(arg);
      if (f->type != V4L2_BUF_TYPE_VIDEO_CAPTURE) return -EINVAL;
      if (request == VIDIOC_G_FMT) {
        f->fmt.pix = format;
        return 0;
      }
      if (request == VIDIOC_S_FMT && !buffers.empty()) return -EBUSY;
      Adjust(&f->fmt.pix);
      if (request == VIDIOC_S_FMT) {
        format = f->fmt.pix;
        // The frame interval is kept if the new format offers it, else the first one is used.
        const FakeFormat* ff = FindFormat(format.pixelformat);
        const bool kept =
            interval_numerator == 1 &&
            std::count(ff->fps.begin(), ff->fps.end(), static_cast<int>(interval_denominator)) > 0;
        if (!kept) {
          interval_numerator = 1;
          interval_denominator = static_cast<uint32_t>(ff->fps.front());
        }
      }
      return 0;
    }
    case VIDIOC_G_PARM:
    case VIDIOC_S_PARM: {
      auto* p = static_cast<v4l2_streamparm*>(arg);
      if (p->type != V4L2_BUF_TYPE_VIDEO_CAPTURE) return -EINVAL;
      if (request == VIDIOC_S_PARM) {
        if (streaming) return -EBUSY;
        const v4l2_fract wanted = p->parm.capture.timeperframe;
        const double wanted_fps = wanted.numerator == 0
                                      ? 1e9
                                      : static_cast<double>(wanted.denominator) / wanted.numerator;
        const FakeFormat* ff = FindFormat(format.pixelformat);
        int best = ff->fps.front();
        for (int fps : ff->fps) {
          if (std::abs(fps - wanted_fps) < std::abs(best - wanted_fps)) best = fps;
        }
        interval_numerator = 1;
        interval_denominator = static_cast<uint32_t>(best);
      }
      std::memset(&p->parm.capture, 0, sizeof(p->parm.capture));
      p->parm.capture.capability = V4L2_CAP_TIMEPERFRAME;
      p->parm.capture.timeperframe.numerator = interval_numerator;
      p->parm.capture.timeperframe.denominator = interval_denominator;
      return 0;
    }
    case VIDIOC_REQBUFS: {
      auto* r = static_cast<v4l2_requestbuffers*>(arg);
      if (r->type != V4L2_BUF_TYPE_VIDEO_CAPTURE || r->memory != V4L2_MEMORY_MMAP) return -EINVAL;
      if (owner_fd >= 0 && owner_fd != fd) return -EBUSY;
      if (streaming) return -EBUSY;
      for (const Buffer& b : buffers) {
        if (b.mappings > 0) return -EBUSY;  // vb2: buffers in use cannot be freed
      }
      buffers.clear();
      incoming.clear();
      done.clear();
      if (r->count == 0) {
        owner_fd = -1;
        return 0;
      }
      const uint32_t count =
          std::clamp<uint32_t>(r->count, 2, static_cast<uint32_t>(spec.max_buffers));
      buffers.resize(count);
      for (uint32_t i = 0; i < count; ++i) {
        Buffer& b = buffers[i];
        b.memory.assign(format.sizeimage, 0);
        b.info.index = i;
        b.info.type = V4L2_BUF_TYPE_VIDEO_CAPTURE;
        b.info.memory = V4L2_MEMORY_MMAP;
        b.info.length = format.sizeimage;
        b.info.m.offset = static_cast<uint32_t>(i * kOffsetStride);
      }
      r->count = count;
      owner_fd = fd;
      return 0;
    }
    case VIDIOC_QUERYBUF:
    case VIDIOC_QBUF:
    case VIDIOC_DQBUF: {
      auto* b = static_cast<v4l2_buffer*>(arg);
      if (b->type != V4L2_BUF_TYPE_VIDEO_CAPTURE || b->memory != V4L2_MEMORY_MMAP) return -EINVAL;
      if (owner_fd != fd) return -EBUSY;
      if (request == VIDIOC_DQBUF) {
        if (!streaming) return -EINVAL;
        Produce(now_ns);
        if (!streaming) return -ENODEV;  // unplugged while producing
        if (done.empty()) return -EAGAIN;
        const int index = done.front();
        done.pop_front();
        Buffer& buffer = buffers[static_cast<std::size_t>(index)];
        buffer.done = false;
        *b = buffer.info;
        return 0;
      }
      if (b->index >= buffers.size()) return -EINVAL;
      Buffer& buffer = buffers[b->index];
      if (request == VIDIOC_QUERYBUF) {
        *b = buffer.info;
        b->flags = (buffer.mappings > 0 ? V4L2_BUF_FLAG_MAPPED : 0) |
                   (buffer.queued ? V4L2_BUF_FLAG_QUEUED : 0) |
                   (buffer.done ? V4L2_BUF_FLAG_DONE : 0);
        return 0;
      }
      if (buffer.queued || buffer.done) return -EINVAL;  // already owned by the driver
      buffer.queued = true;
      incoming.push_back(static_cast<int>(b->index));
      b->flags = V4L2_BUF_FLAG_QUEUED;
      return 0;
    }
    case VIDIOC_STREAMON: {
      if (*static_cast<int*>(arg) != V4L2_BUF_TYPE_VIDEO_CAPTURE) return -EINVAL;
      if (buffers.empty() || owner_fd != fd) return -EINVAL;
      if (streaming) return 0;
      WarmJpegCache();
      streaming = true;
      next_sequence = 0;
      stream_start_ns = SystemMonotonicNs() + IntervalNs();  // after the warm-up
      return 0;
    }
    case VIDIOC_STREAMOFF: {
      if (*static_cast<int*>(arg) != V4L2_BUF_TYPE_VIDEO_CAPTURE) return -EINVAL;
      if (owner_fd != fd) return -EBUSY;
      streaming = false;
      incoming.clear();
      done.clear();
      for (Buffer& b : buffers) b.queued = b.done = false;
      return 0;
    }
    default:
      return -ENOTTY;
  }
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
