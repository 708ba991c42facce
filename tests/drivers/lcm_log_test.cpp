#include "vilma/drivers/lcm_log.h"

#include <unistd.h>

#include <catch2/catch.hpp>
#include <cstdio>
#include <fstream>
#include <iterator>
#include <string>
#include <vector>

#include "vilma/core/error.h"
#include "vilma/drivers/lcm_convert.h"

namespace vilma {
namespace {

std::string TempPath(const std::string& name) {
  return "/tmp/vilma_lcm_log_test_" + std::to_string(::getpid()) + "_" + name;
}

bool Exists(const std::string& path) { return std::ifstream(path).good(); }

TEST_CASE("LCM log write/read round trip", "[lcm]") {
  const std::string path = TempPath("roundtrip.lcmlog");
  std::vector<LcmLogEvent> written;
  {
    LcmLogWriter writer(path);
    CHECK(Exists(path + ".partial"));
    CHECK_FALSE(Exists(path));
    for (int i = 0; i < 50; ++i) {
      ImuSample s;
      s.t_ns = 1000000000LL + i * 5000000LL;
      s.omega_I.x() = 0.01 * i;
      const imu_t msg = ImuToMessage(s, i);
      writer.WriteMessage("IMU", msg, msg.utime);
      std::vector<uint8_t> bytes(static_cast<size_t>(msg.getEncodedSize()));
      msg.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
      written.push_back({msg.utime, "IMU", bytes});
      if (i % 10 == 0) {
        const std::vector<uint8_t> raw = {1, 2, 3, static_cast<uint8_t>(i)};
        writer.Write("RAW_CHANNEL", raw.data(), static_cast<int>(raw.size()), msg.utime);
        written.push_back({msg.utime, "RAW_CHANNEL", raw});
      }
    }
    // An empty payload is a legal event.
    writer.Write("EMPTY", nullptr, 0, 7);
    written.push_back({7, "EMPTY", {}});
    CHECK(writer.num_events() == static_cast<int64_t>(written.size()));
    writer.Close();
    writer.Close();  // idempotent
  }
  CHECK(Exists(path));
  CHECK_FALSE(Exists(path + ".partial"));

  const std::vector<LcmLogEvent> read = ReadLcmLog(path);
  REQUIRE(read.size() == written.size());
  for (size_t i = 0; i < read.size(); ++i) {
    CHECK(read[i].timestamp_us == written[i].timestamp_us);
    CHECK(read[i].channel == written[i].channel);
    CHECK(read[i].data == written[i].data);
  }
  // Events decode back into the messages: read[0] is the IMU sample of i = 0.
  imu_t msg;
  ImuSample sample;
  REQUIRE(DecodeImuMessage(read[0].data.data(), static_cast<int>(read[0].data.size()), &msg,
                           &sample).empty());
  CHECK(msg.seq == 0);
  CHECK(read[1].channel == "RAW_CHANNEL");
  std::remove(path.c_str());
}

TEST_CASE("a corrupted event header ends the log instead of allocating what it claims",
          "[lcm]") {
  // Three events, then the third's data length field overwritten with 2^31 - 1 (found by
  // fuzz_lcm_log: liblcm allocates the claimed length before reading it).
  const std::string path = TempPath("corrupt_length.lcmlog");
  std::vector<long> event_offsets;
  {
    LcmLogWriter writer(path);
    const std::vector<uint8_t> payload(100, 7);
    for (int i = 0; i < 3; ++i) {
      writer.Write("CHANNEL", payload.data(), static_cast<int>(payload.size()), i);
    }
    writer.Close();
  }
  std::string bytes;
  {
    std::ifstream in(path, std::ios::binary);
    bytes.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  const std::string sync("\xED\xA1\xDA\x01", 4);
  const std::size_t third = bytes.find(sync, bytes.find(sync, bytes.find(sync) + 1) + 1);
  REQUIRE(third != std::string::npos);
  const std::size_t data_length_at = third + 4 + 8 + 8 + 4;
  bytes.replace(data_length_at, 4, std::string("\x7F\xFF\xFF\xFF", 4));
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out << bytes;
  }
  const std::vector<LcmLogEvent> read = ReadLcmLog(path);
  CHECK(read.size() == 2);  // the events before the corrupted one
  // A channel length beyond liblcm's limit of 1000 ends the log as well.
  bytes.replace(data_length_at - 4, 4, std::string("\x00\x00\x10\x00", 4));
  {
    std::ofstream out(path, std::ios::binary | std::ios::trunc);
    out << bytes;
  }
  CHECK(ReadLcmLog(path).size() == 2);
  std::remove(path.c_str());
}

TEST_CASE("LCM log errors name the path", "[lcm]") {
  try {
    LcmLogReader reader("/nonexistent/dir/x.lcmlog");
    FAIL("no exception");
  } catch (const InputError& e) {
    CHECK(std::string(e.what()).find("/nonexistent/dir/x.lcmlog") != std::string::npos);
  }
  CHECK_THROWS_AS(LcmLogWriter("/nonexistent/dir/y.lcmlog"), InputError);

  // A file that is not a log reads as an empty log (lcm's reader stops at a bad sync word).
  const std::string path = TempPath("garbage.lcmlog");
  std::ofstream(path) << "this is not an lcm log";
  LcmLogReader reader(path);
  LcmLogEvent event;
  CHECK_FALSE(reader.Next(&event));
  std::remove(path.c_str());
}

}  // namespace
}  // namespace vilma
