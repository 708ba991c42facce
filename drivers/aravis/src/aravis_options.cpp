#include "vilma/drivers/aravis/aravis_options.h"

#include <algorithm>
#include <cmath>
#include <sstream>
#include <type_traits>
#include <vector>

#include "vilma/core/arg_cursor.h"
#include "vilma/core/clock_sync_yaml.h"
#include "vilma/core/error.h"
#include "vilma/core/options_fields.h"
#include "vilma/core/validate.h"
#include "vilma/core/yaml_io.h"
#include "vilma/drivers/driver_status.h"
#include "vilma/drivers/lcm_url.h"

namespace vilma::aravis {
namespace {

bool OneOf(const std::string& value, std::initializer_list<const char*> choices) {
  return std::any_of(choices.begin(), choices.end(),
                     [&](const char* c) { return value == c; });
}

bool Finite(double v) { return std::isfinite(v); }

// The field list (core/options_fields.h): the file's keys, the reader, --print-config's
// writer, and the flags (every top-level key is also a flag --key-with-dashes; a bool is a
// flag without a value with a --no-... form).
template <typename Options, typename Visitor>
void VisitAravisFields(Options& o, Visitor&& v) {
  v("", "device", o.device);
  v("", "fake", o.fake);
  v("", "pixel_format", o.pixel_format);
  v("", "width", o.width);
  v("", "height", o.height);
  v("", "offset_x", o.offset_x);
  v("", "offset_y", o.offset_y);
  v("", "keep_16bit", o.keep_16bit);
  v("", "keep_bayer", o.keep_bayer);
  v("", "frame_rate_hz", o.frame_rate_hz);
  v("", "exposure_auto", o.exposure_auto);
  v("", "exposure_us", o.exposure_us);
  v("", "gain_auto", o.gain_auto);
  v("", "gain", o.gain);
  v("", "trigger", o.trigger);
  v("", "trigger_source", o.trigger_source);
  v("", "trigger_activation", o.trigger_activation);
  v("", "buffers", o.buffers);
  v("", "packet_resend", o.packet_resend);
  v("", "packet_size", o.packet_size);
  v("", "frame_timeout_s", o.frame_timeout_s);
  v("", "reconnect_interval_s", o.reconnect_interval_s);
  v("", "timestamp_source", o.timestamp_source);
  v("", "timestamp_event", o.timestamp_event);
  v("", "time_offset_us", o.time_offset_us);
  v("", "transport_latency_us", o.transport_latency_us);
  VisitClockSyncFields(o.clock_sync, InSection("clock_sync", v));
  v("", "camera_id", o.camera_id);
  v("", "frames", o.frames);
  v("", "fault_lose_camera_after", o.fault_lose_camera_after);
  VisitDriverLcmFields(o, v);
}

struct KeyInfo {
  std::string key;
  bool is_bool;
};

// The top-level keys of the field list (the ones that are flags).
std::vector<KeyInfo> TopLevelKeys() {
  std::vector<KeyInfo> keys;
  const AravisOptions defaults;
  VisitAravisFields(defaults, [&keys](const char* section, const char* key, const auto& field) {
    if (*section != '\0') return;
    keys.push_back({key, std::is_same_v<std::decay_t<decltype(field)>, bool>});
  });
  return keys;
}

std::string FlagOf(const std::string& key) {
  std::string flag = "--" + key;
  std::replace(flag.begin(), flag.end(), '_', '-');
  return flag;
}

AravisOptions ReadNode(const YamlNode& root, const AravisOptions& base) {
  AravisOptions o = base;
  ReadOptionFields(root, MissingKey::kKeepDefault, &o,
                   [](auto& options, auto&& v) { VisitAravisFields(options, v); });
  root.CheckValid(o.Validate());
  return o;
}

}  // namespace

std::string AravisOptions::Validate() const {
  if (fake && !device.empty() && device.rfind("Fake", 0) != 0) {
    return "device: expected empty or a Fake_N device with fake: true";
  }
  if (!OneOf(pixel_format, {"Mono8", "Mono10", "Mono12", "Mono16", "BayerRG8", "BayerGB8",
                            "BayerGR8", "BayerBG8", "RGB8"})) {
    return "pixel_format: expected Mono8, Mono10, Mono12, Mono16, BayerRG8, BayerGB8, BayerGR8, "
           "BayerBG8 or RGB8, got '" + pixel_format + "'";
  }
  if (width < 0) return "width: expected >= 0 (0 = the camera's)";
  if (height < 0) return "height: expected >= 0 (0 = the camera's)";
  if (offset_x < 0) return "offset_x: expected >= 0";
  if (offset_y < 0) return "offset_y: expected >= 0";
  VILMA_RETURN_IF_ERROR(ValidateNonNegative("frame_rate_hz", frame_rate_hz));
  if (!OneOf(exposure_auto, {"off", "once", "continuous"})) {
    return "exposure_auto: expected off, once or continuous, got '" + exposure_auto + "'";
  }
  VILMA_RETURN_IF_ERROR(ValidateNonNegative("exposure_us", exposure_us));
  if (!OneOf(gain_auto, {"off", "once", "continuous"})) {
    return "gain_auto: expected off, once or continuous, got '" + gain_auto + "'";
  }
  if (!Finite(gain)) return "gain: expected a number (< 0 = the camera's)";
  if (trigger && trigger_source.empty()) return "trigger_source: expected a line name";
  if (trigger && trigger_source == "Software" && !(frame_rate_hz > 0.0)) {
    return "frame_rate_hz: expected > 0 with trigger_source Software (the driver's trigger rate)";
  }
  if (trigger && trigger_activation.empty()) return "trigger_activation: expected a name";
  if (buffers < 2 || buffers > 1024) return "buffers: expected 2 .. 1024";
  if (packet_size != 0 && (packet_size < 576 || packet_size > 16384)) {
    return "packet_size: expected 0 (auto) or 576 .. 16384 bytes";
  }
  VILMA_RETURN_IF_ERROR(ValidatePositive("frame_timeout_s", frame_timeout_s));
  VILMA_RETURN_IF_ERROR(ValidatePositive("reconnect_interval_s", reconnect_interval_s));
  if (!OneOf(timestamp_source, {"device", "host"})) {
    return "timestamp_source: expected device or host, got '" + timestamp_source + "'";
  }
  if (!OneOf(timestamp_event, {"exposure_start", "exposure_end"})) {
    return "timestamp_event: expected exposure_start or exposure_end, got '" + timestamp_event + "'";
  }
  if (!Finite(time_offset_us)) return "time_offset_us: expected a number";
  VILMA_RETURN_IF_ERROR(ValidateNonNegative("transport_latency_us", transport_latency_us));
  {
    const std::string e = clock_sync.Validate();
    if (!e.empty()) return "clock_sync." + e;
  }
  VILMA_RETURN_IF_ERROR(ValidateLcm());
  if (camera_id < 0) return "camera_id: expected >= 0";
  if (frames < 0) return "frames: expected >= 0";
  if (fault_lose_camera_after < 0) return "fault_lose_camera_after: expected >= 0";
  return "";
}

AravisOptions ReadAravisOptions(const std::string& yaml_text, const std::string& source,
                                const AravisOptions& base) {
  return ReadNode(YamlNode::LoadString(yaml_text, source), base);
}

AravisOptions LoadAravisOptionsFile(const std::string& path, const AravisOptions& base) {
  return ReadNode(YamlNode::LoadFile(path), base);
}

std::string AravisOptionsToYaml(const AravisOptions& o) {
  return OptionFieldsToYaml(o, [](auto& options, auto&& v) { VisitAravisFields(options, v); });
}

AravisCommandLine ParseAravisCommandLine(const std::vector<std::string>& args) {
  AravisCommandLine cl;
  std::string config_path;
  // Flags become a YAML map read by the same reader as the file, over the file's values: one
  // set of types, defaults and checks for both.
  YAML::Node overrides(YAML::NodeType::Map);
  const std::vector<KeyInfo> keys = TopLevelKeys();
  for (ArgCursor arg(args); arg.Next();) {
    const std::string& name = arg.name();
    if (name == "--help" || name == "-h") {
      cl.help = arg.Flag();
      return cl;
    } else if (name == "--list") {
      cl.list = arg.Flag();
    } else if (name == "--print-config") {
      cl.print_config = arg.Flag();
    } else if (name == "--config") {
      config_path = arg.Value();
      if (config_path.empty()) throw UsageError("--config: expected a file");
    } else {
      bool known = false;
      for (const KeyInfo& info : keys) {
        const std::string flag = FlagOf(info.key);
        if (name == flag) {
          overrides[info.key] = info.is_bool ? (arg.Flag() ? "true" : "false") : arg.Value();
          known = true;
        } else if (info.is_bool && name == "--no-" + flag.substr(2)) {
          arg.Flag();
          overrides[info.key] = "false";
          known = true;
        }
        if (known) break;
      }
      if (!known) throw UsageError("unknown argument '" + arg.word() + "'");
    }
  }
  AravisOptions base;
  if (!config_path.empty()) base = LoadAravisOptionsFile(config_path);
  // Errors name the flag's key on the "command line" (e.g. "command line: frame_rate_hz: ...").
  try {
    cl.options = ReadNode(YamlNode(overrides, "command line", ""), base);
  } catch (const InputError& e) {
    // "command line: frame_rate_hz: ..." -> "command line: --frame-rate-hz: ..."
    std::string message = e.what();
    const std::string prefix = "command line: ";
    if (message.rfind(prefix, 0) == 0) {
      const std::size_t end = message.find(':', prefix.size());
      const std::string key = message.substr(prefix.size(), end - prefix.size());
      if (end != std::string::npos && key.find(' ') == std::string::npos) {
        message = prefix + FlagOf(key) + message.substr(end);
      }
    }
    throw InputError(message);
  }
  return cl;
}

std::string AravisUsage() {
  return std::string(R"(Usage: vilma-aravis [--config FILE] [options]
       vilma-aravis --list [--fake] [--device ID]

Publishes a GenICam camera (GigE Vision / USB3 Vision, through Aravis 0.8) on LCM: images as
vilma.image_t on CAM0 (GRAY8; GRAY16 or BAYER_* if asked), its health as vilma.status_t on
VILMA_STATUS_CAM0 every second. utime is mid-exposure on the robot clock (CLOCK_REALTIME):
the camera's timestamps mapped through a minimum-delay clock filter (docs/drivers.md).

Modes:
  --list                  print the cameras found (id, vendor, model, serial, protocol) and
                          the chosen camera's pixel formats and features, then exit (1 if
                          no camera matches)
  --print-config          print the effective options as YAML and exit
  --help                  this text

Options (each is also a key of the YAML file given with --config, '-' written '_'; flags
override the file; booleans take no value and have a --no-... form):
  --config FILE           options file (config/aravis.yaml is the documented example)
  --device ID             device id, serial number, physical id (MAC) or IP address
                          (default: the first camera)
  --fake                  Aravis's in-process fake camera (Fake_1): no hardware needed
  --pixel-format F        Mono8 (default), Mono10, Mono12, Mono16, BayerRG8, BayerGB8,
                          BayerGR8, BayerBG8, RGB8
  --width W --height H    region of interest [px] (0 = the camera's current size)
  --offset-x X --offset-y Y   region offset [px] (default 0)
  --keep-16bit            Mono10/12/16 as GRAY16 (default: the top 8 bits as GRAY8)
  --keep-bayer            Bayer as the raw BAYER_* mosaic (default: demosaiced to GRAY8)
  --frame-rate-hz R       frame rate (default 20; 0 = the camera's setting)
  --exposure-auto M       off (default), once, continuous
  --exposure-us T         fixed exposure [us] (default 0 = the camera's setting)
  --gain-auto M           off (default), once, continuous
  --gain G                fixed gain, camera units (dB on most) (default -1 = the camera's)
  --trigger               hardware trigger: FrameStart on --trigger-source (default Line0)
                          with --trigger-activation (default RisingEdge); source Software
                          makes the driver trigger at --frame-rate-hz
  --trigger-source S --trigger-activation A
  --buffers N             stream buffers (default 8)
  --packet-resend / --no-packet-resend   GigE Vision packet resend (default on)
  --packet-size B         GigE Vision packet size [bytes] (default 0 = auto-negotiate)
  --frame-timeout-s T     no frame for T s = camera lost, reconnect (default 2; not while
                          waiting for hardware triggers)
  --reconnect-interval-s T   pause between reconnect attempts (default 1)
  --timestamp-source S    device (default: camera clock through the clock filter) or host
                          (buffer arrival time only)
  --timestamp-event E     exposure_start (default) or exposure_end: what the camera's stamp
                          marks; utime = mid-exposure
  --time-offset-us T      constant added to utime [us] (default 0)
  --transport-latency-us T   least time from the end of exposure to the buffer's arrival
                          stamp (readout, first packet) [us] (default 0)
)" + DriverLcmUsage(AravisOptions(), 26) + R"(  --camera-id N           image_t.camera_id (default 0)
  --frames N              stop after N published frames (default 0 = no limit)
  --fault-lose-camera-after N   test: treat the camera as lost after N frames (reconnects)
  (clock_sync.* filter options: YAML only, see config/aravis.yaml)

Exit status: 0 on a clean stop (SIGINT, SIGTERM, --seconds, --frames), 1 on a runtime failure
(no camera, camera refuses a setting, LCM unusable), 2 on a bad command line or options file.
)");
}

}  // namespace vilma::aravis
