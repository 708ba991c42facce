// DriverLcmOptions (drivers/common/driver_lcm_options.h): the LCM keys every driver shares,
// read, validated, written back, parsed from flags and documented once.
#include <catch2/catch.hpp>

#include <string>
#include <vector>

#include "vilma/core/arg_cursor.h"
#include "vilma/core/error.h"
#include "vilma/core/options_fields.h"
#include "vilma/core/yaml_io.h"
#include "vilma/drivers/driver_lcm_options.h"

namespace vilma {
namespace {

DriverLcmOptions Camera() {
  DriverLcmOptions o;
  o.channel = "CAM0";
  return o;
}

// Reads `yaml` over `base` the way the drivers do: the shared keys, then the unknown-key check.
DriverLcmOptions Read(const std::string& yaml, DriverLcmOptions base) {
  ReadOptionFields(YamlNode::LoadString(yaml, "test.yaml"), MissingKey::kKeepDefault, &base,
                   [](auto& o, auto&& v) { VisitDriverLcmFields(o, v); });
  return base;
}

std::string ReadError(const std::string& yaml) {
  try {
    Read(yaml, Camera());
  } catch (const InputError& e) {
    return e.what();
  }
  return "";
}

TEST_CASE("Driver LCM options: channels with suffix and the default status channel",
          "[driver_lcm_options]") {
  DriverLcmOptions o = Camera();
  CHECK(o.ValidateLcm().empty());
  CHECK(o.DataChannel() == "CAM0");
  CHECK(o.StatusChannel() == "VILMA_STATUS_CAM0");
  o.channel_suffix = "_R2";
  CHECK(o.DataChannel() == "CAM0_R2");
  CHECK(o.StatusChannel() == "VILMA_STATUS_CAM0_R2");
  o.status_channel = "HEALTH";
  CHECK(o.StatusChannel() == "HEALTH_R2");
}

TEST_CASE("Driver LCM options: validation names the field", "[driver_lcm_options]") {
  DriverLcmOptions o = Camera();
  o.status_channel = "CAM0";
  CHECK(o.ValidateLcm() == "status_channel: expected another channel than channel");
  o = Camera();
  o.channel = "";
  CHECK(o.ValidateLcm().rfind("channel: ", 0) == 0);
  o = Camera();
  o.channel = "CAM.*";  // LCM matches channel names as regular expressions
  CHECK(o.ValidateLcm().rfind("channel: ", 0) == 0);
  o = Camera();
  o.status_period_s = 0.01;
  CHECK(o.ValidateLcm() == "status_period_s: expected 0.05 .. 60 [s]");
  o.status_period_s = 61.0;
  CHECK(o.ValidateLcm() == "status_period_s: expected 0.05 .. 60 [s]");
  o = Camera();
  o.seconds = -1.0;
  CHECK(o.ValidateLcm() == "seconds: expected >= 0 (0 = no limit)");
}

TEST_CASE("Driver LCM options: YAML keeps absent keys, round-trips, rejects wrong types",
          "[driver_lcm_options]") {
  const DriverLcmOptions o = Read("channel: LEFT\nseconds: 2.5\n", Camera());
  CHECK(o.channel == "LEFT");
  CHECK(o.seconds == 2.5);
  CHECK(o.status_period_s == 1.0);  // absent: the base's value
  CHECK(o.lcm_url.empty());

  DriverLcmOptions full = Camera();
  full.lcm_url = "udpm://239.255.76.67:7667?ttl=0&recv_buf_size=8388608";
  full.channel_suffix = "_R2";
  full.status_channel = "HEALTH";
  full.status_period_s = 0.25;
  full.seconds = 12.125;
  const DriverLcmOptions back = Read(DriverLcmOptionsYaml(full), DriverLcmOptions());
  CHECK(back.lcm_url == full.lcm_url);
  CHECK(back.channel == full.channel);
  CHECK(back.channel_suffix == full.channel_suffix);
  CHECK(back.status_channel == full.status_channel);
  CHECK(back.status_period_s == full.status_period_s);
  CHECK(back.seconds == full.seconds);

  const std::string error = ReadError("seconds: soon\n");
  CHECK(error.find("test.yaml") != std::string::npos);
  CHECK(error.find("seconds") != std::string::npos);
  CHECK(ReadError("chanel: CAM1\n").find("chanel") != std::string::npos);
}

TEST_CASE("Driver LCM options: flags", "[driver_lcm_options]") {
  const std::vector<std::string> args = {"--channel", "CAM1", "--seconds=3", "--lcm-url",
                                         "memq://", "--status-period-s", "0.5", "--list"};
  DriverLcmOptions o = Camera();
  std::vector<std::string> other;
  for (ArgCursor arg(args); arg.Next();) {
    if (!ParseDriverLcmFlag(arg, &o)) other.push_back(arg.name());
  }
  CHECK(o.channel == "CAM1");
  CHECK(o.seconds == 3.0);
  CHECK(o.lcm_url == "memq://");
  CHECK(o.status_period_s == 0.5);
  CHECK(other == std::vector<std::string>{"--list"});  // not ours: left to the driver

  const std::vector<std::string> bad = {"--seconds", "3x"};
  ArgCursor arg(bad);
  REQUIRE(arg.Next());
  CHECK_THROWS_AS(ParseDriverLcmFlag(arg, &o), UsageError);
}

TEST_CASE("Driver LCM options: --help lists every flag with its default",
          "[driver_lcm_options]") {
  const std::string usage = DriverLcmUsage(Camera());
  for (const char* flag : {"--lcm-url", "--channel ", "--channel-suffix", "--status-channel",
                           "--status-period-s", "--seconds"}) {
    CHECK(usage.find(flag) != std::string::npos);
  }
  CHECK(usage.find("[CAM0]") != std::string::npos);
}

}  // namespace
}  // namespace vilma
