#include "vilma/drivers/v4l2/format_negotiation.h"

#include <linux/videodev2.h>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <sstream>

#include "vilma/drivers/v4l2/pixel_convert.h"

namespace vilma::v4l2 {
namespace {

std::string IoctlError(const char* name, int result) {
  return std::string(name) + " failed: " + ErrnoText(result);
}

std::string Size(int width, int height) {
  return std::to_string(width) + "x" + std::to_string(height);
}

std::string FpsText(double fps) {
  std::ostringstream s;
  s << fps;
  return s.str();
}

std::string FourccList(const std::vector<uint32_t>& fourccs) {
  std::string text;
  for (uint32_t f : fourccs) text += (text.empty() ? "" : ", ") + FourccName(f);
  return text.empty() ? "none" : text;
}

}  // namespace

std::vector<uint32_t> EnumerateFourccs(V4l2Io* io, int fd, uint32_t buffer_type) {
  std::vector<uint32_t> fourccs;
  for (uint32_t index = 0; index < 256; ++index) {
    v4l2_fmtdesc desc{};
    desc.index = index;
    desc.type = buffer_type;
    if (io->Ioctl(fd, VIDIOC_ENUM_FMT, &desc) != 0) break;
    fourccs.push_back(desc.pixelformat);
  }
  return fourccs;
}

std::string DescribeFrameSizes(V4l2Io* io, int fd, uint32_t fourcc) {
  std::string text;
  for (uint32_t index = 0; index < 256; ++index) {
    v4l2_frmsizeenum size{};
    size.index = index;
    size.pixel_format = fourcc;
    if (io->Ioctl(fd, VIDIOC_ENUM_FRAMESIZES, &size) != 0) break;
    if (size.type == V4L2_FRMSIZE_TYPE_DISCRETE) {
      text += (text.empty() ? "" : ", ") +
              Size(static_cast<int>(size.discrete.width), static_cast<int>(size.discrete.height));
    } else {
      const v4l2_frmsize_stepwise& s = size.stepwise;
      text = Size(static_cast<int>(s.min_width), static_cast<int>(s.min_height)) + ".." +
             Size(static_cast<int>(s.max_width), static_cast<int>(s.max_height)) + " step " +
             Size(static_cast<int>(s.step_width), static_cast<int>(s.step_height));
      break;  // stepwise and continuous have a single entry
    }
  }
  return text.empty() ? "(sizes not listed)" : text;
}

std::string DescribeFrameRates(V4l2Io* io, int fd, uint32_t fourcc, int width, int height) {
  std::string text;
  for (uint32_t index = 0; index < 256; ++index) {
    v4l2_frmivalenum interval{};
    interval.index = index;
    interval.pixel_format = fourcc;
    interval.width = static_cast<uint32_t>(width);
    interval.height = static_cast<uint32_t>(height);
    if (io->Ioctl(fd, VIDIOC_ENUM_FRAMEINTERVALS, &interval) != 0) break;
    if (interval.type == V4L2_FRMIVAL_TYPE_DISCRETE) {
      if (interval.discrete.numerator == 0) continue;
      text +=
          (text.empty() ? "" : ", ") +
          FpsText(static_cast<double>(interval.discrete.denominator) / interval.discrete.numerator);
    } else {
      const v4l2_frmival_stepwise& s = interval.stepwise;
      // The longest interval is the lowest rate.
      const double low = s.max.numerator == 0 ? 0 : double(s.max.denominator) / s.max.numerator;
      const double high = s.min.numerator == 0 ? 0 : double(s.min.denominator) / s.min.numerator;
      text = FpsText(low) + ".." + FpsText(high);
      break;
    }
  }
  return text.empty() ? "(rates not listed)" : text + " fps";
}

std::string NegotiateFormat(V4l2Io* io, int fd, const FormatRequest& request,
                            NegotiatedFormat* result) {
  *result = NegotiatedFormat{};
  const bool mplane = request.buffer_type == V4L2_BUF_TYPE_VIDEO_CAPTURE_MPLANE;
  const std::vector<uint32_t> offered = EnumerateFourccs(io, fd, request.buffer_type);
  uint32_t chosen = 0;
  for (uint32_t wanted : request.fourccs) {
    if (IsSupportedFourcc(wanted) && std::count(offered.begin(), offered.end(), wanted) > 0) {
      chosen = wanted;
      break;
    }
  }
  if (chosen == 0) {
    return "the device offers pixel formats " + FourccList(offered) + ", none of " +
           FourccList(request.fourccs) + " (vilma-v4l2 converts GREY, Y16, YUYV, MJPG)";
  }

  // The single-planar and the multi-planar format hold the same fields for one plane.
  v4l2_format format{};
  format.type = request.buffer_type;
  int result_code = io->Ioctl(fd, VIDIOC_G_FMT, &format);
  if (result_code != 0) return IoctlError("VIDIOC_G_FMT", result_code);
  // (pix_mp is packed: its fields are read and written by value, not through references.)
  if (request.width > 0 && request.height > 0) {
    if (mplane) {
      format.fmt.pix_mp.width = static_cast<uint32_t>(request.width);
      format.fmt.pix_mp.height = static_cast<uint32_t>(request.height);
    } else {
      format.fmt.pix.width = static_cast<uint32_t>(request.width);
      format.fmt.pix.height = static_cast<uint32_t>(request.height);
    }
  }
  const int wanted_width =
      static_cast<int>(mplane ? format.fmt.pix_mp.width : format.fmt.pix.width);
  const int wanted_height =
      static_cast<int>(mplane ? format.fmt.pix_mp.height : format.fmt.pix.height);
  if (mplane) {
    format.fmt.pix_mp.pixelformat = chosen;
    format.fmt.pix_mp.field = V4L2_FIELD_NONE;
    format.fmt.pix_mp.num_planes = 1;
    format.fmt.pix_mp.plane_fmt[0].bytesperline = 0;  // let the driver choose
  } else {
    format.fmt.pix.pixelformat = chosen;
    format.fmt.pix.field = V4L2_FIELD_NONE;
    format.fmt.pix.bytesperline = 0;  // let the driver choose (it may pad rows)
  }
  result_code = io->Ioctl(fd, VIDIOC_S_FMT, &format);
  if (result_code != 0) return IoctlError("VIDIOC_S_FMT", result_code);
  const uint32_t set_fourcc = mplane ? format.fmt.pix_mp.pixelformat : format.fmt.pix.pixelformat;
  const uint32_t field = mplane ? format.fmt.pix_mp.field : format.fmt.pix.field;
  if (set_fourcc != chosen) {
    return "VIDIOC_S_FMT: asked for " + FourccName(chosen) + ", the device set " +
           FourccName(set_fourcc);
  }
  if (field != V4L2_FIELD_NONE && field != V4L2_FIELD_ANY) {
    return "the device delivers interlaced fields (field " + std::to_string(field) +
           "); vilma-v4l2 needs progressive frames";
  }
  if (mplane && format.fmt.pix_mp.num_planes != 1) {
    return "the device set " + FourccName(chosen) + " in " +
           std::to_string(format.fmt.pix_mp.num_planes) + " planes; vilma-v4l2 needs one";
  }
  result->fourcc = chosen;
  result->width = static_cast<int>(mplane ? format.fmt.pix_mp.width : format.fmt.pix.width);
  result->height = static_cast<int>(mplane ? format.fmt.pix_mp.height : format.fmt.pix.height);
  const uint32_t bytes_per_line =
      mplane ? format.fmt.pix_mp.plane_fmt[0].bytesperline : format.fmt.pix.bytesperline;
  result->bytes_per_line = chosen == V4L2_PIX_FMT_MJPEG ? 0 : static_cast<int>(bytes_per_line);
  result->size_image = mplane ? format.fmt.pix_mp.plane_fmt[0].sizeimage : format.fmt.pix.sizeimage;
  if (result->width != wanted_width || result->height != wanted_height) {
    const std::string text = "asked for " + Size(wanted_width, wanted_height) +
                             ", the device set " + Size(result->width, result->height) + " (" +
                             FourccName(chosen) + " sizes: " + DescribeFrameSizes(io, fd, chosen) +
                             ")";
    if (request.require_size) return text;
    result->notes.push_back(text);
  }

  v4l2_streamparm parm{};
  parm.type = request.buffer_type;
  result_code = io->Ioctl(fd, VIDIOC_G_PARM, &parm);
  const bool settable =
      result_code == 0 && (parm.parm.capture.capability & V4L2_CAP_TIMEPERFRAME) != 0;
  if (request.fps > 0.0) {
    if (!settable) {
      const std::string text = "the device cannot set a frame rate (no V4L2_CAP_TIMEPERFRAME)";
      if (request.require_fps) return text;
      result->notes.push_back(text);
    } else {
      // timeperframe = 1 / fps as a fraction with a 1000x denominator (29.97 fps: 1000/29970).
      parm.parm.capture.timeperframe.numerator = 1000;
      parm.parm.capture.timeperframe.denominator =
          static_cast<uint32_t>(std::lround(request.fps * 1000.0));
      result_code = io->Ioctl(fd, VIDIOC_S_PARM, &parm);
      if (result_code != 0) return IoctlError("VIDIOC_S_PARM", result_code);
    }
  }
  const v4l2_fract& interval = parm.parm.capture.timeperframe;
  if ((result_code == 0 || settable) && interval.numerator != 0) {
    result->fps = static_cast<double>(interval.denominator) / interval.numerator;
  }
  if (request.fps > 0.0 && settable && std::abs(result->fps - request.fps) > 0.01 * request.fps) {
    const std::string text =
        "asked for " + FpsText(request.fps) + " fps, the device set " + FpsText(result->fps) +
        " fps (" + FourccName(chosen) + " " + Size(result->width, result->height) + ": " +
        DescribeFrameRates(io, fd, chosen, result->width, result->height) + ")";
    if (request.require_fps) return text;
    result->notes.push_back(text);
  }
  return "";
}

}  // namespace vilma::v4l2
