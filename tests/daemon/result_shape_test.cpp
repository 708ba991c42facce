// The result types of this module have the one shape of core/report.h (Ceres's Solver::Summary):
// BriefReport() one line, FullReport() lines ending in '\n'. Checked at compile time
// (HasReports) and on a default-constructed value (nothing done: the reports still read).
#include <catch2/catch.hpp>

#include "vilma/core/report.h"
#include "vilma/daemon/estimator_daemon.h"

TEMPLATE_TEST_CASE("result types of daemon: one-line BriefReport and a FullReport of whole lines",
                   "[report]", vilma::daemon::DaemonSummary) {
  STATIC_REQUIRE(vilma::HasReports<TestType>::value);
  const TestType result{};
  CHECK(vilma::ReportShapeError(result) == "");
}
