// vilma-usb-imu device dialogue and sample mapping, in process: the configuration against the
// simulated MIP device (both families, NACK, silence), the decimation choice, and ImuStream's
// units, drop counting, clock mapping and monotonic stamps.
#include <catch2/catch.hpp>

#include "test_skip.h"

#ifdef VILMA_HAVE_DRIVER_USB_IMU

#include "drivers/usb_imu_sim_device.h"
#include "vilma/drivers/usb_imu/imu_stream.h"
#include "vilma/drivers/usb_imu/mip_device.h"

namespace vilma::usb_imu {
namespace {

constexpr int64_t kMs = 1000000;

TEST_CASE("MipDevice configures both families: base rate, decimation, command sequence",
          "[usb_imu]") {
  const MipFamily family = GENERATE(MipFamily::kGx5, MipFamily::kCv7);
  test::SimMipDeviceOptions sim;
  sim.family = family;
  sim.base_rate_hz = 1000;
  test::SimTransport transport(sim);
  transport.Open();
  MipFramer framer;
  MipDevice device(&transport, &framer);
  MipConfig config;
  config.family = family;
  config.rate_hz = 250;
  const MipConfigResult r = device.Configure(config);
  CHECK(r.base_rate_hz == 1000);
  CHECK(r.decimation == 4);
  CHECK(r.rate_hz == 250);
  CHECK(transport.device().streaming());
  CHECK(transport.device().decimation() == 4);
  // idle, ping, base rate, format, low-pass accel + gyro, stream on, resume.
  const std::vector<MipPacket>& c = transport.device().commands();
  REQUIRE(c.size() == 8);
  CHECK(CommandDescriptor(c[0]) == mip::kSetToIdle);
  CHECK(CommandDescriptor(c[1]) == mip::kPing);
  CHECK(CommandDescriptor(c[3]) ==
        (family == MipFamily::kGx5 ? mip::kGx5ImuMessageFormat : mip::kMessageFormat));
  CHECK(CommandDescriptor(c[6]) == mip::kDatastreamControl);
  CHECK(CommandDescriptor(c[7]) == mip::kResume);
  CHECK(framer.stats().checksum_errors == 0);
}

TEST_CASE("MipDevice reports a NACK and a silent device by command name", "[usb_imu]") {
  test::SimMipDeviceOptions sim;
  sim.nack_descriptor = mip::kGx5ImuMessageFormat;
  test::SimTransport nacking(sim);
  MipFramer framer;
  MipDevice device(&nacking, &framer);
  CHECK_THROWS_WITH(device.Configure(MipConfig{}),
                    "IMU message format (0x0C,0x08): NACK: invalid parameter from simulated MIP "
                    "device");

  sim = {};
  sim.answer_commands = false;
  test::SimTransport silent(sim);
  MipDevice quiet(&silent, &framer);
  MipConfig config;
  config.command_timeout_ms = 20;
  config.command_retries = 2;
  CHECK_THROWS_WITH(quiet.Configure(config),
                    Catch::Contains("set to idle (0x01,0x02): no reply from simulated MIP device "
                                    "within 20 ms (2 tries)"));
  CHECK(silent.device().commands().size() == 2);  // one try each

  // A GX5 spoken to in the CV7 dialect: its base-rate command is unknown there.
  sim = {};
  test::SimTransport gx5(sim);
  MipDevice wrong(&gx5, &framer);
  config = {};
  config.family = MipFamily::kCv7;
  CHECK_THROWS_WITH(wrong.Configure(config), Catch::Contains("NACK: unknown command"));
}

TEST_CASE("ChooseDecimation: nearest integer, or an error naming the rates near it",
          "[usb_imu]") {
  CHECK(ChooseDecimation(1000, 200) == 5);
  CHECK(ChooseDecimation(1000, 1000) == 1);
  CHECK_THROWS_AS(ChooseDecimation(1000, 5000), MipCommandError);  // above the base rate
  CHECK(ChooseDecimation(1000, 333.3) == 3);
  CHECK_THROWS_WITH(ChooseDecimation(1000, 300),
                    "rate_hz 300 is not base rate 1000 Hz / an integer; near it: 333.333 Hz or "
                    "250 Hz");
  CHECK_THROWS_AS(ChooseDecimation(0, 100), MipCommandError);
}

// The libusb transport without hardware: only "no such device" can be tested here (the rest
// runs only with a MicroStrain IMU plugged in, docs/drivers.md).
TEST_CASE("UsbTransport: an absent device is a clear 'device gone' error", "[usb_imu]") {
  UsbDeviceSelector selector;
  selector.vendor_id = 0x199b;
  selector.product_ids = {0x0001};  // no MicroStrain product has this id
  UsbTransport transport(selector);
  CHECK(transport.Describe() == "USB 199b:0001");
  try {
    transport.Open();
    FAIL("opened a USB device 199b:0001");
  } catch (const TransportError& e) {
    const std::string what = e.what();
    if (what.rfind("libusb_init", 0) == 0) {
      VILMA_SKIP("libusb cannot start here (" << what << ")");
    }
    CHECK(what == "USB 199b:0001: no such device");
    CHECK(e.device_gone());  // the driver would retry (a device that is being replugged)
  }
  uint8_t byte = 0;
  CHECK_THROWS_AS(transport.Read(&byte, 1, 1), TransportError);
  CHECK_THROWS_AS(transport.Write(&byte, 1), TransportError);
  transport.Close();  // idempotent
}

MipImuSample Sample(int64_t k, int64_t period_ns, int64_t device0_ns = 5000 * kMs) {
  MipImuSample s;
  test::SimReadings(k, s.accel_g, s.gyro_rad_s);
  s.has_accel = s.has_gyro = s.has_timestamp = true;
  s.device_ns = device0_ns + k * period_ns;
  return s;
}

TEST_CASE("ImuStream: SI units, drops from device-time gaps, incomplete samples", "[usb_imu]") {
  ImuStream stream(TimeSource::kDevice, ClockSyncOptions{}, 200.0, 0);
  const int64_t host0 = 1700000000LL * 1000000000LL;
  ImuSample out;
  REQUIRE(stream.Process(Sample(0, 5 * kMs), host0 + 2 * kMs, &out));
  CHECK(out.t_ns == host0 + 2 * kMs);  // device: the first arrival's offset
  double accel[3];
  double gyro[3];
  test::SimReadings(0, accel, gyro);
  CHECK(out.a_I.z() == Approx(9.80665));
  CHECK(out.a_I.y() == Approx(accel[1] * 9.80665));
  CHECK(out.omega_I.y() == Approx(-0.5));
  REQUIRE(stream.Process(Sample(1, 5 * kMs), host0 + 9 * kMs, &out));
  CHECK(out.t_ns == host0 + 7 * kMs);  // device spacing kept, arrival jitter ignored
  REQUIRE(stream.Process(Sample(4, 5 * kMs), host0 + 23 * kMs, &out));  // 2 and 3 lost
  CHECK(stream.counters().dropped == 2);
  MipImuSample no_gyro = Sample(5, 5 * kMs);
  no_gyro.has_gyro = false;
  CHECK_FALSE(stream.Process(no_gyro, host0 + 30 * kMs, &out));
  CHECK(stream.counters().incomplete == 1);
  // The device clock restarts (reboot): re-anchored, counted, stamps still increase.
  REQUIRE(stream.Process(Sample(0, 5 * kMs, 0), host0 + 40 * kMs, &out));
  CHECK(out.t_ns == host0 + 40 * kMs);
  CHECK(stream.counters().device_time_jumps == 1);
  CHECK(stream.counters().dropped == 2);
  CHECK(stream.counters().published == 4);
}

TEST_CASE("ImuStream host_sync: warm-up, then device stamps on the host clock", "[usb_imu]") {
  ClockSyncOptions clock;
  clock.min_observations = 5;
  ImuStream stream(TimeSource::kHostSync, clock, 100.0, 300000);  // 0.3 ms fixed latency
  const int64_t host0 = 1700000000LL * 1000000000LL;
  ImuSample out;
  int published = 0;
  int64_t last = 0;
  for (int64_t k = 0; k < 300; ++k) {
    // Arrival = event + 0.3 ms fixed + 0..2 ms (every 7th on time).
    const int64_t event = host0 + k * 10 * kMs;
    const int64_t arrival = event + 300000 + (k % 7 == 0 ? 0 : (k * 7919) % (2 * kMs));
    if (stream.Process(Sample(k, 10 * kMs, 42 * kMs), arrival, &out)) {
      ++published;
      CHECK(out.t_ns > last);
      last = out.t_ns;
      if (k > 20) CHECK(std::abs(out.t_ns - event) < 20000);  // 20 us
    }
  }
  CHECK(stream.counters().warmup == 4);
  CHECK(published == 296);
  CHECK(stream.clock().stats().valid);
}

}  // namespace
}  // namespace vilma::usb_imu

#else

TEST_CASE("vilma-usb-imu device dialogue", "[usb_imu]") {
  VILMA_SKIP("vilma-usb-imu is not built here (pkg-config finds no libusb-1.0: libusb-1.0-0-dev)");
}

#endif
