#include "vilma/drivers/v4l2/v4l2_io.h"

#include <fcntl.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <sys/mman.h>
#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <filesystem>
#include <fstream>

namespace vilma::v4l2 {

namespace fs = std::filesystem;

int SystemV4l2Io::Open(const std::string& path) {
  int fd;
  do {
    fd = ::open(path.c_str(), O_RDWR | O_NONBLOCK | O_CLOEXEC);
  } while (fd < 0 && errno == EINTR);
  return fd >= 0 ? fd : -errno;
}

void SystemV4l2Io::Close(int fd) {
  if (fd >= 0) ::close(fd);
}

int SystemV4l2Io::Ioctl(int fd, unsigned long request, void* arg) {
  int result;
  do {
    result = ::ioctl(fd, request, arg);
  } while (result < 0 && errno == EINTR);
  return result < 0 ? -errno : 0;
}

void* SystemV4l2Io::Map(int fd, std::size_t length, int64_t offset) {
  void* address =
      ::mmap(nullptr, length, PROT_READ | PROT_WRITE, MAP_SHARED, fd, static_cast<off_t>(offset));
  return address == MAP_FAILED ? nullptr : address;
}

void SystemV4l2Io::Unmap(void* address, std::size_t length) {
  if (address != nullptr) ::munmap(address, length);
}

int SystemV4l2Io::Poll(int fd, int timeout_ms) {
  pollfd p{};
  p.fd = fd;
  p.events = POLLIN;
  int result;
  do {
    result = ::poll(&p, 1, timeout_ms);
  } while (result < 0 && errno == EINTR);
  if (result < 0) return -errno;
  if (result == 0) return 0;
  // uvcvideo and the V4L2 core report a disconnected device as POLLERR (| POLLHUP).
  if ((p.revents & (POLLERR | POLLHUP | POLLNVAL)) != 0) return -ENODEV;
  return 1;
}

namespace {

// /dev/video12 -> 12 (sorting by number, not by text: video10 after video9).
long NodeNumber(const std::string& path) {
  const std::size_t digits = path.find_first_of("0123456789");
  return digits == std::string::npos ? -1 : std::strtol(path.c_str() + digits, nullptr, 10);
}

}  // namespace

std::vector<std::string> SystemV4l2Io::ListDeviceNodes() {
  std::vector<std::string> nodes;
  std::error_code error;
  for (const fs::directory_entry& entry : fs::directory_iterator("/dev", error)) {
    const std::string name = entry.path().filename().string();
    if (name.rfind("video", 0) == 0 && name.size() > 5 &&
        std::all_of(name.begin() + 5, name.end(), ::isdigit)) {
      nodes.push_back(entry.path().string());
    }
  }
  std::sort(nodes.begin(), nodes.end(), [](const std::string& a, const std::string& b) {
    return NodeNumber(a) < NodeNumber(b);
  });
  return nodes;
}

std::vector<std::pair<std::string, std::string>> SystemV4l2Io::ListDeviceLinks() {
  std::vector<std::pair<std::string, std::string>> links;
  for (const char* dir : {"/dev/v4l/by-id", "/dev/v4l/by-path"}) {
    std::error_code error;
    for (const fs::directory_entry& entry : fs::directory_iterator(dir, error)) {
      const std::string node = ResolveNode(entry.path().string());
      if (!node.empty()) links.emplace_back(entry.path().string(), node);
    }
  }
  std::sort(links.begin(), links.end());
  return links;
}

std::string SystemV4l2Io::ResolveNode(const std::string& path) {
  std::error_code error;
  const fs::path node = fs::canonical(path, error);
  return error ? std::string() : node.string();
}

int64_t SystemV4l2Io::MonotonicNowNs() {
  timespec ts{};
  ::clock_gettime(CLOCK_MONOTONIC, &ts);
  return static_cast<int64_t>(ts.tv_sec) * 1000000000 + ts.tv_nsec;
}

int SystemV4l2Io::UvcHardwareTimestamps() {
  std::ifstream in("/sys/module/uvcvideo/parameters/hwtimestamps");
  int value = -1;
  if (!(in >> value)) return -1;
  return value != 0 ? 1 : 0;
}

std::string FourccName(uint32_t fourcc) {
  std::string name;
  for (int i = 0; i < 4; ++i) {
    const char c = static_cast<char>((fourcc >> (8 * i)) & 0xff);
    name += (c >= 32 && c < 127) ? c : '?';
  }
  while (!name.empty() && name.back() == ' ') name.pop_back();
  return name;
}

uint32_t FourccFromName(const std::string& name_in) {
  std::string name = name_in;
  if (name.size() == 3) name += ' ';
  if (name.size() != 4) return 0;
  uint32_t fourcc = 0;
  for (int i = 0; i < 4; ++i) {
    const char c = name[static_cast<std::size_t>(i)];
    const bool ok = (c >= 'A' && c <= 'Z') || (c >= '0' && c <= '9') || c == ' ';
    if (!ok) return 0;
    fourcc |= static_cast<uint32_t>(static_cast<unsigned char>(c)) << (8 * i);
  }
  return fourcc;
}

std::string ErrnoText(int negative_errno) {
  return std::strerror(negative_errno < 0 ? -negative_errno : negative_errno);
}

}  // namespace vilma::v4l2
