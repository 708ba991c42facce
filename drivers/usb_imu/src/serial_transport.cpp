// SerialTransport (termios) and ReplayTransport (a recorded byte file) of transport.h.
#include <fcntl.h>
#include <poll.h>
#include <sys/ioctl.h>
#include <termios.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstring>
#include <fstream>
#include <iterator>

#include "vilma/drivers/usb_imu/transport.h"

namespace vilma::usb_imu {
namespace {

speed_t BaudConstant(int baud) {
  switch (baud) {
    case 9600: return B9600;
    case 19200: return B19200;
    case 38400: return B38400;
    case 57600: return B57600;
    case 115200: return B115200;
    case 230400: return B230400;
    case 460800: return B460800;
    case 921600: return B921600;
    default: return 0;
  }
}

// Errors after which the tty is gone (USB unplugged, pty master closed): reopen later.
bool IsGoneErrno(int error) {
  return error == EIO || error == ENXIO || error == ENODEV || error == ENOENT || error == EBADF;
}

}  // namespace

bool IsSupportedBaud(int baud) { return BaudConstant(baud) != 0; }

SerialTransport::SerialTransport(std::string path, int baud) : path_(std::move(path)), baud_(baud) {}

SerialTransport::~SerialTransport() { Close(); }

std::string SerialTransport::Describe() const {
  return path_ + " at " + std::to_string(baud_) + " baud";
}

void SerialTransport::Open() {
  Close();
  if (!IsSupportedBaud(baud_)) {
    throw TransportError(path_ + ": baud " + std::to_string(baud_) +
                             " is not one of 9600 19200 38400 57600 115200 230400 460800 921600",
                         false);
  }
  fd_ = ::open(path_.c_str(), O_RDWR | O_NOCTTY | O_NONBLOCK | O_CLOEXEC);
  if (fd_ < 0) {
    const int error = errno;
    std::string hint;
    if (error == EACCES) {
      hint = " (add the user to group dialout, or install config/udev/99-vilma-usb-imu.rules)";
    }
    throw TransportError(path_ + ": cannot open: " + std::strerror(error) + hint,
                         IsGoneErrno(error));
  }
  termios tio{};
  if (tcgetattr(fd_, &tio) != 0) {
    const int error = errno;
    Close();
    throw TransportError(path_ + ": not a terminal device: " + std::strerror(error), false);
  }
  // Raw 8N1, no flow control, reads return whatever has arrived (poll() does the waiting).
  cfmakeraw(&tio);
  tio.c_cflag |= CLOCAL | CREAD;
  tio.c_cflag &= ~static_cast<tcflag_t>(CRTSCTS | CSTOPB | PARENB);
  tio.c_cc[VMIN] = 0;
  tio.c_cc[VTIME] = 0;
  cfsetispeed(&tio, BaudConstant(baud_));
  cfsetospeed(&tio, BaudConstant(baud_));
  if (tcsetattr(fd_, TCSANOW, &tio) != 0) {
    const int error = errno;
    Close();
    throw TransportError(path_ + ": cannot set raw " + std::to_string(baud_) +
                             " baud: " + std::strerror(error),
                         IsGoneErrno(error));
  }
  // Exclusive: a second driver (or a terminal program) would steal bytes from the stream.
  ioctl(fd_, TIOCEXCL);
  tcflush(fd_, TCIOFLUSH);
}

void SerialTransport::Close() {
  if (fd_ >= 0) ::close(fd_);
  fd_ = -1;
}

std::size_t SerialTransport::Read(uint8_t* data, std::size_t size, int timeout_ms) {
  if (fd_ < 0) throw TransportError(path_ + ": not open", true);
  pollfd p{fd_, POLLIN, 0};
  const int ready = ::poll(&p, 1, timeout_ms);
  if (ready < 0) {
    if (errno == EINTR) return 0;
    throw TransportError(path_ + ": poll: " + std::strerror(errno), false);
  }
  if (ready == 0) return 0;
  if ((p.revents & POLLIN) == 0 && (p.revents & (POLLHUP | POLLERR | POLLNVAL)) != 0) {
    throw TransportError(path_ + ": device hung up", true);
  }
  const ssize_t n = ::read(fd_, data, size);
  if (n > 0) return static_cast<std::size_t>(n);
  if (n == 0) throw TransportError(path_ + ": end of file (device gone)", true);
  const int error = errno;
  if (error == EAGAIN || error == EINTR) return 0;
  throw TransportError(path_ + ": read: " + std::strerror(error), IsGoneErrno(error));
}

void SerialTransport::Write(const uint8_t* data, std::size_t size) {
  if (fd_ < 0) throw TransportError(path_ + ": not open", true);
  std::size_t done = 0;
  while (done < size) {
    const ssize_t n = ::write(fd_, data + done, size - done);
    if (n > 0) {
      done += static_cast<std::size_t>(n);
      continue;
    }
    const int error = errno;
    if (n < 0 && (error == EAGAIN || error == EINTR)) {
      pollfd p{fd_, POLLOUT, 0};
      if (::poll(&p, 1, 1000) == 0) throw TransportError(path_ + ": write timed out", false);
      continue;
    }
    throw TransportError(path_ + ": write: " + std::strerror(error), IsGoneErrno(error));
  }
}

ReplayTransport::ReplayTransport(std::string path, std::size_t chunk_bytes)
    : path_(std::move(path)), chunk_bytes_(chunk_bytes == 0 ? 1 : chunk_bytes) {}

void ReplayTransport::Open() {
  std::ifstream in(path_, std::ios::binary);
  if (!in) throw TransportError(path_ + ": cannot open the recorded byte stream", false);
  bytes_.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  if (in.bad()) throw TransportError(path_ + ": read error", false);
  at_ = 0;
  opened_ = true;
}

std::size_t ReplayTransport::Read(uint8_t* data, std::size_t size, int /*timeout_ms*/) {
  const std::size_t n = std::min({size, chunk_bytes_, bytes_.size() - at_});
  std::memcpy(data, bytes_.data() + at_, n);
  at_ += n;
  return n;
}

}  // namespace vilma::usb_imu
