// vilma-v4l2's options: strict YAML, command-line flags over it, validation
// (drivers/v4l2/src/v4l2_options.cpp), and the shipped config/v4l2.yaml.
#include <catch2/catch.hpp>

#include "test_skip.h"

#ifdef VILMA_HAVE_DRIVER_V4L2
#include <linux/videodev2.h>

#include <fstream>
#include <sstream>

#include "vilma/core/arg_cursor.h"
#include "vilma/core/error.h"
#include "vilma/drivers/v4l2/v4l2_options.h"

namespace vilma::v4l2 {
namespace {

V4l2DriverOptions FromYaml(const std::string& text) {
  return ReadV4l2Options(YamlNode::LoadString(text, "v4l2.yaml"));
}

std::string YamlError(const std::string& text) {
  try {
    FromYaml(text);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

V4l2DriverOptions FromArgs(const std::vector<std::string>& args) {
  bool help = false;
  return ParseV4l2CommandLine(args, &help);
}

std::string UsageErrorOf(const std::vector<std::string>& args) {
  try {
    FromArgs(args);
  } catch (const UsageError& e) {
    return e.what();
  }
  return "";
}

TEST_CASE("v4l2 the shipped config/v4l2.yaml is valid and lists every option", "[v4l2]") {
  const std::string path = std::string(VILMA_SOURCE_DIR) + "/config/v4l2.yaml";
  const V4l2DriverOptions o = LoadV4l2Options(path);
  CHECK(o.capture.device == "/dev/video0");
  CHECK(o.channel == "CAM0");
  // Every key that --print-config writes is in the shipped file (and nothing else is).
  const YAML::Node shipped = YAML::LoadFile(path);
  const YAML::Node printed = YAML::Load(V4l2OptionsYaml(o));
  for (const auto& kv : printed) CHECK(shipped[kv.first.as<std::string>()].IsDefined());
  CHECK(shipped.size() == printed.size());
}

TEST_CASE("v4l2 YAML options are read, absent keys keep defaults", "[v4l2]") {
  const V4l2DriverOptions o = FromYaml(
      "device: /dev/v4l/by-id/usb-cam\nformats: [YUYV, MJPG]\nwidth: 752\nheight: 480\n"
      "fps: 20\nexposure: 5000\ngain: 12\ncontrols: {power_line_frequency: 1}\n"
      "timestamps: {readout_us: 8000}\nrecovery: {reconnect_max_s: 5}\nchannel: CAM1\n"
      "camera_id: 1\n");
  CHECK(o.capture.device == "/dev/v4l/by-id/usb-cam");
  CHECK(o.capture.format.fourccs == std::vector<uint32_t>{V4L2_PIX_FMT_YUYV, V4L2_PIX_FMT_MJPEG});
  CHECK(o.capture.format.width == 752);
  CHECK(o.capture.format.fps == 20.0);
  CHECK(o.capture.controls.exposure_us == 5000.0);
  CHECK(o.capture.controls.gain == 12);
  CHECK(o.capture.controls.controls.at("power_line_frequency") == 1);
  CHECK(o.capture.timestamps.readout_us == 8000.0);
  CHECK(o.capture.timestamps.offset_refresh_s == 0.1);  // default
  CHECK(o.capture.reconnect_max_s == 5.0);
  CHECK(o.DataChannel() == "CAM1");
  CHECK(o.StatusChannel() == "VILMA_STATUS_CAM1");
  CHECK(o.camera_id == 1);
  const V4l2DriverOptions automatic = FromYaml("exposure: auto\ngain: auto\n");
  CHECK(automatic.capture.controls.exposure_us == 0.0);
  CHECK(automatic.capture.controls.gain == -1);
}

TEST_CASE("v4l2 bad YAML options name the file, the key and the expectation", "[v4l2]") {
  CHECK_THAT(YamlError("devise: /dev/video0\n"),
             Catch::StartsWith("v4l2.yaml: devise: no such key here (unknown key; check spelling; known keys here: ") &&
                 Catch::Contains("device") && Catch::EndsWith(")"));
  CHECK(YamlError("timestamps: {readout: 1}\n").find("timestamps.readout: no such key") !=
        std::string::npos);
  CHECK(YamlError("width: wide\n").find("v4l2.yaml: width: an integer") != std::string::npos);
  CHECK(YamlError("formats: [GREY, RGB3]\n").find("formats: 'RGB3' is not one of GREY, Y16") !=
        std::string::npos);
  CHECK(YamlError("formats: [grey]\n").find("'grey' is not a fourcc") != std::string::npos);
  CHECK(YamlError("exposure: -5\n").find("exposure: auto or a positive exposure time [us]") !=
        std::string::npos);
  CHECK(YamlError("buffers: 64\n") == "v4l2.yaml: buffers: expected 2 .. 32");
  CHECK(YamlError("timestamps: {stamp_source: soe}\n").find("timestamps.stamp_source: auto,") !=
        std::string::npos);
  CHECK(YamlError("width: 640\n").find("width: expected width and height both") !=
        std::string::npos);
  CHECK(YamlError("channel: cam0\n").find("channel: channel name 'cam0'") != std::string::npos);
  CHECK(YamlError("require_fps: true\n").find("require_fps: expected fps > 0") !=
        std::string::npos);
  CHECK(YamlError("controls: {Brightness: 3}\n").find("controls.Brightness") != std::string::npos);
}

TEST_CASE("v4l2 command-line flags override the config file in any order", "[v4l2]") {
  const std::string path = std::string(VILMA_SOURCE_DIR) + "/config/v4l2.yaml";
  const V4l2DriverOptions o = FromArgs({"--device",
                                        "/dev/video3",
                                        "--config",
                                        path,
                                        "--size=320x240",
                                        "--fps",
                                        "15",
                                        "--formats",
                                        "MJPG,GREY",
                                        "--exposure",
                                        "2500",
                                        "--gain",
                                        "auto",
                                        "--control",
                                        "brightness=-4",
                                        "--control",
                                        "sharpness=2",
                                        "--channel",
                                        "CAM1",
                                        "--channel-suffix",
                                        "_R2",
                                        "--camera-id",
                                        "1",
                                        "--seconds",
                                        "3",
                                        "--fake",
                                        "--buffers",
                                        "6",
                                        "--keep-16-bit",
                                        "--buffer-stamps",
                                        "--readout-us",
                                        "100",
                                        "--require-size",
                                        "--status-period-s",
                                        "0.5",
                                        "--stamp-source",
                                        "end_of_frame"});
  CHECK(o.capture.device == "/dev/video3");
  CHECK(o.capture.format.width == 320);
  CHECK(o.capture.format.height == 240);
  CHECK(o.capture.format.fps == 15.0);
  CHECK(o.capture.format.fourccs == std::vector<uint32_t>{V4L2_PIX_FMT_MJPEG, V4L2_PIX_FMT_GREY});
  CHECK(o.capture.controls.exposure_us == 2500.0);
  CHECK(o.capture.controls.gain == -1);
  CHECK(o.capture.controls.controls.at("brightness") == -4);
  CHECK(o.capture.controls.controls.at("sharpness") == 2);
  CHECK(o.DataChannel() == "CAM1_R2");
  CHECK(o.StatusChannel() == "VILMA_STATUS_CAM1_R2");
  CHECK(o.camera_id == 1);
  CHECK(o.seconds == 3.0);
  CHECK(o.fake);
  CHECK(o.capture.buffers == 6);
  CHECK(o.capture.keep_16_bit);
  CHECK_FALSE(o.capture.timestamps.mid_exposure);
  CHECK(o.capture.timestamps.readout_us == 100.0);
  CHECK(o.capture.format.require_size);
  CHECK(o.status_period_s == 0.5);
  CHECK(o.capture.timestamps.stamp_source == StampPoint::kEndOfFrame);
  CHECK(o.config_file == path);
}

TEST_CASE("v4l2 bad command lines are usage errors that say what is wrong", "[v4l2]") {
  CHECK(UsageErrorOf({"--frobnicate"}) == "unknown option --frobnicate");
  CHECK(UsageErrorOf({"/dev/video0"}).find("unexpected argument") != std::string::npos);
  CHECK(UsageErrorOf({"--size", "640"}).find("not WIDTHxHEIGHT") != std::string::npos);
  CHECK(UsageErrorOf({"--size", "640x480x3"}).find("not WIDTHxHEIGHT") != std::string::npos);
  CHECK(UsageErrorOf({"--fps", "fast"}).find("--fps: 'fast' is not a number") != std::string::npos);
  CHECK(UsageErrorOf({"--exposure", "0"}).find("--exposure") != std::string::npos);
  CHECK(UsageErrorOf({"--gain", "-2"}).find("--gain") != std::string::npos);
  CHECK(UsageErrorOf({"--control", "brightness"}).find("NAME=INTEGER") != std::string::npos);
  CHECK(UsageErrorOf({"--stamp-source", "middle"}).find("--stamp-source: 'middle'") !=
        std::string::npos);
  CHECK(UsageErrorOf({"--fake=yes"}).find("takes no value") != std::string::npos);
  CHECK(UsageErrorOf({"--buffers", "1"}).find("buffers: expected 2 .. 32") != std::string::npos);
  CHECK(UsageErrorOf({"--channel"}).find("expected a value") != std::string::npos);
  CHECK(UsageErrorOf({"--status-channel", "CAM0"}).find("another channel") != std::string::npos);
  CHECK(UsageErrorOf({"--fake-unplug-after", "5"}).find("together with --fake") !=
        std::string::npos);
  CHECK_THROWS_AS(FromArgs({"--config", "/nonexistent/v4l2.yaml"}), InputError);
}

TEST_CASE("v4l2 the effective options (--print-config) read back as the same options", "[v4l2]") {
  const V4l2DriverOptions o =
      FromArgs({"--size", "752x480", "--fps", "20", "--exposure", "3000", "--control",
                "brightness=7", "--channel-suffix", "_X", "--formats", "Y16,YUYV"});
  const std::string yaml = V4l2OptionsYaml(o);
  const V4l2DriverOptions back = FromYaml(yaml);
  CHECK(V4l2OptionsYaml(back) == yaml);
  CHECK(back.capture.format.fourccs == o.capture.format.fourccs);
  CHECK(back.capture.controls.controls == o.capture.controls.controls);
  CHECK(back.DataChannel() == "CAM0_X");
}

TEST_CASE("v4l2 the systemd unit's command line is one vilma-v4l2 accepts", "[v4l2]") {
  const std::string unit_path =
      std::string(VILMA_SOURCE_DIR) + "/config/systemd/vilma-v4l2@.service";
  std::ifstream unit(unit_path);
  REQUIRE(unit);
  std::string line, exec;
  while (std::getline(unit, line)) {
    if (line.rfind("ExecStart=", 0) == 0) exec = line.substr(10);
  }
  REQUIRE(!exec.empty());
  // The installed paths replaced by the repository's, %f by a by-id link.
  std::istringstream words(exec);
  std::vector<std::string> args;
  std::string word;
  words >> word;  // the program
  CHECK(word == "/usr/local/bin/vilma-v4l2");
  while (words >> word) {
    if (word == "/etc/vilma/v4l2.yaml") word = std::string(VILMA_SOURCE_DIR) + "/config/v4l2.yaml";
    if (word == "%f") word = "/dev/v4l/by-id/usb-cam-video-index0";
    args.push_back(word);
  }
  const V4l2DriverOptions o = FromArgs(args);
  CHECK(o.capture.device == "/dev/v4l/by-id/usb-cam-video-index0");
}

TEST_CASE("v4l2 the usage text (--help) names every flag the parser knows", "[v4l2]") {
  const std::string usage = V4l2Usage();
  for (const char* flag : {"--config",
                           "--device",
                           "--formats",
                           "--size",
                           "--fps",
                           "--require-size",
                           "--require-fps",
                           "--keep-16-bit",
                           "--buffers",
                           "--exposure",
                           "--gain",
                           "--control",
                           "--readout-us",
                           "--stamp-source",
                           "--buffer-stamps",
                           "--lcm-url",
                           "--channel",
                           "--camera-id",
                           "--channel-suffix",
                           "--status-channel",
                           "--seconds",
                           "--status-period-s",
                           "--fake",
                           "--fake-unplug-after",
                           "--list",
                           "--print-config",
                           "--help"}) {
    CAPTURE(flag);
    CHECK(usage.find(std::string(flag) + " ") != std::string::npos);
  }
}

}  // namespace
}  // namespace vilma::v4l2

#else
TEST_CASE("vilma-v4l2 options", "[v4l2]") {
  VILMA_SKIP("vilma-v4l2 is not built here (<linux/videodev2.h> missing)");
}
#endif
