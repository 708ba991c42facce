// UsbTransport of transport.h: the IMU's USB CDC-ACM function driven directly through libusb
// (no tty). Runs only with the hardware (docs/drivers.md); the tests cover "no such device".
//
// A MicroStrain GX5/CV7 enumerates as a CDC-ACM device: a communication interface (class 0x02)
// and a data interface (class 0x0A) with one bulk IN and one bulk OUT endpoint carrying the
// MIP byte stream. The kernel's cdc_acm binds both; libusb's auto-detach unbinds it while we
// hold the interfaces and rebinds it when we release them.
#include <libusb.h>

#include <algorithm>
#include <sstream>

#include "vilma/drivers/usb_imu/transport.h"

namespace vilma::usb_imu {
namespace {

constexpr uint8_t kCdcCommunicationClass = 0x02;
constexpr uint8_t kCdcDataClass = 0x0A;
// CDC class requests (USB CDC PSTN subclass 1.2, section 6.3).
constexpr uint8_t kSetLineCoding = 0x20;
constexpr uint8_t kSetControlLineState = 0x22;

std::string Hex4(uint16_t value) {
  std::ostringstream out;
  out.width(4);
  out.fill('0');
  out << std::hex << value;
  return out.str();
}

// Errors after which the device is gone (unplugged): the driver reopens with backoff.
bool IsGone(int code) {
  return code == LIBUSB_ERROR_NO_DEVICE || code == LIBUSB_ERROR_IO ||
         code == LIBUSB_ERROR_NOT_FOUND;
}

std::string StringDescriptor(libusb_device_handle* handle, uint8_t index) {
  if (index == 0) return "";
  unsigned char text[256] = {};
  const int n = libusb_get_string_descriptor_ascii(handle, index, text, sizeof(text));
  return n > 0 ? std::string(reinterpret_cast<const char*>(text), static_cast<std::size_t>(n))
               : "";
}

}  // namespace

struct UsbTransport::Impl {
  libusb_context* context = nullptr;
  libusb_device_handle* handle = nullptr;
  int comm_interface = -1;
  int data_interface = -1;
  bool comm_claimed = false;
  bool data_claimed = false;
  uint8_t endpoint_in = 0;
  uint8_t endpoint_out = 0;
  int in_packet_bytes = 64;  // wMaxPacketSize of the IN endpoint
  std::string description;
};

std::vector<UsbDeviceInfo> ListUsbDevices(uint16_t vendor_id) {
  libusb_context* context = nullptr;
  const int init = libusb_init(&context);
  if (init != 0) {
    throw TransportError(std::string("libusb_init: ") + libusb_error_name(init), false);
  }
  std::vector<UsbDeviceInfo> out;
  libusb_device** list = nullptr;
  const ssize_t count = libusb_get_device_list(context, &list);
  for (ssize_t i = 0; i < count; ++i) {
    libusb_device_descriptor d{};
    if (libusb_get_device_descriptor(list[i], &d) != 0) continue;
    if (vendor_id != 0 && d.idVendor != vendor_id) continue;
    UsbDeviceInfo info;
    info.vendor_id = d.idVendor;
    info.product_id = d.idProduct;
    info.bus = libusb_get_bus_number(list[i]);
    info.address = libusb_get_device_address(list[i]);
    libusb_device_handle* handle = nullptr;
    if (libusb_open(list[i], &handle) == 0) {
      info.serial = StringDescriptor(handle, d.iSerialNumber);
      info.product = StringDescriptor(handle, d.iProduct);
      libusb_close(handle);
    }
    out.push_back(info);
  }
  if (count >= 0) libusb_free_device_list(list, 1);
  libusb_exit(context);
  return out;
}

UsbTransport::UsbTransport(UsbDeviceSelector selector)
    : selector_(std::move(selector)), impl_(std::make_unique<Impl>()) {}

UsbTransport::~UsbTransport() { Close(); }

std::string UsbTransport::Describe() const {
  if (!impl_->description.empty()) return impl_->description;
  std::string ids = "USB " + Hex4(selector_.vendor_id) + ":";
  for (std::size_t i = 0; i < selector_.product_ids.size(); ++i) {
    ids += (i ? "/" : "") + Hex4(selector_.product_ids[i]);
  }
  if (!selector_.serial.empty()) ids += " serial " + selector_.serial;
  return ids;
}

void UsbTransport::Open() {
  Close();
  Impl& m = *impl_;
  const int init = libusb_init(&m.context);
  if (init != 0) {
    m.context = nullptr;
    throw TransportError(std::string("libusb_init: ") + libusb_error_name(init), false);
  }
  libusb_device** list = nullptr;
  const ssize_t count = libusb_get_device_list(m.context, &list);
  std::string open_error;
  for (ssize_t i = 0; i < count && m.handle == nullptr; ++i) {
    libusb_device_descriptor d{};
    if (libusb_get_device_descriptor(list[i], &d) != 0 || d.idVendor != selector_.vendor_id) {
      continue;
    }
    bool product_matches = false;
    for (uint16_t id : selector_.product_ids) product_matches = product_matches || id == d.idProduct;
    if (!product_matches) continue;
    libusb_device_handle* handle = nullptr;
    const int opened = libusb_open(list[i], &handle);
    if (opened != 0) {
      open_error = std::string(libusb_error_name(opened)) +
                   (opened == LIBUSB_ERROR_ACCESS
                        ? " (install config/udev/99-vilma-usb-imu.rules and replug)"
                        : "");
      continue;
    }
    const std::string serial = StringDescriptor(handle, d.iSerialNumber);
    if (!selector_.serial.empty() && serial != selector_.serial) {
      libusb_close(handle);
      continue;
    }
    m.handle = handle;
    m.description = "USB " + Hex4(d.idVendor) + ":" + Hex4(d.idProduct) + " bus " +
                    std::to_string(libusb_get_bus_number(list[i])) + " device " +
                    std::to_string(libusb_get_device_address(list[i])) +
                    (serial.empty() ? "" : " serial " + serial);
  }
  if (count >= 0) libusb_free_device_list(list, 1);
  if (m.handle == nullptr) {
    const std::string what = Describe();
    Close();
    throw TransportError(what + ": " + (open_error.empty() ? "no such device" : "cannot open: " + open_error),
                         open_error.empty());
  }

  // The CDC data interface and its bulk endpoints (else the first interface with bulk IN+OUT).
  libusb_config_descriptor* config = nullptr;
  if (libusb_get_active_config_descriptor(libusb_get_device(m.handle), &config) != 0) {
    const std::string what = m.description;
    Close();
    throw TransportError(what + ": cannot read the configuration descriptor", true);
  }
  for (uint8_t i = 0; i < config->bNumInterfaces; ++i) {
    if (config->interface[i].num_altsetting < 1) continue;
    const libusb_interface_descriptor& alt = config->interface[i].altsetting[0];
    if (alt.bInterfaceClass == kCdcCommunicationClass && m.comm_interface < 0) {
      m.comm_interface = alt.bInterfaceNumber;
    }
    uint8_t in = 0;
    uint8_t out = 0;
    int in_packet_bytes = 64;
    for (uint8_t e = 0; e < alt.bNumEndpoints; ++e) {
      const libusb_endpoint_descriptor& ep = alt.endpoint[e];
      if ((ep.bmAttributes & 0x03) != LIBUSB_TRANSFER_TYPE_BULK) continue;
      if (ep.bEndpointAddress & LIBUSB_ENDPOINT_IN) {
        in = ep.bEndpointAddress;
        in_packet_bytes = std::max(8, static_cast<int>(ep.wMaxPacketSize & 0x7FF));
      } else {
        out = ep.bEndpointAddress;
      }
    }
    const bool better = m.data_interface < 0 || alt.bInterfaceClass == kCdcDataClass;
    if (in != 0 && out != 0 && better) {
      m.data_interface = alt.bInterfaceNumber;
      m.endpoint_in = in;
      m.endpoint_out = out;
      m.in_packet_bytes = in_packet_bytes;
    }
  }
  libusb_free_config_descriptor(config);
  if (m.data_interface < 0) {
    const std::string what = m.description;
    Close();
    throw TransportError(what + ": no interface with bulk IN and OUT endpoints", false);
  }
  libusb_set_auto_detach_kernel_driver(m.handle, 1);
  const int claimed = libusb_claim_interface(m.handle, m.data_interface);
  if (claimed != 0) {
    const std::string what = m.description;
    Close();
    throw TransportError(what + ": cannot claim interface " + std::to_string(m.data_interface) +
                             ": " + libusb_error_name(claimed) +
                             " (another program holds the device?)",
                         IsGone(claimed));
  }
  m.data_claimed = true;
  // Line coding and DTR/RTS on the communication interface: harmless on a native USB device,
  // and some CDC firmwares only send once DTR is set. Failures here are not fatal.
  if (m.comm_interface >= 0 && libusb_claim_interface(m.handle, m.comm_interface) == 0) {
    m.comm_claimed = true;
    unsigned char coding[7] = {0x00, 0xC2, 0x01, 0x00, 0, 0, 8};  // 115200 8N1, little-endian
    libusb_control_transfer(m.handle, 0x21, kSetLineCoding, 0,
                            static_cast<uint16_t>(m.comm_interface), coding, sizeof(coding), 500);
    libusb_control_transfer(m.handle, 0x21, kSetControlLineState, 0x0003,
                            static_cast<uint16_t>(m.comm_interface), nullptr, 0, 500);
  }
}

void UsbTransport::Close() {
  Impl& m = *impl_;
  if (m.handle != nullptr) {
    if (m.comm_claimed) libusb_release_interface(m.handle, m.comm_interface);
    if (m.data_claimed) libusb_release_interface(m.handle, m.data_interface);
    libusb_close(m.handle);
  }
  if (m.context != nullptr) libusb_exit(m.context);
  m = Impl();
}

std::size_t UsbTransport::Read(uint8_t* data, std::size_t size, int timeout_ms) {
  Impl& m = *impl_;
  if (m.handle == nullptr) throw TransportError(Describe() + ": not open", true);
  // One USB packet per transfer: a bulk IN transfer ends early only on a short packet, so a
  // larger request could hold full-size packets back until the timeout, and the arrival stamps
  // (the clock filter's input) would lag by up to timeout_ms.
  const auto request = static_cast<int>(std::min<std::size_t>(
      size, static_cast<std::size_t>(m.in_packet_bytes)));
  int transferred = 0;
  const int rc = libusb_bulk_transfer(m.handle, m.endpoint_in, data, request, &transferred,
                                      static_cast<unsigned>(timeout_ms));
  if (rc == 0 || rc == LIBUSB_ERROR_TIMEOUT) return static_cast<std::size_t>(transferred);
  if (rc == LIBUSB_ERROR_PIPE) {  // a stalled endpoint: clear it and go on
    libusb_clear_halt(m.handle, m.endpoint_in);
    return static_cast<std::size_t>(transferred);
  }
  throw TransportError(m.description + ": bulk read: " + libusb_error_name(rc), IsGone(rc));
}

void UsbTransport::Write(const uint8_t* data, std::size_t size) {
  Impl& m = *impl_;
  if (m.handle == nullptr) throw TransportError(Describe() + ": not open", true);
  int transferred = 0;
  const int rc = libusb_bulk_transfer(m.handle, m.endpoint_out, const_cast<uint8_t*>(data),
                                      static_cast<int>(size), &transferred, 1000);
  if (rc != 0 || transferred != static_cast<int>(size)) {
    throw TransportError(m.description + ": bulk write: " +
                             (rc != 0 ? libusb_error_name(rc) : "short write"),
                         IsGone(rc));
  }
}

}  // namespace vilma::usb_imu
