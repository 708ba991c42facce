// vilma-usb-imu on a pty: the stamp error and latency figures of docs/drivers.md (a hidden test;
// scripts/bench-clock-sync.sh runs it). The harness is usb_imu_pty_harness.h.
#include <catch2/catch.hpp>

#include "test_skip.h"

#ifdef VILMA_HAVE_DRIVER_USB_IMU

#include <cstdio>

#include "drivers/usb_imu_pty_harness.h"

namespace vilma::usb_imu {
namespace {

using namespace pty_test;  // NOLINT: the harness is this test's vocabulary

// The end-to-end figures of docs/drivers.md (scripts/bench-clock-sync.sh runs this hidden
// test): 10 s of a GX5 at 200 Hz with a +50 ppm clock on a pty, no faults; stamp error against
// the simulator's event times after the first 0.5 s, and the driver's own latency and skew.
TEST_CASE("vilma-usb-imu on a pty: stamp error and latency figures", "[.usb_imu_bench]") {
  if (!vilma::test::FileExists(kProgram)) VILMA_SKIP("vilma-usb-imu is not built: " << kProgram);
  test::SimMipDeviceOptions sim;
  const std::string link = vilma::test::ScratchDir() + "/imu_tty_bench";
  PtyImu imu(link, sim, 50.0, Faults{});
  imu.set_stream_seconds(10.0);
  const std::string url = vilma::test::UniqueLcmUrl();
  Subscriber sub(url);
  const std::string log = vilma::test::ScratchDir() + "/usb_imu_bench.log";
  REQUIRE(RunDriver(url, {"--serial", link, "--seconds", "10.8"}, &sub, log) == 0);
  const std::vector<double> errors = CheckSamples(sub.imus, &imu);
  status_t ok;
  for (const status_t& s : sub.statuses) {
    if (s.state == status_t::OK) ok = s;
  }
  std::printf("| samples | stamp error median [us] | p99 [us] | max [us] | skew [ppm] (true -50) "
              "| latency p50 [ms] | p99 [ms] |\n|---|---|---|---|---|---|---|\n");
  std::printf("| %zu | %.0f | %.0f | %.0f | %.1f | %.2f | %.2f |\n", sub.imus.size(),
              1e3 * Percentile(errors, 0.5), 1e3 * Percentile(errors, 0.99),
              1e3 * Percentile(errors, 1.0), Metric(sub.statuses.back(), "clock_skew_ppm"),
              Metric(ok, "latency_p50_ms"), Metric(ok, "latency_p99_ms"));
  CHECK(Percentile(errors, 1.0) < 2.0);
}

}  // namespace
}  // namespace vilma::usb_imu

#endif
