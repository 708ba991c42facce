// The state of FakeV4l2Io (fake_v4l2_io.h), shared by its two source files: fake_v4l2_io.cpp
// (the camera's timeline, buffers, plugging, the public calls) and fake_v4l2_ioctl.cpp (the
// V4L2 ioctls). Private to drivers/v4l2/src.
#pragma once

#include <linux/videodev2.h>
#include <sys/time.h>
#include <time.h>

#include <algorithm>
#include <cstring>
#include <deque>
#include <map>
#include <opencv2/imgcodecs.hpp>
#include <set>
#include <string>
#include <vector>

#include "vilma/drivers/v4l2/fake_v4l2_io.h"

namespace vilma::v4l2 {
namespace fake_detail {

constexpr int64_t kNsPerS = 1000000000;
// Buffer offsets for mmap are cookies, as the kernel's (vb2 uses index << PAGE_SHIFT).
constexpr int64_t kOffsetStride = int64_t{1} << 24;

inline int64_t SystemMonotonicNs() {
  timespec ts{};
  ::clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<int64_t>(ts.tv_sec) * kNsPerS + ts.tv_nsec;
}

inline void CopyName(const std::string& text, uint8_t* out, std::size_t size) {
  std::memset(out, 0, size);
  std::memcpy(out, text.data(), std::min(text.size(), size - 1));
}

struct FakeControl {
  v4l2_queryctrl query{};
  std::vector<std::pair<int32_t, std::string>> menu;  // (value, name) of menu controls
  int32_t value = 0;
};

FakeControl MakeControl(uint32_t id, uint32_t type, const char* name, int32_t minimum,
                        int32_t maximum, int32_t step, int32_t default_value);
// JPEG without its DHT segments (what UVC cameras send; decoders use the Annex K tables).
std::vector<uint8_t> StripHuffmanTables(const std::vector<uint8_t>& jpeg);

// v4l2_pix_format <-> the one-plane v4l2_pix_format_mplane (the multi-planar API).
inline v4l2_pix_format_mplane ToMultiplanar(const v4l2_pix_format& pix) {
  v4l2_pix_format_mplane mp{};
  mp.width = pix.width;
  mp.height = pix.height;
  mp.pixelformat = pix.pixelformat;
  mp.field = pix.field;
  mp.colorspace = pix.colorspace;
  mp.num_planes = 1;
  mp.plane_fmt[0].bytesperline = pix.bytesperline;
  mp.plane_fmt[0].sizeimage = pix.sizeimage;
  return mp;
}
inline v4l2_pix_format FromMultiplanar(const v4l2_pix_format_mplane& mp) {
  v4l2_pix_format pix{};
  pix.width = mp.width;
  pix.height = mp.height;
  pix.pixelformat = mp.pixelformat;
  pix.field = mp.field;
  pix.bytesperline = mp.plane_fmt[0].bytesperline;
  return pix;
}

}  // namespace fake_detail

struct FakeV4l2Io::State {
  using FakeControl = fake_detail::FakeControl;
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
    return static_cast<int64_t>(interval_numerator) * fake_detail::kNsPerS / interval_denominator;
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
      if (spec.mjpg_without_huffman_tables) jpeg = fake_detail::StripHuffmanTables(jpeg);
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
      // uvcvideo without hardware stamps: the first packet's arrival, flagged SOE all the same.
      const bool first_packet = spec.driver == "uvcvideo" && !spec.uvc_hw_timestamps;
      const int64_t stamp_ns = soe && !first_packet ? ready_ns - ExposureNs() : ready_ns;
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
      buffer.info.timestamp.tv_sec = static_cast<time_t>(stamp_ns / fake_detail::kNsPerS);
      buffer.info.timestamp.tv_usec =
          static_cast<suseconds_t>((stamp_ns % fake_detail::kNsPerS) / 1000);
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

}  // namespace vilma::v4l2
