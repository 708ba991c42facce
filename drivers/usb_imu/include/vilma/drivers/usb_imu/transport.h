// Byte transports of vilma-usb-imu: the MIP protocol runs over any of them.
//   SerialTransport  a tty (termios raw 8N1): /dev/ttyACM0 of the kernel's cdc_acm driver, a
//                    UART adapter, or a pseudo-terminal (the tests' simulated device)
//   UsbTransport     libusb: the device by vendor/product id, the kernel's cdc_acm detached,
//                    the CDC data interface's bulk endpoints claimed (usb_transport.cpp)
//   ReplayTransport  a recorded byte stream from a file (writes are discarded)
#pragma once

#include <cstddef>
#include <cstdint>
#include <memory>
#include <stdexcept>
#include <string>
#include <vector>

namespace vilma::usb_imu {

// A transport failure. `device_gone`: the device disappeared (unplugged, tty hung up,
// LIBUSB_ERROR_NO_DEVICE): the driver closes and reopens with backoff.
class TransportError : public std::runtime_error {
 public:
  TransportError(const std::string& message, bool device_gone)
      : std::runtime_error(message), device_gone_(device_gone) {}
  bool device_gone() const { return device_gone_; }

 private:
  bool device_gone_;
};

class ByteTransport {
 public:
  virtual ~ByteTransport() = default;
  // Opens (or reopens after Close) the device; throws TransportError.
  virtual void Open() = 0;
  virtual void Close() = 0;
  // Reads up to `size` bytes, waiting at most `timeout_ms`; 0 on timeout. Throws TransportError.
  virtual std::size_t Read(uint8_t* data, std::size_t size, int timeout_ms) = 0;
  // Writes all bytes or throws TransportError.
  virtual void Write(const uint8_t* data, std::size_t size) = 0;
  // True when no byte will ever come again (end of a replayed file).
  virtual bool AtEnd() const { return false; }
  // What is open, for logs and errors ("/dev/ttyACM0 at 115200 baud").
  virtual std::string Describe() const = 0;
};

class SerialTransport : public ByteTransport {
 public:
  // `baud`: one of the standard termios rates (9600 .. 921600); checked by Open().
  SerialTransport(std::string path, int baud);
  ~SerialTransport() override;
  void Open() override;
  void Close() override;
  std::size_t Read(uint8_t* data, std::size_t size, int timeout_ms) override;
  void Write(const uint8_t* data, std::size_t size) override;
  std::string Describe() const override;

 private:
  std::string path_;
  int baud_;
  int fd_ = -1;
};

// True if `baud` is a rate SerialTransport supports.
bool IsSupportedBaud(int baud);

struct UsbDeviceSelector {
  uint16_t vendor_id = 0x199b;                      // MicroStrain
  std::vector<uint16_t> product_ids = {0x3065, 0x3d65};  // GX5 / CV7 / GQ7 family; older GX4
  std::string serial;                               // iSerialNumber to match; "" = first found
};

// A USB device seen by libusb, for --list and for errors that say what was found instead.
struct UsbDeviceInfo {
  uint16_t vendor_id = 0;
  uint16_t product_id = 0;
  int bus = 0;
  int address = 0;
  std::string serial;
  std::string product;
};

// Devices with `vendor_id` (0: all) on the bus; throws TransportError when libusb cannot start.
std::vector<UsbDeviceInfo> ListUsbDevices(uint16_t vendor_id);

class UsbTransport : public ByteTransport {
 public:
  explicit UsbTransport(UsbDeviceSelector selector);
  ~UsbTransport() override;
  void Open() override;
  void Close() override;
  std::size_t Read(uint8_t* data, std::size_t size, int timeout_ms) override;
  void Write(const uint8_t* data, std::size_t size) override;
  std::string Describe() const override;

 private:
  struct Impl;
  UsbDeviceSelector selector_;
  std::unique_ptr<Impl> impl_;
};

class ReplayTransport : public ByteTransport {
 public:
  // Reads `path` in chunks of `chunk_bytes` (a USB/tty read returns a few packets at a time).
  explicit ReplayTransport(std::string path, std::size_t chunk_bytes = 64);
  void Open() override;
  void Close() override {}
  std::size_t Read(uint8_t* data, std::size_t size, int timeout_ms) override;
  void Write(const uint8_t*, std::size_t) override {}
  bool AtEnd() const override { return opened_ && at_ >= bytes_.size(); }
  std::string Describe() const override { return "recorded bytes " + path_; }

 private:
  std::string path_;
  std::size_t chunk_bytes_;
  std::vector<uint8_t> bytes_;
  std::size_t at_ = 0;
  bool opened_ = false;
};

}  // namespace vilma::usb_imu
