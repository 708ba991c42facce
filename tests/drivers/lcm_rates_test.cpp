#include "vilma/drivers/lcm_rates.h"

#include <catch2/catch.hpp>
#include <vector>

#include "vilma/drivers/lcm_convert.h"

namespace vilma {
namespace {

std::vector<uint8_t> ImuBytes(int64_t seq) {
  ImuSample s;
  s.t_ns = 1000000 * seq;
  const imu_t msg = ImuToMessage(s, seq);
  std::vector<uint8_t> bytes(static_cast<size_t>(msg.getEncodedSize()));
  msg.encode(bytes.data(), 0, static_cast<int>(bytes.size()));
  return bytes;
}

TEST_CASE("Rate monitor counts messages, bytes and seq gaps", "[lcm]") {
  LcmRateMonitor monitor;
  double t = 0.0;
  for (int64_t seq : {0, 1, 2, 5, 6, 6, 3, 7}) {  // 3 and 4 lost; 6 duplicated; 3 late
    const std::vector<uint8_t> bytes = ImuBytes(seq);
    monitor.OnMessage("IMU", bytes.data(), static_cast<int>(bytes.size()), t);
    t += 0.005;
  }
  const uint8_t other[3] = {1, 2, 3};  // not a sequenced type: counted, no gaps
  monitor.OnMessage("OTHER", other, 3, 0.0);
  monitor.OnMessage("OTHER", other, 3, 1.0);

  const ChannelStats& imu = monitor.channels().at("IMU");
  CHECK(imu.messages == 8);
  CHECK(imu.bytes == 8 * kImuMessageBytes);
  CHECK(imu.lost == 2);
  CHECK(imu.out_of_order == 2);
  CHECK(imu.sequenced);
  CHECK_FALSE(monitor.channels().at("OTHER").sequenced);
  CHECK(monitor.total_messages() == 10);
  CHECK(monitor.total_lost() == 2);

  const std::string table = monitor.FullReport();
  CHECK(table.find("TOTAL messages=10 bytes=582 lost=2 out_of_order=2") != std::string::npos);
  CHECK(monitor.BriefReport() == "2 channels, 10 messages, 0.00 MB, 2 lost, 2 out of order");
  const std::string periodic = monitor.PeriodicReport(1.0);
  CHECK(periodic.find("IMU") != std::string::npos);
  CHECK(monitor.channels().at("IMU").window_messages == 0);
}

}  // namespace
}  // namespace vilma
