#include "vilma/drivers/v4l2/device_list.h"

#include <linux/videodev2.h>

#include <cerrno>
#include <sstream>

#include "vilma/drivers/v4l2/camera_controls.h"
#include "vilma/drivers/v4l2/format_negotiation.h"
#include "vilma/drivers/v4l2/pixel_convert.h"

namespace vilma::v4l2 {

std::string ListDevices(V4l2Io* io, int* capture_nodes) {
  *capture_nodes = 0;
  std::ostringstream out;
  const std::vector<std::string> nodes = io->ListDeviceNodes();
  if (nodes.empty()) {
    return "no V4L2 video devices: /dev/video* is absent (is the camera plugged in, and its "
           "kernel driver, e.g. uvcvideo, loaded? `lsmod | grep uvcvideo`, `dmesg | tail`)\n";
  }
  const auto links = io->ListDeviceLinks();
  for (const std::string& node : nodes) {
    out << node << "\n";
    for (const auto& link : links) {
      if (link.second == node) out << "  name: " << link.first << "\n";
    }
    const int fd = io->Open(node);
    if (fd < 0) {
      out << "  cannot open: " << ErrnoText(fd)
          << (fd == -EACCES ? " (add the user to group 'video')" : "") << "\n";
      continue;
    }
    v4l2_capability cap{};
    if (io->Ioctl(fd, VIDIOC_QUERYCAP, &cap) != 0) {
      out << "  not a V4L2 device (VIDIOC_QUERYCAP failed)\n";
      io->Close(fd);
      continue;
    }
    const uint32_t caps =
        (cap.capabilities & V4L2_CAP_DEVICE_CAPS) != 0 ? cap.device_caps : cap.capabilities;
    out << "  driver: " << FieldText(cap.driver) << ", card: " << FieldText(cap.card)
        << ", bus: " << FieldText(cap.bus_info) << "\n";
    const bool mplane =
        (caps & V4L2_CAP_VIDEO_CAPTURE) == 0 && (caps & V4L2_CAP_VIDEO_CAPTURE_MPLANE) != 0;
    if ((caps & V4L2_CAP_VIDEO_CAPTURE) == 0 && !mplane) {
      out << "  not a video capture node"
          << ((caps & V4L2_CAP_META_CAPTURE) != 0 ? " (metadata node)" : "") << "\n";
      io->Close(fd);
      continue;
    }
    ++*capture_nodes;
    out << "  capture" << (mplane ? " (multi-planar API)" : "")
        << ((caps & V4L2_CAP_STREAMING) != 0 ? ", streaming" : ", NO streaming") << "\n";
    const uint32_t type = mplane ? V4L2_BUF_TYPE_VIDEO_CAPTURE_MPLANE : V4L2_BUF_TYPE_VIDEO_CAPTURE;
    v4l2_format current{};
    current.type = type;
    if (io->Ioctl(fd, VIDIOC_G_FMT, &current) == 0) {
      const v4l2_pix_format& pix = current.fmt.pix;
      const v4l2_pix_format_mplane& pix_mp = current.fmt.pix_mp;
      out << "  current format: " << FourccName(mplane ? pix_mp.pixelformat : pix.pixelformat)
          << " " << (mplane ? pix_mp.width : pix.width) << "x"
          << (mplane ? pix_mp.height : pix.height) << "\n";
    }
    out << "  formats:\n";
    for (uint32_t fourcc : EnumerateFourccs(io, fd, type)) {
      out << "    " << FourccName(fourcc)
          << (IsSupportedFourcc(fourcc) ? "" : " (not converted by vilma-v4l2)") << ": "
          << DescribeFrameSizes(io, fd, fourcc) << "\n";
      for (uint32_t index = 0; index < 64; ++index) {
        v4l2_frmsizeenum size{};
        size.index = index;
        size.pixel_format = fourcc;
        if (io->Ioctl(fd, VIDIOC_ENUM_FRAMESIZES, &size) != 0 ||
            size.type != V4L2_FRMSIZE_TYPE_DISCRETE) {
          break;
        }
        const int w = static_cast<int>(size.discrete.width);
        const int h = static_cast<int>(size.discrete.height);
        out << "      " << w << "x" << h << ": " << DescribeFrameRates(io, fd, fourcc, w, h)
            << "\n";
      }
    }
    const std::string controls = DescribeControls(io, fd);
    out << "  controls:" << (controls.empty() ? " none\n" : "\n" + controls);
    io->Close(fd);
  }
  if (*capture_nodes == 0) out << "no video capture node among these devices\n";
  return out.str();
}

}  // namespace vilma::v4l2
