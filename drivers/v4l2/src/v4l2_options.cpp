#include "vilma/drivers/v4l2/v4l2_options.h"

#include <cmath>
#include <cstdlib>
#include <map>
#include <sstream>
#include <vector>

#include "vilma/core/arg_cursor.h"
#include "vilma/core/error.h"
#include "vilma/core/options_fields.h"
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

namespace {

// The field list (core/options_fields.h): reader and --print-config's writer. Fields with a
// form of their own: formats by fourcc name, exposure and gain "auto" or a number, controls a
// map of v4l2-ctl name to integer, the stamp source by name.
template <typename Options, typename Visitor>
void VisitV4l2Fields(Options& o, Visitor&& v) {
  auto& c = o.capture;
  v("", "device", c.device);
  v("", "formats",
    WithCodec(c.format.fourccs,
              [](const YamlNode& node, const char* key, std::vector<uint32_t>* fourccs) {
                const char* expected = "a list of fourccs, e.g. [GREY, YUYV, MJPG]";
                std::vector<std::string> names;
                for (const YAML::Node& item : SequenceOrFail(node, key, expected)) {
                  if (!item.IsScalar()) node.Fail(key, expected);
                  names.push_back(item.Scalar());
                }
                const std::string error = ParseFourccs(names, fourccs);
                if (!error.empty()) node.Fail(key, error);
              },
              [](const std::vector<uint32_t>& fourccs) {
                std::string text = "[";
                for (std::size_t i = 0; i < fourccs.size(); ++i) {
                  text += (i ? ", " : "") + FormatYamlScalar(FourccName(fourccs[i]));
                }
                return text + "]";
              }));
  v("", "width", c.format.width);
  v("", "height", c.format.height);
  v("", "fps", c.format.fps);
  v("", "require_size", c.format.require_size);
  v("", "require_fps", c.format.require_fps);
  v("", "keep_16_bit", c.keep_16_bit);
  v("", "buffers", c.buffers);
  v("", "exposure",
    WithCodec(c.controls.exposure_us,
              [](const YamlNode& node, const char* key, double* exposure_us) {
                if (!ParseExposure(node.Get<std::string>(key), exposure_us)) {
                  node.Fail(key, "auto or a positive exposure time [us]");
                }
              },
              [](double exposure_us) {
                return exposure_us > 0.0 ? FormatYamlScalar(exposure_us) : std::string("auto");
              }));
  v("", "gain",
    WithCodec(c.controls.gain,
              [](const YamlNode& node, const char* key, int* gain) {
                if (!ParseGain(node.Get<std::string>(key), gain)) {
                  node.Fail(key, "auto or an integer >= 0 (the camera's gain units)");
                }
              },
              [](int gain) { return gain < 0 ? std::string("auto") : std::to_string(gain); }));
  v("", "controls",
    WithCodec(c.controls.controls,
              [](const YamlNode& node, const char* key, std::map<std::string, int64_t>* controls) {
                const YamlNode map = node.Child(key);
                if (!map.IsMap()) node.Fail(key, "a map of control name: integer value");
                controls->clear();
                for (const auto& kv : map.raw()) {
                  const std::string name = kv.first.as<std::string>();
                  (*controls)[name] = map.Get<int64_t>(name);
                }
              },
              [](const std::map<std::string, int64_t>& controls) {
                std::string text = "{";
                for (const auto& [name, value] : controls) {
                  text += (text.size() > 1 ? ", " : "") + name + ": " + std::to_string(value);
                }
                return text + "}";
              }));
  v("", "exposure_readback_s", c.exposure_readback_s);
  v("timestamps", "mid_exposure", c.timestamps.mid_exposure);
  v("timestamps", "stamp_source",
    WithCodec(c.timestamps.stamp_source,
              [](const YamlNode& node, const char* key, StampPoint* point) {
                if (!ParseStampPoint(node.Get<std::string>(key), point)) {
                  node.Fail(key, "auto, start_of_exposure, end_of_exposure or end_of_frame");
                }
              },
              [](StampPoint point) { return StampPointName(point); }));
  v("timestamps", "readout_us", c.timestamps.readout_us);
  v("timestamps", "offset_refresh_s", c.timestamps.offset_refresh_s);
  v("timestamps", "realtime_step_ms", c.timestamps.realtime_step_ms);
  v("recovery", "reconnect_initial_s", c.reconnect_initial_s);
  v("recovery", "reconnect_max_s", c.reconnect_max_s);
  v("recovery", "frame_timeout_s", c.frame_timeout_s);
  v("", "camera_id", o.camera_id);
  VisitDriverLcmFields(o, v);
}

}  // namespace

V4l2DriverOptions ReadV4l2Options(const YamlNode& root, const V4l2DriverOptions& defaults) {
  if (!root.IsMap()) root.Fail("", "a map of vilma-v4l2 options");
  V4l2DriverOptions o = defaults;
  o.config_file = root.file();
  ReadOptionFields(root, MissingKey::kKeepDefault, &o,
                   [](auto& options, auto&& v) { VisitV4l2Fields(options, v); });
  root.CheckValid(o.Validate());
  return o;
}

V4l2DriverOptions LoadV4l2Options(const std::string& path) {
  return ReadV4l2Options(YamlNode::LoadFile(path));
}

std::string V4l2OptionsYaml(const V4l2DriverOptions& o) {
  return OptionFieldsToYaml(o, [](auto& options, auto&& v) { VisitV4l2Fields(options, v); });
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
