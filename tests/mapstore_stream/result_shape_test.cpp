// MapStoreServerCounters has the one shape of core/report.h; its FullReport lists every
// counter by the name mapstored publishes it under.
#include <catch2/catch.hpp>

#include <algorithm>
#include <string>

#include "vilma/core/report.h"
#include "vilma/mapstore/stream/map_store_server.h"

TEST_CASE("mapstored's counters: one-line BriefReport, a FullReport line per counter",
          "[report]") {
  STATIC_REQUIRE(vilma::HasReports<vilma::mapstore::MapStoreServerCounters>::value);
  vilma::mapstore::MapStoreServerCounters c;
  CHECK(vilma::ReportShapeError(c) == "");
  c.chunks_received = 12;
  c.chunks_duplicate = 2;
  c.fsyncs = 3;
  c.finalize_errors = 1;
  c.stream_repairs = 4;
  CHECK(c.BriefReport() ==
        "12 chunks received, 0 journaled, 2 duplicate, 0 out of order, 3 fsyncs, 0 acks");
  const std::string full = c.FullReport();
  CHECK(vilma::ReportShapeError(c) == "");
  CHECK_THAT(full, Catch::Contains("\nchunks_received 12\n") &&
                       Catch::Contains("\nfinalize_errors 1\n") &&
                       Catch::Contains("\nstream_repairs 4\n") &&
                       Catch::StartsWith("missions_completed 0\n"));
  int lines = 0;
  c.VisitCounters([&lines](const char*, uint64_t) { ++lines; });
  CHECK(lines == 17);  // 16 + stream_repairs (2026-11-27)
  CHECK(static_cast<int>(std::count(full.begin(), full.end(), '\n')) == lines);
}
