#include "vilma/drivers/v4l2/v4l2_options.h"

#include <cmath>
#include <cstdlib>
#include <sstream>

#include "vilma/core/arg_cursor.h"
#include "vilma/core/error.h"
#include "vilma/core/validate.h"
#include "vilma/drivers/driver_status.h"
#include "vilma/drivers/lcm_url.h"

namespace vilma::v4l2 {
namespace {

bool ParseNumber(const std::string& text, double* value) {
  char* end = nullptr;
  *value = std::strtod(text.c_str(), &end);
  return !text.empty() && end != nullptr && *end == '\0' && std::isfinite(*value);
}

bool ParseInt(const std::string& text, int64_t* value) {
  char* end = nullptr;
  *value = std::strtoll(text.c_str(), &end, 10);
  return !text.empty() && end != nullptr && *end == '\0';
}

// "GREY,Y16" or a YAML list -> fourccs; "" or the bad name's message.
std::string ParseFourccs(const std::vector<std::string>& names, std::vector<uint32_t>* fourccs) {
  fourccs->clear();
  for (const std::string& name : names) {
    const uint32_t fourcc = FourccFromName(name);
    if (fourcc == 0) return "'" + name + "' is not a fourcc (expected GREY, Y16, YUYV or MJPG)";
    fourccs->push_back(fourcc);
  }
  return "";
}

std::vector<std::string> SplitComma(const std::string& text) {
  std::vector<std::string> parts;
  std::stringstream ss(text);
  std::string part;
  while (std::getline(ss, part, ',')) parts.push_back(part);
  return parts;
}

double NumberOr(const YamlNode& node, const std::string& key, double fallback) {
  return node.GetOr<double>(key, fallback);
}

}  // namespace

bool ParseExposure(const std::string& text, double* exposure_us) {
  if (text == "auto") {
    *exposure_us = 0.0;
    return true;
  }
  double value = 0.0;
  if (!ParseNumber(text, &value) || value <= 0.0) return false;
  *exposure_us = value;
  return true;
}

bool ParseGain(const std::string& text, int* gain) {
  if (text == "auto") {
    *gain = -1;
    return true;
  }
  int64_t value = 0;
  if (!ParseInt(text, &value) || value < 0 || value > 1000000) return false;
  *gain = static_cast<int>(value);
  return true;
}

std::string V4l2DriverOptions::Validate() const {
  const std::string capture_error = capture.Validate();
  if (!capture_error.empty()) return capture_error;
  const std::string lcm_error = ValidateLcm();
  if (!lcm_error.empty()) return lcm_error;
  if (camera_id < 0) return "camera_id: expected >= 0";
  return "";
}

V4l2DriverOptions ReadV4l2Options(const YamlNode& root, const V4l2DriverOptions& defaults) {
  if (!root.IsMap()) root.Fail("", "a map of vilma-v4l2 options");
  V4l2DriverOptions o = defaults;
  o.config_file = root.file();
  CaptureOptions& c = o.capture;
  c.device = root.GetOr<std::string>("device", c.device);
  if (root.Has("formats")) {
    const YamlNode list = root.Child("formats");
    if (!list.IsSequence()) root.Fail("formats", "a list of fourccs, e.g. [GREY, YUYV, MJPG]");
    std::vector<std::string> names;
    for (const YAML::Node& item : list.raw()) {
      if (!item.IsScalar()) root.Fail("formats", "a list of fourccs, e.g. [GREY, YUYV, MJPG]");
      names.push_back(item.Scalar());
    }
    const std::string error = ParseFourccs(names, &c.format.fourccs);
    if (!error.empty()) root.Fail("formats", error);
  }
  c.format.width = root.GetOr<int>("width", c.format.width);
  c.format.height = root.GetOr<int>("height", c.format.height);
  c.format.fps = NumberOr(root, "fps", c.format.fps);
  c.format.require_size = root.GetOr<bool>("require_size", c.format.require_size);
  c.format.require_fps = root.GetOr<bool>("require_fps", c.format.require_fps);
  c.keep_16_bit = root.GetOr<bool>("keep_16_bit", c.keep_16_bit);
  c.buffers = root.GetOr<int>("buffers", c.buffers);
  if (root.Has("exposure") &&
      !ParseExposure(root.Get<std::string>("exposure"), &c.controls.exposure_us)) {
    root.Fail("exposure", "auto or a positive exposure time [us]");
  }
  if (root.Has("gain") && !ParseGain(root.Get<std::string>("gain"), &c.controls.gain)) {
    root.Fail("gain", "auto or an integer >= 0 (the camera's gain units)");
  }
  if (root.Has("controls")) {
    const YamlNode controls = root.Child("controls");
    if (!controls.IsMap()) root.Fail("controls", "a map of control name: integer value");
    c.controls.controls.clear();
    for (const auto& kv : controls.raw()) {
      const std::string name = kv.first.as<std::string>();
      c.controls.controls[name] = controls.Get<int64_t>(name);
    }
  }
  c.exposure_readback_s = NumberOr(root, "exposure_readback_s", c.exposure_readback_s);
  if (root.Has("timestamps")) {
    const YamlNode t = root.MapChild("timestamps");
    c.timestamps.mid_exposure = t.GetOr<bool>("mid_exposure", c.timestamps.mid_exposure);
    c.timestamps.readout_us = NumberOr(t, "readout_us", c.timestamps.readout_us);
    if (t.Has("stamp_source") &&
        !ParseStampPoint(t.Get<std::string>("stamp_source"), &c.timestamps.stamp_source)) {
      t.Fail("stamp_source", "auto, start_of_exposure, end_of_exposure or end_of_frame");
    }
    c.timestamps.offset_refresh_s = NumberOr(t, "offset_refresh_s", c.timestamps.offset_refresh_s);
    c.timestamps.realtime_step_ms = NumberOr(t, "realtime_step_ms", c.timestamps.realtime_step_ms);
    t.CheckNoUnknownKeys();
  }
  if (root.Has("recovery")) {
    const YamlNode r = root.MapChild("recovery");
    c.reconnect_initial_s = NumberOr(r, "reconnect_initial_s", c.reconnect_initial_s);
    c.reconnect_max_s = NumberOr(r, "reconnect_max_s", c.reconnect_max_s);
    c.frame_timeout_s = NumberOr(r, "frame_timeout_s", c.frame_timeout_s);
    r.CheckNoUnknownKeys();
  }
  ReadDriverLcmOptions(root, &o);
  o.camera_id = root.GetOr<int>("camera_id", o.camera_id);
  root.CheckNoUnknownKeys();
  root.CheckValid(o.Validate());
  return o;
}

V4l2DriverOptions LoadV4l2Options(const std::string& path) {
  return ReadV4l2Options(YamlNode::LoadFile(path));
}

std::string V4l2OptionsYaml(const V4l2DriverOptions& o) {
  const CaptureOptions& c = o.capture;
  std::ostringstream y;
  y.precision(10);
  auto quoted = [](const std::string& s) { return "\"" + s + "\""; };
  y << "device: " << quoted(c.device) << "\n";
  y << "formats: [";
  for (std::size_t i = 0; i < c.format.fourccs.size(); ++i) {
    y << (i ? ", " : "") << quoted(FourccName(c.format.fourccs[i]));
  }
  y << "]\n";
  y << "width: " << c.format.width << "\nheight: " << c.format.height << "\n";
  y << "fps: " << c.format.fps << "\n";
  y << "require_size: " << (c.format.require_size ? "true" : "false") << "\n";
  y << "require_fps: " << (c.format.require_fps ? "true" : "false") << "\n";
  y << "keep_16_bit: " << (c.keep_16_bit ? "true" : "false") << "\n";
  y << "buffers: " << c.buffers << "\n";
  y << "exposure: ";
  if (c.controls.exposure_us > 0.0) {
    y << c.controls.exposure_us << "\n";
  } else {
    y << "auto\n";
  }
  y << "gain: " << (c.controls.gain < 0 ? std::string("auto") : std::to_string(c.controls.gain))
    << "\n";
  y << "controls: {";
  bool first = true;
  for (const auto& kv : c.controls.controls) {
    y << (first ? "" : ", ") << kv.first << ": " << kv.second;
    first = false;
  }
  y << "}\n";
  y << "exposure_readback_s: " << c.exposure_readback_s << "\n";
  y << "timestamps:\n";
  y << "  mid_exposure: " << (c.timestamps.mid_exposure ? "true" : "false") << "\n";
  y << "  stamp_source: " << StampPointName(c.timestamps.stamp_source) << "\n";
  y << "  readout_us: " << c.timestamps.readout_us << "\n";
  y << "  offset_refresh_s: " << c.timestamps.offset_refresh_s << "\n";
  y << "  realtime_step_ms: " << c.timestamps.realtime_step_ms << "\n";
  y << "recovery:\n";
  y << "  reconnect_initial_s: " << c.reconnect_initial_s << "\n";
  y << "  reconnect_max_s: " << c.reconnect_max_s << "\n";
  y << "  frame_timeout_s: " << c.frame_timeout_s << "\n";
  y << "camera_id: " << o.camera_id << "\n";
  return y.str() + DriverLcmOptionsYaml(o);
}

std::string V4l2Usage() {
  return std::string(R"(Usage: vilma-v4l2 [--config FILE] [options]
       vilma-v4l2 --list [--fake]

Publishes a V4L2 camera (USB UVC, MIPI) on LCM: every frame as a vilma.image_t (GRAY8, or
GRAY16 with --keep-16-bit on a Y16 camera) on CAM0, stamped mid-exposure on the robot's clock
(CLOCK_REALTIME), with health (vilma.status_t) on VILMA_STATUS_CAM0 every second: frames
published, dropped (kernel sequence gaps), malformed, reconnects, rate, latency. Survives
the camera being unplugged and plugged in again. Details: docs/drivers.md.

Options (each overrides the same field of --config; defaults in brackets):
  --config FILE         YAML options (config/v4l2.yaml lists every field)
  --device PATH         /dev/videoN or /dev/v4l/by-id/... link [/dev/video0]
  --formats A,B,...     pixel formats in order of preference, of GREY, Y16, YUYV, MJPG
                        [GREY,Y16,YUYV,MJPG]
  --size WxH            frame size [the camera's current one]; the nearest the camera has
                        is taken and reported, unless --require-size
  --fps F               frame rate [Hz] [the camera's current one]; nearest, unless
                        --require-fps
  --require-size        another size than --size is an error
  --require-fps         a rate off by more than 1 % is an error
  --keep-16-bit         publish Y16 as GRAY16 (else GRAY8 from the high byte)
  --buffers N           mmap buffers in the ring, 2..32 [4]
  --exposure auto|US    auto exposure, or a fixed exposure time [us] (the camera's control
                        counts 100 us steps) [auto]
  --gain auto|N         auto gain, or a fixed gain in the camera's units [auto]
  --control NAME=VALUE  any other control by its v4l2-ctl name (repeatable), e.g.
                        --control power_line_frequency=1; unknown names are warnings
  --readout-us US       end of exposure to end of frame [us], for end-of-frame stamps [0]
  --stamp-source S      what buffer stamps mark: auto (the buffer's flags; uvcvideo without
                        hardware timestamps: end_of_exposure), start_of_exposure,
                        end_of_exposure, end_of_frame [auto]
  --buffer-stamps       publish the kernel's buffer stamp, not mid-exposure
)" + DriverLcmUsage(V4l2DriverOptions(), 24) + R"(  --camera-id N         image_t.camera_id, the camera's index in the rig [0]
  --fake                use the built-in fake camera (no hardware; for demos and tests)
  --fake-unplug-after N with --fake: unplug the camera after N frames for 0.5 s (recovery)
  --list                print the devices, their formats, sizes, rates and controls; exit
  --print-config        print the effective options as YAML and exit
  --help                this text

Exit status: 0 success (also after SIGINT/SIGTERM or --seconds), 1 a camera that cannot be
opened or cannot deliver what is asked (the message says what it offers) or LCM unusable;
--list: no capture device; 2 a bad command line or options file.
)");
}

V4l2DriverOptions ParseV4l2CommandLine(const std::vector<std::string>& args, bool* help) {
  *help = false;
  // --config first, so that every other flag overrides the file whatever the order.
  V4l2DriverOptions o;
  for (ArgCursor arg(args); arg.Next();) {
    if (arg.name() == "--help" || arg.name() == "-h") {
      *help = true;
      return o;
    }
    if (arg.name() == "--config") o = LoadV4l2Options(arg.Value());
  }
  auto number = [](ArgCursor& arg) {
    const std::string text = arg.Value();
    double value = 0.0;
    if (!ParseNumber(text, &value))
      throw UsageError(arg.name() + ": '" + text + "' is not a number");
    return value;
  };
  auto integer = [](ArgCursor& arg) {
    const std::string text = arg.Value();
    int64_t value = 0;
    if (!ParseInt(text, &value) || value < INT32_MIN || value > INT32_MAX) {
      throw UsageError(arg.name() + ": '" + text + "' is not an integer");
    }
    return static_cast<int>(value);
  };
  CaptureOptions& c = o.capture;
  for (ArgCursor arg(args); arg.Next();) {
    const std::string& name = arg.name();
    if (name == "--config") {
      arg.Value();  // read in the first pass
    } else if (name == "--device") {
      c.device = arg.Value();
    } else if (name == "--formats") {
      const std::string error = ParseFourccs(SplitComma(arg.Value()), &c.format.fourccs);
      if (!error.empty()) throw UsageError("--formats: " + error);
    } else if (name == "--size") {
      const std::string text = arg.Value();
      int w = 0, h = 0;
      char x = 0;
      std::istringstream in(text);
      if (!(in >> w >> x >> h) || x != 'x' || !in.eof() || w <= 0 || h <= 0) {
        throw UsageError("--size: '" + text + "' is not WIDTHxHEIGHT (e.g. 752x480)");
      }
      c.format.width = w;
      c.format.height = h;
    } else if (name == "--fps") {
      c.format.fps = number(arg);
    } else if (name == "--require-size") {
      c.format.require_size = arg.Flag();
    } else if (name == "--require-fps") {
      c.format.require_fps = arg.Flag();
    } else if (name == "--keep-16-bit") {
      c.keep_16_bit = arg.Flag();
    } else if (name == "--buffers") {
      c.buffers = integer(arg);
    } else if (name == "--exposure") {
      const std::string text = arg.Value();
      if (!ParseExposure(text, &c.controls.exposure_us)) {
        throw UsageError("--exposure: '" + text + "' is not auto or a positive time [us]");
      }
    } else if (name == "--gain") {
      const std::string text = arg.Value();
      if (!ParseGain(text, &c.controls.gain)) {
        throw UsageError("--gain: '" + text + "' is not auto or an integer >= 0");
      }
    } else if (name == "--control") {
      const std::string text = arg.Value();
      const std::size_t eq = text.find('=');
      int64_t value = 0;
      if (eq == std::string::npos || eq == 0 || !ParseInt(text.substr(eq + 1), &value)) {
        throw UsageError("--control: '" + text + "' is not NAME=INTEGER");
      }
      c.controls.controls[text.substr(0, eq)] = value;
    } else if (name == "--readout-us") {
      c.timestamps.readout_us = number(arg);
    } else if (name == "--stamp-source") {
      const std::string text = arg.Value();
      if (!ParseStampPoint(text, &c.timestamps.stamp_source)) {
        throw UsageError("--stamp-source: '" + text +
                         "' is not auto, start_of_exposure, end_of_exposure or end_of_frame");
      }
    } else if (name == "--buffer-stamps") {
      c.timestamps.mid_exposure = !arg.Flag();
    } else if (ParseDriverLcmFlag(arg, &o)) {
    } else if (name == "--camera-id") {
      o.camera_id = integer(arg);
    } else if (name == "--fake") {
      o.fake = arg.Flag();
    } else if (name == "--fake-unplug-after") {
      o.fake_unplug_after = integer(arg);
    } else if (name == "--list") {
      o.list = arg.Flag();
    } else if (name == "--print-config") {
      o.print_config = arg.Flag();
    } else if (arg.is_option()) {
      throw UsageError("unknown option " + arg.word());
    } else {
      throw UsageError("unexpected argument '" + arg.word() + "' (vilma-v4l2 takes options only)");
    }
  }
  if (o.fake_unplug_after < 0 || (o.fake_unplug_after > 0 && !o.fake)) {
    throw UsageError("--fake-unplug-after: expected N >= 1 together with --fake");
  }
  const std::string error = o.Validate();
  if (!error.empty()) throw UsageError(error);
  return o;
}

}  // namespace vilma::v4l2
