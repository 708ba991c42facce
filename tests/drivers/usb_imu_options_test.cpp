// vilma-usb-imu options: strict YAML (unknown keys, bad values named with file and key), the
// --print-config round trip, command-line flags over the config file, config/usb_imu.yaml.
#include <catch2/catch.hpp>

#include "test_skip.h"

#ifdef VILMA_HAVE_DRIVER_USB_IMU

#include <cstdio>
#include <fstream>
#include <regex>
#include <sstream>

#include "integration/process_util.h"
#include "vilma/core/arg_cursor.h"
#include "vilma/core/error.h"
#include "vilma/drivers/usb_imu/usb_imu_options.h"

namespace vilma::usb_imu {
namespace {

UsbImuOptions FromYaml(const std::string& text) {
  return ReadUsbImuOptions(YamlNode::LoadString(text, "imu.yaml"));
}

UsbImuCommandLine Parse(std::vector<std::string> args) {
  args.insert(args.begin(), "vilma-usb-imu");
  std::vector<const char*> argv;
  for (const std::string& a : args) argv.push_back(a.c_str());
  return ParseUsbImuCommandLine(static_cast<int>(argv.size()), argv.data());
}

std::string WriteFile(const std::string& name, const std::string& text) {
  const std::string path = vilma::test::ScratchDir() + "/" + name;
  std::ofstream(path) << text;
  return path;
}

std::string ErrorOf(const std::string& yaml) {
  try {
    FromYaml(yaml);
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST_CASE("usb_imu options: defaults are valid and --print-config reads back", "[usb_imu]") {
  UsbImuOptions o;
  CHECK(o.Validate().empty());
  CHECK(o.DataChannel() == "IMU");
  CHECK(o.StatusChannel() == "VILMA_STATUS_IMU");
  o.transport = "usb";
  o.usb_product_ids = {0x3065, 0x1234};
  o.family = "cv7";
  o.rate_hz = 500;
  o.channel_suffix = "_R2";
  o.clock_sync.window_s = 20.0;
  const std::string yaml = UsbImuOptionsToYaml(o);
  CHECK(yaml.find("usb_vendor_id: 0x199b") != std::string::npos);
  const UsbImuOptions back = FromYaml(yaml);
  CHECK(back.transport == "usb");
  CHECK(back.usb_vendor_id == 0x199b);
  CHECK(back.usb_product_ids == std::vector<int>{0x3065, 0x1234});
  CHECK(back.family == "cv7");
  CHECK(back.rate_hz == 500);
  CHECK(back.clock_sync.window_s == 20.0);
  CHECK(back.DataChannel() == "IMU_R2");
  CHECK(back.StatusChannel() == "VILMA_STATUS_IMU_R2");
  CHECK(UsbImuOptionsToYaml(back) == yaml);
}

TEST_CASE("usb_imu options: bad YAML names file, key and expectation", "[usb_imu]") {
  // Unknown keys: the message lists the keys the reader knows (core/yaml_io.h).
  CHECK_THAT(ErrorOf("transport: serial\nbaud_rate: 9600\n"),
             Catch::StartsWith("imu.yaml: baud_rate: no such key here (unknown key; check spelling; known keys here: ") &&
                 Catch::Contains(" baud,") && Catch::EndsWith(")"));
  CHECK(ErrorOf("baud: 12345\n") ==
        "imu.yaml: baud: expected one of 9600 19200 38400 57600 115200 230400 460800 921600");
  CHECK(ErrorOf("family: gx4\n") == "imu.yaml: family: expected gx5 or cv7");
  CHECK(ErrorOf("rate_hz: 0\n") == "imu.yaml: rate_hz: expected 0 < rate <= 10000 [Hz]");
  CHECK(ErrorOf("lowpass: manual\n").find("lowpass_cutoff_hz: expected") != std::string::npos);
  CHECK(ErrorOf("clock_sync:\n  window_s: -1\n") == "imu.yaml: clock_sync.window_s: expected > 0");
  CHECK_THAT(ErrorOf("clock_sync:\n  windows: 3\n"),
             Catch::StartsWith("imu.yaml: clock_sync.windows: no such key here (unknown key; check spelling; known keys here: ") &&
                 Catch::Contains("window_s") && Catch::EndsWith(")"));
  CHECK(ErrorOf("usb_product_ids: [0x3065, zz]\n") ==
        "imu.yaml: usb_product_ids: expected a list of 16-bit ids like [0x3065, 0x3d65]");
  CHECK(ErrorOf("usb_product_ids: 5\n") ==
        "imu.yaml: usb_product_ids: expected a list of 16-bit ids like [0x3065, 0x3d65]");
  CHECK(ErrorOf("usb_product_ids: [0x13065]\n") ==
        "imu.yaml: usb_product_ids: expected a 16-bit id (0 .. 0xffff)");
  CHECK(ErrorOf("channel: imu\n").find("channel: channel name 'imu'") != std::string::npos);
  CHECK(ErrorOf("transport: replay\nreplay_file: x.bin\n") ==
        "imu.yaml: configure: expected false with transport replay (a recording cannot answer "
        "commands)");
  CHECK(ErrorOf("transport: replay\nreplay_file: x.bin\nconfigure: false\nreplay_rate: 0\n")
            .find("time_source: expected device") != std::string::npos);
  CHECK(ErrorOf("- 1\n- 2\n") == "imu.yaml: (top level): expected a map of vilma-usb-imu options");
  CHECK(FromYaml("").transport == "serial");  // an empty file: all defaults
}

TEST_CASE("usb_imu command line: flags override the config file wherever it stands",
          "[usb_imu]") {
  const std::string config =
      WriteFile("usb_imu_cl.yaml", "serial_device: /dev/ttyACM3\nrate_hz: 100\nfamily: cv7\n");
  UsbImuCommandLine cl = Parse({"--rate-hz", "250", "--config", config, "--channel", "IMU1"});
  CHECK(cl.options.serial_device == "/dev/ttyACM3");
  CHECK(cl.options.family == "cv7");
  CHECK(cl.options.rate_hz == 250);
  CHECK(cl.options.channel == "IMU1");
  CHECK(cl.options.StatusChannel() == "VILMA_STATUS_IMU1");

  cl = Parse({"--usb", "--vendor-id", "0x1234", "--product-id", "0x3065,26000", "--usb-serial",
              "6251.1234"});
  CHECK(cl.options.transport == "usb");
  CHECK(cl.options.usb_vendor_id == 0x1234);
  CHECK(cl.options.usb_product_ids == std::vector<int>{0x3065, 26000});
  CHECK(cl.options.usb_serial == "6251.1234");

  cl = Parse({"--replay-bytes", "rec.bin", "--replay-rate", "0", "--time-source", "device"});
  CHECK(cl.options.transport == "replay");
  CHECK_FALSE(cl.options.configure);
  cl = Parse({"--serial", "/dev/ttyUSB0", "--baud", "921600", "--lowpass", "manual",
              "--lowpass-cutoff-hz", "40", "--transport-latency-us", "350", "--seconds", "2",
              "--no-configure", "--print-config"});
  CHECK(cl.options.baud == 921600);
  CHECK(cl.options.lowpass_cutoff_hz == 40);
  CHECK(cl.options.transport_latency_us == 350);
  CHECK_FALSE(cl.options.configure);
  CHECK(cl.print_config);
  CHECK(Parse({"--help"}).help);
  CHECK(Parse({"--list"}).list);

  CHECK_THROWS_AS(Parse({"--bogus"}), UsageError);
  CHECK_THROWS_AS(Parse({"--rate-hz"}), UsageError);
  CHECK_THROWS_AS(Parse({"--rate-hz", "fast"}), UsageError);
  CHECK_THROWS_AS(Parse({"--usb=yes"}), UsageError);
  CHECK_THROWS_WITH(Parse({"--product-id", "0xfffff"}),
                    "--product-id: expected a 16-bit USB id like 0x199b, got '0xfffff'");
  CHECK_THROWS_WITH(Parse({"--family", "gx3"}), "options: family: expected gx5 or cv7");
  CHECK_THROWS_AS(Parse({"--config", "/nonexistent/usb_imu.yaml"}), InputError);
}

TEST_CASE("config/usb_imu.yaml is valid and lists every option", "[usb_imu]") {
  const std::string path = std::string(VILMA_SOURCE_DIR) + "/config/usb_imu.yaml";
  const UsbImuOptions o = LoadUsbImuOptions(path);
  CHECK(o.Validate().empty());
  // Every key of the effective options appears in the example file.
  const std::string text = vilma::test::ReadTextFile(path);
  const YAML::Node all = YAML::Load(UsbImuOptionsToYaml(UsbImuOptions()));
  for (const auto& kv : all) {
    const std::string key = kv.first.as<std::string>();
    INFO(key);
    CHECK(text.find(key + ":") != std::string::npos);
  }
}

// The udev rule grants access to the vendor the driver opens by default, and every rule line is
// made of KEY==value / KEY=value / KEY+=value pairs (a typo would make udev skip the line).
TEST_CASE("config/udev/99-vilma-usb-imu.rules matches the driver's vendor id", "[usb_imu]") {
  const std::string path = std::string(VILMA_SOURCE_DIR) + "/config/udev/99-vilma-usb-imu.rules";
  std::ifstream in(path);
  REQUIRE(in);
  char vendor[8];
  std::snprintf(vendor, sizeof(vendor), "%04x", UsbImuOptions().usb_vendor_id);
  const std::regex pair(R"re(\s*[A-Z_]+(\{[A-Za-z_]+\})?(==|\+=|:=|=)"[^"]*"\s*)re");
  int rules = 0;
  for (std::string line; std::getline(in, line);) {
    if (line.empty() || line[0] == '#') continue;
    ++rules;
    INFO(line);
    CHECK(line.find(std::string("{idVendor}==\"") + vendor + "\"") != std::string::npos);
    std::stringstream parts(line);
    for (std::string part; std::getline(parts, part, ',');) CHECK(std::regex_match(part, pair));
  }
  CHECK(rules == 2);  // the tty and the USB device node
}

}  // namespace
}  // namespace vilma::usb_imu

#else

TEST_CASE("vilma-usb-imu options", "[usb_imu]") {
  VILMA_SKIP("vilma-usb-imu is not built here (pkg-config finds no libusb-1.0: libusb-1.0-0-dev)");
}

#endif
