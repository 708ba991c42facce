// The V4L2 ioctls of the fake camera (fake_v4l2_io.h: what it emulates and how).
#include <cerrno>

#include "fake_v4l2_state.h"

namespace vilma::v4l2 {

using fake_detail::CopyName;
using fake_detail::FakeControl;
using fake_detail::FromMultiplanar;
using fake_detail::kOffsetStride;
using fake_detail::SystemMonotonicNs;
using fake_detail::ToMultiplanar;

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
      const uint32_t video =
          spec.multiplanar ? V4L2_CAP_VIDEO_CAPTURE_MPLANE : V4L2_CAP_VIDEO_CAPTURE;
      cap->device_caps =
          capture ? (video | V4L2_CAP_STREAMING) : (V4L2_CAP_META_CAPTURE | V4L2_CAP_STREAMING);
      cap->capabilities = video | V4L2_CAP_META_CAPTURE | V4L2_CAP_STREAMING | V4L2_CAP_DEVICE_CAPS;
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
  // The one buffer type this camera speaks (a multi-planar-only device refuses the other).
  const uint32_t type =
      spec.multiplanar ? V4L2_BUF_TYPE_VIDEO_CAPTURE_MPLANE : V4L2_BUF_TYPE_VIDEO_CAPTURE;
  const bool mplane = spec.multiplanar;

  switch (request) {
    case VIDIOC_ENUM_FMT: {
      auto* d = static_cast<v4l2_fmtdesc*>(arg);
      if (d->type != type || d->index >= spec.formats.size()) return -EINVAL;
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
      if (f->type != type) return -EINVAL;
      if (request == VIDIOC_G_FMT) {
        if (mplane) {
          f->fmt.pix_mp = ToMultiplanar(format);
        } else {
          f->fmt.pix = format;
        }
        return 0;
      }
      if (request == VIDIOC_S_FMT && !buffers.empty()) return -EBUSY;
      v4l2_pix_format pix = mplane ? FromMultiplanar(f->fmt.pix_mp) : f->fmt.pix;
      Adjust(&pix);
      if (mplane) {
        f->fmt.pix_mp = ToMultiplanar(pix);
      } else {
        f->fmt.pix = pix;
      }
      if (request == VIDIOC_S_FMT) {
        format = pix;
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
      if (p->type != type) return -EINVAL;
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
      if (r->type != type || r->memory != V4L2_MEMORY_MMAP) return -EINVAL;
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
        b.info.type = type;
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
      if (b->type != type || b->memory != V4L2_MEMORY_MMAP) return -EINVAL;
      // Multi-planar: the application passes its plane array (m.planes, length entries).
      v4l2_plane* planes = mplane ? b->m.planes : nullptr;
      if (mplane && (planes == nullptr || b->length < 1)) return -EINVAL;
      if (owner_fd != fd) return -EBUSY;
      // The buffer's description in the caller's layout.
      auto copy_out = [&](const v4l2_buffer& info) {
        *b = info;
        if (mplane) {
          std::memset(&planes[0], 0, sizeof(planes[0]));
          planes[0].bytesused = info.bytesused;
          planes[0].length = info.length;
          planes[0].m.mem_offset = info.m.offset;
          b->m.planes = planes;
          b->length = 1;
          b->bytesused = 0;
        }
      };
      if (request == VIDIOC_DQBUF) {
        if (!streaming) return -EINVAL;
        Produce(now_ns);
        if (!streaming) return -ENODEV;  // unplugged while producing
        if (done.empty()) return -EAGAIN;
        const int index = done.front();
        done.pop_front();
        Buffer& buffer = buffers[static_cast<std::size_t>(index)];
        buffer.done = false;
        copy_out(buffer.info);
        return 0;
      }
      if (b->index >= buffers.size()) return -EINVAL;
      Buffer& buffer = buffers[b->index];
      if (request == VIDIOC_QUERYBUF) {
        copy_out(buffer.info);
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
      if (*static_cast<uint32_t*>(arg) != type) return -EINVAL;
      if (buffers.empty() || owner_fd != fd) return -EINVAL;
      if (streaming) return 0;
      WarmJpegCache();
      streaming = true;
      next_sequence = 0;
      stream_start_ns = SystemMonotonicNs() + IntervalNs();  // after the warm-up
      return 0;
    }
    case VIDIOC_STREAMOFF: {
      if (*static_cast<uint32_t*>(arg) != type) return -EINVAL;
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

}  // namespace vilma::v4l2
