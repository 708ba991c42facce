#include "vilma/drivers/aravis/aravis_camera.h"

#include <arv.h>

#include <cmath>
#include <sstream>
#include <stdexcept>

namespace vilma::aravis {
namespace {

std::string Str(const char* s) { return s == nullptr ? "" : s; }

// Throws "what: Aravis's message" if `error` is set (and frees it).
void Check(GError* error, const std::string& what) {
  if (error == nullptr) return;
  const std::string message = what + ": " + error->message;
  g_error_free(error);
  throw std::runtime_error(message);
}

// An optional query: false (and the error swallowed) if the camera cannot answer.
bool Ok(GError* error) {
  if (error == nullptr) return true;
  g_error_free(error);
  return false;
}

std::string Join(const char** items, guint n) {
  std::string text;
  for (guint i = 0; i < n; ++i) text += (i ? " " : "") + Str(items[i]);
  g_free(static_cast<void*>(items));
  return text;
}

ArvAuto AutoOf(const std::string& mode) {
  if (mode == "once") return ARV_AUTO_ONCE;
  if (mode == "continuous") return ARV_AUTO_CONTINUOUS;
  return ARV_AUTO_OFF;
}

const char* BufferStatusName(ArvBufferStatus status) {
  switch (status) {
    case ARV_BUFFER_STATUS_SUCCESS: return "SUCCESS";
    case ARV_BUFFER_STATUS_CLEARED: return "CLEARED";
    case ARV_BUFFER_STATUS_TIMEOUT: return "TIMEOUT";
    case ARV_BUFFER_STATUS_MISSING_PACKETS: return "MISSING_PACKETS";
    case ARV_BUFFER_STATUS_WRONG_PACKET_ID: return "WRONG_PACKET_ID";
    case ARV_BUFFER_STATUS_SIZE_MISMATCH: return "SIZE_MISMATCH";
    case ARV_BUFFER_STATUS_FILLING: return "FILLING";
    case ARV_BUFFER_STATUS_ABORTED: return "ABORTED";
    default: return "UNKNOWN";
  }
}

int64_t RealtimeNowNs() {
  timespec ts{};
  clock_gettime(CLOCK_REALTIME, &ts);
  return static_cast<int64_t>(ts.tv_sec) * 1000000000 + ts.tv_nsec;
}

void OnControlLost(ArvDevice* /*device*/, gpointer user_data) {
  static_cast<std::atomic<bool>*>(user_data)->store(true);
}

}  // namespace

std::vector<CameraInfo> DiscoverCameras(bool fake) {
  // Either the fake camera or the real interfaces: GigE Vision discovery waits 1 s for
  // answers, which the fake camera need not pay (at start and at every reconnect).
  for (const char* real : {"GigEVision", "USB3Vision"}) {
    if (fake) {
      arv_disable_interface(real);
    } else {
      arv_enable_interface(real);
    }
  }
  if (fake) {
    arv_enable_interface("Fake");
  } else {
    arv_disable_interface("Fake");
  }
  arv_update_device_list();
  std::vector<CameraInfo> cameras;
  const unsigned n = arv_get_n_devices();
  for (unsigned i = 0; i < n; ++i) {
    CameraInfo c;
    c.id = Str(arv_get_device_id(i));
    c.vendor = Str(arv_get_device_vendor(i));
    c.model = Str(arv_get_device_model(i));
    c.serial = Str(arv_get_device_serial_nbr(i));
    c.protocol = Str(arv_get_device_protocol(i));
    c.physical_id = Str(arv_get_device_physical_id(i));
    c.address = Str(arv_get_device_address(i));
    cameras.push_back(c);
  }
  return cameras;
}

std::string FindCamera(const std::vector<CameraInfo>& cameras, const std::string& device,
                       CameraInfo* found) {
  if (cameras.empty()) {
    return "no camera found (GigE Vision cameras must be on a reachable subnet, USB3 Vision "
           "cameras need access rights: see docs/drivers.md)";
  }
  if (device.empty()) {
    *found = cameras.front();
    return "";
  }
  for (const CameraInfo& c : cameras) {
    if (device == c.id || device == c.serial || device == c.physical_id ||
        (!c.address.empty() && device == c.address)) {
      *found = c;
      return "";
    }
  }
  std::string known;
  for (const CameraInfo& c : cameras) known += (known.empty() ? "" : ", ") + c.id;
  return "no camera '" + device + "' (found: " + known + ")";
}

AravisCamera::AravisCamera(const CameraInfo& info, const AravisOptions& options)
    : info_(info), options_(options) {
  GError* error = nullptr;
  camera_ = arv_camera_new(info.id.c_str(), &error);
  Check(error, "open camera " + info.id);
  if (camera_ == nullptr) throw std::runtime_error("open camera " + info.id + ": failed");
  ArvDevice* device = arv_camera_get_device(camera_);
  control_lost_handler_ =
      g_signal_connect(device, "control-lost", G_CALLBACK(OnControlLost), &control_lost_);
  frame_ids_wrap_16bit_ = arv_camera_is_gv_device(camera_) || info.protocol == "Fake";
  try {
    Configure(options);
  } catch (...) {
    g_signal_handler_disconnect(device, control_lost_handler_);
    g_object_unref(camera_);
    throw;
  }
}

AravisCamera::~AravisCamera() {
  Stop();
  if (stream_ != nullptr) g_object_unref(stream_);
  if (camera_ != nullptr) {
    g_signal_handler_disconnect(arv_camera_get_device(camera_), control_lost_handler_);
    g_object_unref(camera_);
  }
}

void AravisCamera::Configure(const AravisOptions& o) {
  GError* error = nullptr;
  // Settings that change the payload are only writable while the camera is idle.
  arv_camera_stop_acquisition(camera_, nullptr);

  arv_camera_set_pixel_format_from_string(camera_, o.pixel_format.c_str(), &error);
  Check(error, "pixel_format " + o.pixel_format + " (see vilma-aravis --list)");

  int x = 0, y = 0, w = 0, h = 0;
  arv_camera_get_region(camera_, &x, &y, &w, &h, &error);
  Check(error, "read the region");
  const int want_w = o.width > 0 ? o.width : w;
  const int want_h = o.height > 0 ? o.height : h;
  arv_camera_set_region(camera_, o.offset_x, o.offset_y, want_w, want_h, &error);
  Check(error, "region " + std::to_string(want_w) + "x" + std::to_string(want_h) + "+" +
                   std::to_string(o.offset_x) + "+" + std::to_string(o.offset_y));
  arv_camera_get_region(camera_, &x, &y, &width_, &height_, &error);
  Check(error, "read the region");
  if ((o.width > 0 && width_ != o.width) || (o.height > 0 && height_ != o.height)) {
    throw std::runtime_error("region: the camera set " + std::to_string(width_) + "x" +
                             std::to_string(height_) + " instead of " + std::to_string(o.width) +
                             "x" + std::to_string(o.height) + " (size increments: --list)");
  }

  if (o.trigger) {
    arv_camera_set_trigger(camera_, o.trigger_source.c_str(), &error);
    Check(error, "trigger_source " + o.trigger_source);
    if (arv_camera_is_feature_available(camera_, "TriggerActivation", nullptr)) {
      arv_camera_set_string(camera_, "TriggerActivation", o.trigger_activation.c_str(), &error);
      Check(error, "trigger_activation " + o.trigger_activation);
    }
  } else if (arv_camera_is_feature_available(camera_, "TriggerMode", nullptr)) {
    arv_camera_clear_triggers(camera_, &error);
    Check(error, "switch the trigger off");
  }
  // In trigger mode the frame rate limits the trigger rate only on some cameras; set it when
  // asked all the same, except that cameras refuse it while triggered (then it is not fatal).
  if (o.frame_rate_hz > 0.0) {
    arv_camera_set_frame_rate(camera_, o.frame_rate_hz, &error);
    if (o.trigger) {
      Ok(error);
    } else {
      Check(error, "frame_rate_hz " + std::to_string(o.frame_rate_hz));
    }
  }
  frame_rate_hz_ = arv_camera_get_frame_rate(camera_, &error);
  if (!Ok(error)) frame_rate_hz_ = 0.0;

  if (o.exposure_auto != "off" || arv_camera_is_exposure_auto_available(camera_, nullptr)) {
    arv_camera_set_exposure_time_auto(camera_, AutoOf(o.exposure_auto), &error);
    if (o.exposure_auto == "off") {
      Ok(error);  // cameras without ExposureAuto are always "off"
    } else {
      Check(error, "exposure_auto " + o.exposure_auto);
    }
  }
  if (o.exposure_auto == "off" && o.exposure_us > 0.0) {
    arv_camera_set_exposure_time(camera_, o.exposure_us, &error);
    Check(error, "exposure_us " + std::to_string(o.exposure_us));
  }
  if (o.gain_auto != "off" || arv_camera_is_gain_auto_available(camera_, nullptr)) {
    arv_camera_set_gain_auto(camera_, AutoOf(o.gain_auto), &error);
    if (o.gain_auto == "off") {
      Ok(error);
    } else {
      Check(error, "gain_auto " + o.gain_auto);
    }
  }
  if (o.gain_auto == "off" && o.gain >= 0.0) {
    arv_camera_set_gain(camera_, o.gain, &error);
    Check(error, "gain " + std::to_string(o.gain));
  }

  if (arv_camera_is_gv_device(camera_)) {
    if (o.packet_size > 0) {
      arv_camera_gv_set_packet_size(camera_, o.packet_size, &error);
      Check(error, "packet_size " + std::to_string(o.packet_size));
    } else {
      arv_camera_gv_auto_packet_size(camera_, &error);
      Check(error, "negotiate the packet size");
    }
  }
  pixel_format_ = Str(arv_camera_get_pixel_format_as_string(camera_, nullptr));
}

void AravisCamera::Start() {
  GError* error = nullptr;
  if (stream_ == nullptr) {
    stream_ = arv_camera_create_stream(camera_, nullptr, nullptr, &error);
    Check(error, "create the stream");
    if (stream_ == nullptr) throw std::runtime_error("create the stream: failed");
    if (ARV_IS_GV_STREAM(stream_)) {
      g_object_set(stream_, "packet-resend",
                   options_.packet_resend ? ARV_GV_STREAM_PACKET_RESEND_ALWAYS
                                          : ARV_GV_STREAM_PACKET_RESEND_NEVER,
                   nullptr);
    }
    const guint payload = arv_camera_get_payload(camera_, &error);
    Check(error, "read the payload size");
    for (int i = 0; i < options_.buffers; ++i) {
      arv_stream_push_buffer(stream_, arv_buffer_new_allocate(payload));
    }
  }
  arv_camera_start_acquisition(camera_, &error);
  Check(error, "start acquisition");
  acquiring_ = true;
}

void AravisCamera::Stop() {
  if (!acquiring_) return;
  acquiring_ = false;
  arv_camera_stop_acquisition(camera_, nullptr);  // a lost camera cannot answer: not an error
}

bool AravisCamera::Pop(uint64_t timeout_us, CameraFrame* frame) {
  ArvBuffer* buffer = arv_stream_timeout_pop_buffer(stream_, timeout_us);
  if (buffer == nullptr) return false;
  *frame = CameraFrame();
  frame->buffer = buffer;
  const ArvBufferStatus status = arv_buffer_get_status(buffer);
  frame->status = BufferStatusName(status);
  frame->frame_id = arv_buffer_get_frame_id(buffer);
  frame->device_ns = static_cast<int64_t>(arv_buffer_get_timestamp(buffer));
  frame->host_arrival_ns = static_cast<int64_t>(arv_buffer_get_system_timestamp(buffer));
  if (frame->host_arrival_ns == 0) frame->host_arrival_ns = RealtimeNowNs();
  frame->ok = status == ARV_BUFFER_STATUS_SUCCESS &&
              arv_buffer_get_payload_type(buffer) == ARV_BUFFER_PAYLOAD_TYPE_IMAGE;
  if (frame->ok) {
    size_t size = 0;
    frame->raw.data = static_cast<const uint8_t*>(arv_buffer_get_image_data(buffer, &size));
    frame->raw.size = size;
    frame->raw.width = arv_buffer_get_image_width(buffer);
    frame->raw.height = arv_buffer_get_image_height(buffer);
    gint x_padding = 0, y_padding = 0;
    arv_buffer_get_image_padding(buffer, &x_padding, &y_padding);
    frame->raw.row_padding = x_padding;
    frame->format_known =
        SourceFormatFromPfnc(arv_buffer_get_image_pixel_format(buffer), &frame->raw.format);
  }
  return true;
}

void AravisCamera::Requeue(CameraFrame* frame) {
  if (frame->buffer != nullptr) arv_stream_push_buffer(stream_, frame->buffer);
  frame->buffer = nullptr;
}

void AravisCamera::SoftwareTrigger() {
  GError* error = nullptr;
  arv_camera_software_trigger(camera_, &error);
  Check(error, "software trigger");
}

double AravisCamera::ReadExposureUs() {
  GError* error = nullptr;
  if (!arv_camera_is_exposure_time_available(camera_, nullptr)) return 0.0;
  const double exposure_us = arv_camera_get_exposure_time(camera_, &error);
  return Ok(error) && std::isfinite(exposure_us) && exposure_us > 0.0 ? exposure_us : 0.0;
}

std::vector<std::pair<std::string, uint64_t>> AravisCamera::StreamCounters() const {
  std::vector<std::pair<std::string, uint64_t>> counters;
  if (stream_ == nullptr) return counters;
  const guint n = arv_stream_get_n_infos(stream_);
  for (guint i = 0; i < n; ++i) {
    if (arv_stream_get_info_type(stream_, i) != G_TYPE_UINT64) continue;
    counters.emplace_back(Str(arv_stream_get_info_name(stream_, i)),
                          arv_stream_get_info_uint64(stream_, i));
  }
  return counters;
}

std::string DescribeCamera(const CameraInfo& info) {
  GError* error = nullptr;
  ArvCamera* camera = arv_camera_new(info.id.c_str(), &error);
  Check(error, "open camera " + info.id);
  std::ostringstream out;
  out << "camera " << info.id << ": " << info.vendor << " " << info.model << ", serial "
      << info.serial << ", " << info.protocol << "\n";
  int sw = 0, sh = 0;
  arv_camera_get_sensor_size(camera, &sw, &sh, &error);
  if (Ok(error)) out << "  sensor: " << sw << "x" << sh << " px\n";
  int x = 0, y = 0, w = 0, h = 0;
  arv_camera_get_region(camera, &x, &y, &w, &h, &error);
  if (Ok(error)) out << "  region: " << w << "x" << h << "+" << x << "+" << y << "\n";
  int wmin = 0, wmax = 0, hmin = 0, hmax = 0;
  arv_camera_get_width_bounds(camera, &wmin, &wmax, &error);
  const bool have_w = Ok(error);
  arv_camera_get_height_bounds(camera, &hmin, &hmax, &error);
  if (have_w && Ok(error)) {
    out << "  width " << wmin << ".." << wmax << " (step "
        << arv_camera_get_width_increment(camera, nullptr) << "), height " << hmin << ".."
        << hmax << " (step " << arv_camera_get_height_increment(camera, nullptr) << ")\n";
  }
  if (arv_camera_is_binning_available(camera, nullptr)) {
    int bx = 1, by = 1;
    arv_camera_get_binning(camera, &bx, &by, nullptr);
    out << "  binning: " << bx << "x" << by << "\n";
  }
  guint n = 0;
  const char** formats = arv_camera_dup_available_pixel_formats_as_strings(camera, &n, &error);
  if (Ok(error) && formats != nullptr) {
    out << "  pixel formats: " << Join(formats, n) << " (now "
        << Str(arv_camera_get_pixel_format_as_string(camera, nullptr)) << ")\n";
  }
  if (arv_camera_is_frame_rate_available(camera, nullptr)) {
    double lo = 0, hi = 0;
    arv_camera_get_frame_rate_bounds(camera, &lo, &hi, nullptr);
    out << "  frame rate: " << arv_camera_get_frame_rate(camera, nullptr) << " Hz (" << lo
        << ".." << hi << ")\n";
  }
  if (arv_camera_is_exposure_time_available(camera, nullptr)) {
    double lo = 0, hi = 0;
    arv_camera_get_exposure_time_bounds(camera, &lo, &hi, nullptr);
    out << "  exposure: " << arv_camera_get_exposure_time(camera, nullptr) << " us (" << lo
        << ".." << hi << "), auto "
        << (arv_camera_is_exposure_auto_available(camera, nullptr) ? "available" : "no") << "\n";
  }
  if (arv_camera_is_gain_available(camera, nullptr)) {
    double lo = 0, hi = 0;
    arv_camera_get_gain_bounds(camera, &lo, &hi, nullptr);
    out << "  gain: " << arv_camera_get_gain(camera, nullptr) << " (" << lo << ".." << hi
        << "), auto " << (arv_camera_is_gain_auto_available(camera, nullptr) ? "available" : "no")
        << "\n";
  }
  const char** sources = arv_camera_dup_available_trigger_sources(camera, &n, &error);
  if (Ok(error) && sources != nullptr) out << "  trigger sources: " << Join(sources, n) << "\n";
  if (arv_camera_is_feature_available(camera, "TriggerActivation", nullptr)) {
    const char** act = arv_camera_dup_available_enumerations_as_strings(camera, "TriggerActivation",
                                                                       &n, &error);
    if (Ok(error) && act != nullptr) out << "  trigger activations: " << Join(act, n) << "\n";
  }
  if (arv_camera_is_feature_available(camera, "GevTimestampTickFrequency", nullptr)) {
    out << "  timestamp tick frequency: "
        << arv_camera_get_integer(camera, "GevTimestampTickFrequency", nullptr) << " Hz\n";
  }
  if (arv_camera_is_gv_device(camera)) {
    out << "  GigE packet size: " << arv_camera_gv_get_packet_size(camera, nullptr)
        << " bytes\n";
  }
  out << "  payload: " << arv_camera_get_payload(camera, nullptr) << " bytes\n";
  g_object_unref(camera);
  return out.str();
}

}  // namespace vilma::aravis
