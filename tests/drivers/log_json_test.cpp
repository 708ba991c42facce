#include "vilma/drivers/log_json.h"

#include <catch2/catch.hpp>
#include <cmath>
#include <filesystem>
#include <sstream>
#include <unistd.h>
#include <vilma/imu_t.hpp>
#include <vilma/pose_t.hpp>
#include <vilma/status_t.hpp>

#include "vilma/core/error.h"
#include "vilma/drivers/lcm_log.h"
#include "vilma/drivers/lcm_safe_decode.h"

namespace vilma {
namespace {

std::string TempDir(const std::string& name) {
  const std::string dir = std::filesystem::temp_directory_path().string() + "/vilma_" + name + "_" +
                          std::to_string(::getpid());
  std::filesystem::remove_all(dir);
  std::filesystem::create_directories(dir);
  return dir;
}

status_t MakeStatus() {
  status_t s;
  s.utime = 1700000000000000;
  s.node = "vilma-estimatord";
  s.state = status_t::DEGRADED;
  s.message = "LOST, \"0\" features\n";
  s.counter_names = {"drops", "queue_input_depth_max"};
  s.counter_values = {3, -7};
  s.num_counters = 2;
  s.metric_names = {"latency_total_p99_ms", "cpu_load"};
  s.metric_values = {2.5, NAN};
  s.num_metrics = 2;
  return s;
}

TEST_CASE("WriteLogJson writes status_t and pose_t events as JSON lines and skips others", "[lcm]") {
  const std::string dir = TempDir("log_json");
  const std::string path = dir + "/run.lcmlog";
  {
    LcmLogWriter writer(path);
    writer.WriteMessage("VILMA_STATUS", MakeStatus(), 5);
    pose_t p{};
    p.utime = 42;
    p.seq = 7;
    p.status = pose_t::TRACKING;
    p.position[0] = 1.5;
    p.orientation[0] = 1.0;
    writer.WriteMessage("VILMA_ODOM", p, 6);
    imu_t imu{};
    writer.WriteMessage("VILMA_IMU_COPY", imu, 7);  // another type on a matching channel
    writer.WriteMessage("IMU", imu, 8);             // a channel that does not match
    // A status_t whose counter count is negative: lcm-gen's decoder throws; skipped.
    status_t bad = MakeStatus();
    std::vector<uint8_t> bytes(static_cast<std::size_t>(bad.getEncodedSize()));
    bad.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
    writer.Write("VILMA_STATUS", bytes.data(), 40, 9);  // truncated: does not decode
    writer.Close();
  }
  std::ostringstream out;
  const LogJsonStats stats = WriteLogJson(path, std::regex("VILMA_.*"), out);
  CHECK(stats.events_matched == 4);
  CHECK(stats.status == 1);
  CHECK(stats.poses == 1);
  CHECK(stats.skipped == 2);
  const std::string expected =
      "{\"log_us\":5,\"channel\":\"VILMA_STATUS\",\"type\":\"status\",\"utime\":1700000000000000,"
      "\"node\":\"vilma-estimatord\",\"state\":2,\"message\":\"LOST, \\\"0\\\" features\\n\","
      "\"counters\":{\"drops\":3,\"queue_input_depth_max\":-7},"
      "\"metrics\":{\"latency_total_p99_ms\":2.5,\"cpu_load\":null}}\n"
      "{\"log_us\":6,\"channel\":\"VILMA_ODOM\",\"type\":\"pose\",\"utime\":42,\"seq\":7,"
      "\"status\":2,\"position\":[1.5,0,0],\"orientation\":[1,0,0,0]}\n";
  CHECK(out.str() == expected);

  std::ostringstream only_odom;
  CHECK(WriteLogJson(path, std::regex("VILMA_ODOM"), only_odom).poses == 1);
  CHECK(only_odom.str().find("\"type\":\"status\"") == std::string::npos);
  CHECK_THROWS_AS(WriteLogJson(dir + "/absent.lcmlog", std::regex(".*"), out), InputError);
  std::filesystem::remove_all(dir);
}

std::vector<uint8_t> Encode(const status_t& s) {
  std::vector<uint8_t> bytes(static_cast<std::size_t>(s.getEncodedSize()));
  s.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  return bytes;
}

void PutInt32(std::vector<uint8_t>* bytes, std::size_t at, int32_t value) {
  for (int i = 0; i < 4; ++i) (*bytes)[at + i] = static_cast<uint8_t>(static_cast<uint32_t>(value) >> (24 - 8 * i));
}

TEST_CASE("DecodeStatusMessage bounds the array counts before lcm-gen allocates them", "[lcm][safe_decode]") {
  const status_t s = MakeStatus();
  std::vector<uint8_t> bytes = Encode(s);
  status_t out;
  REQUIRE(DecodeStatusMessage(bytes.data(), static_cast<int>(bytes.size()), &out) == "");
  CHECK(out.counter_names == s.counter_names);
  CHECK(out.metric_values[0] == 2.5);
  // num_counters sits after hash, utime, node, state and message.
  const std::size_t at_counters = 8 + 8 + 4 + s.node.size() + 1 + 4 + 4 + s.message.size() + 1;
  std::vector<uint8_t> huge = bytes;
  PutInt32(&huge, at_counters, 0x7fffffff);  // lcm-gen would resize to 2^31 - 1 strings
  CHECK(DecodeStatusMessage(huge.data(), static_cast<int>(huge.size()), &out) ==
        "status_t: counter_names: count 2147483647 beyond the message");
  PutInt32(&huge, at_counters, -1);
  CHECK(DecodeStatusMessage(huge.data(), static_cast<int>(huge.size()), &out) ==
        "status_t: counter_names: count -1 < 0");
  CHECK_THAT(DecodeStatusMessage(bytes.data(), static_cast<int>(bytes.size()) - 1, &out),
             Catch::StartsWith("status_t:"));
  CHECK_THAT(DecodeStatusMessage(bytes.data(), 3, &out), Catch::StartsWith("status_t:"));
  std::vector<uint8_t> longer = bytes;
  longer.push_back(0);
  CHECK(DecodeStatusMessage(longer.data(), static_cast<int>(longer.size()), &out) ==
        "status_t: 1 bytes after the last field");
  CHECK(DecodeStatusMessage(nullptr, 0, &out) != "");

  // Through the log reader: the event is skipped, the next one is read.
  const std::string dir = TempDir("log_json_huge");
  {
    LcmLogWriter writer(dir + "/huge.lcmlog");
    PutInt32(&huge, at_counters, 0x7fffffff);
    writer.Write("VILMA_STATUS", huge.data(), static_cast<int>(huge.size()), 1);
    writer.WriteMessage("VILMA_STATUS", s, 2);
    writer.Close();
  }
  std::ostringstream json;
  const LogJsonStats stats = WriteLogJson(dir + "/huge.lcmlog", std::regex(".*"), json);
  CHECK(stats.skipped == 1);
  CHECK(stats.status == 1);
  std::filesystem::remove_all(dir);
}

}  // namespace
}  // namespace vilma
