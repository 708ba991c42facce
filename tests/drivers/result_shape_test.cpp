// The result types of this module have the one shape of core/report.h (Ceres's Solver::Summary):
// BriefReport() one line, FullReport() lines ending in '\n'. Checked at compile time
// (HasReports) and on a default-constructed value (nothing done: the reports still read).
#include <catch2/catch.hpp>

#include "vilma/core/report.h"
#include "vilma/drivers/log_json.h"
#include "vilma/drivers/pose_log.h"
#include "vilma/drivers/replay.h"

TEMPLATE_TEST_CASE("result types of drivers: one-line BriefReport and a FullReport of whole lines",
                   "[report]", vilma::ReplaySummary, vilma::PoseLogStats,
                   vilma::LocalizationLogStats, vilma::LogJsonStats) {
  STATIC_REQUIRE(vilma::HasReports<TestType>::value);
  const TestType result{};
  CHECK(vilma::ReportShapeError(result) == "");
}
