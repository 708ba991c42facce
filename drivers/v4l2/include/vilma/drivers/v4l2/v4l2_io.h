// The system calls a V4L2 capture program makes on a video device node (open, ioctl, mmap,
// poll, close), behind an interface: SystemV4l2Io makes them on the kernel, FakeV4l2Io
// (fake_v4l2_io.h) emulates a camera in the process, so that the capture loop, the format
// negotiation and `--list` are tested for real on machines without /dev/video*.
//
// Every call returns an error as a negative errno (-ENODEV, -EINVAL, ...), never sets errno
// for the caller, and retries EINTR itself.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <vector>

namespace vilma::v4l2 {

class V4l2Io {
 public:
  virtual ~V4l2Io() = default;

  // open(path, O_RDWR | O_NONBLOCK | O_CLOEXEC): a file descriptor >= 0 or -errno.
  virtual int Open(const std::string& path) = 0;
  virtual void Close(int fd) = 0;
  // ioctl(fd, request, arg): 0 or -errno.
  virtual int Ioctl(int fd, unsigned long request, void* arg) = 0;
  // mmap(nullptr, length, PROT_READ | PROT_WRITE, MAP_SHARED, fd, offset); nullptr on failure.
  virtual void* Map(int fd, std::size_t length, int64_t offset) = 0;
  virtual void Unmap(void* address, std::size_t length) = 0;
  // poll(fd, POLLIN) for up to timeout_ms: 1 when a buffer can be dequeued, 0 on time-out,
  // -ENODEV when the device reported POLLERR/POLLHUP (unplugged), other -errno on failure.
  virtual int Poll(int fd, int timeout_ms) = 0;

  // The video device nodes present (/dev/video*), sorted by number.
  virtual std::vector<std::string> ListDeviceNodes() = 0;
  // Stable names of devices (/dev/v4l/by-id/* and by-path/*): (link, the node it points at).
  virtual std::vector<std::pair<std::string, std::string>> ListDeviceLinks() = 0;
  // The node a path stands for (a by-id link resolved), or "" when it does not exist.
  virtual std::string ResolveNode(const std::string& path) = 0;

  // CLOCK_MONOTONIC now [ns]: the clock of the kernel's buffer stamps (the fake's own clock).
  virtual int64_t MonotonicNowNs() = 0;

  // uvcvideo's module parameter hwtimestamps (/sys/module/uvcvideo/parameters/hwtimestamps):
  // 1 when its buffer stamps come from the cameras' clocks, 0 when they are the host's
  // arrival time of a frame's first packet, -1 when unknown (module not loaded).
  virtual int UvcHardwareTimestamps() = 0;
};

// The kernel.
class SystemV4l2Io : public V4l2Io {
 public:
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
};

// "GREY", "YUYV", "MJPG", "Y16 " as text ("Y16" without the trailing blank).
std::string FourccName(uint32_t fourcc);
// The fourcc of a name as written in options ("GREY", "Y16", "YUYV", "MJPG"); 0 if not 4
// characters of [A-Z0-9 ] (after padding a 3-letter name with a blank).
uint32_t FourccFromName(const std::string& name);
// A fixed-size name field of a V4L2 struct (driver, card, control name, ...) as text, up to
// its first NUL or its end (a full field need not be NUL-terminated).
template <std::size_t N>
std::string FieldText(const uint8_t (&field)[N]) {
  std::size_t length = 0;
  while (length < N && field[length] != 0) ++length;
  return std::string(reinterpret_cast<const char*>(field), length);
}

// "No such device" style text of a negative errno.
std::string ErrnoText(int negative_errno);

}  // namespace vilma::v4l2
