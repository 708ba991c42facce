// vilma-aravis options: strict YAML, command-line flags, validation (aravis_options.cpp).
#include <catch2/catch.hpp>

#include "test_skip.h"

#ifdef VILMA_HAVE_DRIVER_ARAVIS

#include <string>
#include <vector>

#include "vilma/core/arg_cursor.h"
#include "vilma/core/error.h"
#include "vilma/drivers/aravis/aravis_options.h"

namespace vilma::aravis {
namespace {

std::string ErrorOf(const std::string& yaml) {
  try {
    ReadAravisOptions(yaml, "test.yaml");
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

std::string CommandLineError(const std::vector<std::string>& args) {
  try {
    ParseAravisCommandLine(args);
  } catch (const std::exception& e) {
    return e.what();
  }
  return "";
}

TEST_CASE("Aravis options: defaults are valid, channels", "[aravis]") {
  AravisOptions o;
  CHECK(o.Validate().empty());
  CHECK(o.DataChannel() == "CAM0");
  CHECK(o.StatusChannel() == "VILMA_STATUS_CAM0");
  o.channel = "CAM1";
  o.channel_suffix = "_R2";
  CHECK(o.DataChannel() == "CAM1_R2");
  CHECK(o.StatusChannel() == "VILMA_STATUS_CAM1_R2");
  o.status_channel = "HEALTH";
  CHECK(o.StatusChannel() == "HEALTH_R2");
  o.status_channel = "CAM1";
  CHECK(o.Validate() == "status_channel: expected another channel than channel");
}

TEST_CASE("Aravis options from YAML: absent keys keep defaults, errors name the key",
          "[aravis]") {
  const AravisOptions o = ReadAravisOptions(
      "fake: true\npixel_format: BayerRG8\nframe_rate_hz: 30\nclock_sync:\n  window_s: 5\n",
      "test.yaml");
  CHECK(o.fake);
  CHECK(o.pixel_format == "BayerRG8");
  CHECK(o.frame_rate_hz == 30.0);
  CHECK(o.clock_sync.window_s == 5.0);
  CHECK(o.buffers == 8);
  CHECK(ReadAravisOptions("", "empty.yaml").buffers == 8);

  CHECK_THAT(ErrorOf("framerate: 20\n"),
             Catch::StartsWith("test.yaml: framerate: no such key here (unknown key; check spelling; known keys here: ") &&
                 Catch::Contains("frame_rate_hz") && Catch::EndsWith(")"));
  CHECK(ErrorOf("buffers: 1\n") == "test.yaml: buffers: expected 2 .. 1024");
  CHECK(ErrorOf("frame_rate_hz: fast\n").find("test.yaml: frame_rate_hz") == 0);
  CHECK(ErrorOf("pixel_format: YUV422\n").find("test.yaml: pixel_format: expected Mono8") == 0);
  CHECK(ErrorOf("exposure_auto: sometimes\n").find("exposure_auto") != std::string::npos);
  CHECK(ErrorOf("timestamp_event: readout\n").find("timestamp_event") != std::string::npos);
  CHECK(ErrorOf("channel: cam0\n").find("test.yaml: channel: channel name 'cam0'") == 0);
  CHECK(ErrorOf("clock_sync:\n  window_s: -1\n").find("test.yaml: clock_sync.window_s") == 0);
  CHECK(ErrorOf("clock_sync:\n  windows: 1\n").find("clock_sync.windows") != std::string::npos);
  CHECK(ErrorOf("packet_size: 100\n").find("packet_size") != std::string::npos);
  CHECK(ErrorOf("trigger: true\ntrigger_source: Software\nframe_rate_hz: 0\n")
            .find("frame_rate_hz: expected > 0 with trigger_source Software") !=
        std::string::npos);
  CHECK(ErrorOf("- a\n- b\n").find("test.yaml") == 0);
}

TEST_CASE("Aravis options: the printed configuration reads back the same", "[aravis]") {
  AravisOptions o;
  o.device = "Basler-123";
  o.exposure_auto = "continuous";
  o.gain = 3.5;
  o.channel_suffix = "_X";
  o.clock_sync.outlier_threshold_ms = 4.0;
  const std::string yaml = AravisOptionsToYaml(o);
  const AravisOptions back = ReadAravisOptions(yaml, "printed");
  CHECK(AravisOptionsToYaml(back) == yaml);
  CHECK(back.exposure_auto == "continuous");
  CHECK(back.gain_auto == "off");
  CHECK(back.clock_sync.outlier_threshold_ms == 4.0);
}

TEST_CASE("Aravis command line: flags mirror the keys and override --config", "[aravis]") {
  const std::string config = std::string(VILMA_SOURCE_DIR) + "/config/aravis.yaml";
  AravisCommandLine cl = ParseAravisCommandLine(
      {"--frame-rate-hz", "30", "--config", config, "--fake", "--no-packet-resend",
       "--channel=CAM1", "--seconds", "2.5", "--keep-16bit", "--exposure-us", "5000"});
  CHECK(cl.options.frame_rate_hz == 30.0);  // the flag wins over the file, wherever it stands
  CHECK(cl.options.fake);
  CHECK_FALSE(cl.options.packet_resend);
  CHECK(cl.options.channel == "CAM1");
  CHECK(cl.options.seconds == 2.5);
  CHECK(cl.options.keep_16bit);
  CHECK(cl.options.exposure_us == 5000.0);
  CHECK(cl.options.width == 752);  // from the file
  CHECK_FALSE(cl.help);
  CHECK(ParseAravisCommandLine({"--list", "--fake"}).list);
  CHECK(ParseAravisCommandLine({"--print-config"}).print_config);
  CHECK(ParseAravisCommandLine({"--help", "--bogus"}).help);

  CHECK_THROWS_AS(ParseAravisCommandLine({"--bogus"}), UsageError);
  CHECK_THROWS_AS(ParseAravisCommandLine({"--fake=yes"}), UsageError);
  CHECK_THROWS_AS(ParseAravisCommandLine({"--channel"}), UsageError);
  CHECK(CommandLineError({"--frame-rate-hz", "abc"}).find("command line: --frame-rate-hz") == 0);
  CHECK(CommandLineError({"--buffers", "0"}) == "command line: --buffers: expected 2 .. 1024");
  CHECK(CommandLineError({"--config", "/nonexistent/aravis.yaml"})
            .find("/nonexistent/aravis.yaml: cannot open") == 0);
}

TEST_CASE("The documented example config/aravis.yaml is valid", "[aravis]") {
  const AravisOptions o =
      LoadAravisOptionsFile(std::string(VILMA_SOURCE_DIR) + "/config/aravis.yaml");
  CHECK(o.width == 752);
  CHECK(o.height == 480);
  CHECK(o.frame_rate_hz == 20.0);
  CHECK(o.exposure_auto == "off");
  CHECK(o.Validate().empty());
}

TEST_CASE("vilma-aravis --help names every flag", "[aravis]") {
  const std::string usage = AravisUsage();
  for (const char* flag :
       {"--device", "--fake", "--pixel-format", "--width", "--height", "--offset-x",
        "--offset-y", "--keep-16bit", "--keep-bayer", "--frame-rate-hz", "--exposure-auto",
        "--exposure-us", "--gain-auto", "--gain", "--trigger", "--trigger-source",
        "--trigger-activation", "--buffers", "--packet-resend", "--packet-size",
        "--frame-timeout-s", "--reconnect-interval-s", "--timestamp-source",
        "--timestamp-event", "--time-offset-us", "--transport-latency-us", "--lcm-url",
        "--channel", "--channel-suffix", "--status-channel", "--camera-id",
        "--status-period-s", "--seconds", "--frames", "--fault-lose-camera-after", "--list",
        "--print-config", "--config", "--help"}) {
    INFO(flag);
    CHECK(usage.find(flag) != std::string::npos);
  }
}

}  // namespace
}  // namespace vilma::aravis

#else

TEST_CASE("Aravis options", "[aravis]") {
  VILMA_SKIP("vilma-aravis is not built here (pkg-config finds no aravis-0.8: libaravis-dev)");
}

#endif
