// The result types of this module have the one shape of core/report.h (Ceres's Solver::Summary):
// BriefReport() one line, FullReport() lines ending in '\n'. Checked at compile time
// (HasReports) and on a default-constructed value (nothing done: the reports still read).
#include <catch2/catch.hpp>

#include "vilma/core/report.h"
#include "vilma/drivers/lcm_rates.h"
#include "vilma/drivers/log_json.h"
#include "vilma/drivers/pose_log.h"
#include "vilma/drivers/replay.h"

TEMPLATE_TEST_CASE("result types of drivers: one-line BriefReport and a FullReport of whole lines",
                   "[report]", vilma::ReplaySummary, vilma::PoseLogStats,
                   vilma::LocalizationLogStats, vilma::LogJsonStats,
                   vilma::LcmRateMonitor) {
  STATIC_REQUIRE(vilma::HasReports<TestType>::value);
  const TestType result{};
  CHECK(vilma::ReportShapeError(result) == "");
}

#ifdef VILMA_HAVE_DRIVER_ARAVIS
#include "vilma/drivers/aravis/aravis_driver.h"

TEST_CASE("vilma-aravis's run summary: the stop lines from one result", "[report]") {
  STATIC_REQUIRE(vilma::HasReports<vilma::aravis::AravisRunSummary>::value);
  vilma::aravis::AravisRunSummary s;
  CHECK(vilma::ReportShapeError(s) == "");
  s.published = 40;
  s.dropped = 1;
  s.latency_p50_ms = 0.25;
  s.stream = "completed 41";
  CHECK(s.BriefReport() == "40 frames published, 1 dropped, 0 incomplete, 0 reconnects");
  CHECK(s.FullReport("P") ==
        "P: stopped: 40 frames published, 1 dropped, 0 incomplete, 0 reconnects; latency to "
        "publish p50 0.25 ms, p99 0.00 ms (arrival -> LCM publish, last 512 frames)\n"
        "P: stream: completed 41\n");
  s.error = "camera lost";
  CHECK(s.BriefReport() ==
        "40 frames published, 1 dropped, 0 incomplete, 0 reconnects; error: camera lost");
}
#endif

#ifdef VILMA_HAVE_DRIVER_USB_IMU
#include "vilma/drivers/usb_imu/usb_imu_run_summary.h"

TEST_CASE("vilma-usb-imu's run summary: the stop line from one result", "[report]") {
  STATIC_REQUIRE(vilma::HasReports<vilma::usb_imu::UsbImuRunSummary>::value);
  vilma::usb_imu::UsbImuRunSummary s;
  CHECK(vilma::ReportShapeError(s) == "");
  s.published = 398;
  s.dropped = 2;
  s.checksum_errors = 1;
  s.skew_ppm = 12.5;
  CHECK(s.FullReport() ==
        "vilma-usb-imu: published 398 samples, dropped 2, packets 0, checksum errors 1, "
        "truncated 0, malformed 0, garbage bytes 0, bad fields 0, incomplete 0, reconnects 0, "
        "clock resets 0, skew 12.5 ppm\n");
}
#endif
