#include "vilma/core/report.h"

#include <catch2/catch.hpp>

namespace {

struct Shaped {
  std::string brief = "3 things, 1.0 s";
  std::string full = "3 things\n  time 1.0 s\n";
  std::string BriefReport() const { return brief; }
  std::string FullReport() const { return full; }
};
struct OnlyReport {
  std::string Report() const { return ""; }
};
struct WrongType {
  const char* BriefReport() const { return ""; }
  std::string FullReport() const { return ""; }
};

}  // namespace

TEST_CASE("result shape: BriefReport and FullReport returning std::string are detected") {
  STATIC_REQUIRE(vilma::HasReports<Shaped>::value);
  STATIC_REQUIRE_FALSE(vilma::HasReports<OnlyReport>::value);
  STATIC_REQUIRE_FALSE(vilma::HasReports<WrongType>::value);
}

TEST_CASE("result shape: one line, and lines that end in a newline") {
  Shaped s;
  CHECK(vilma::ReportShapeError(s).empty());
  s.brief = "two\nlines";
  CHECK(vilma::ReportShapeError(s).rfind("BriefReport:", 0) == 0);
  s.brief = "";
  CHECK(vilma::ReportShapeError(s).rfind("BriefReport:", 0) == 0);
  s = Shaped();
  s.full = "no newline at the end";
  CHECK(vilma::ReportShapeError(s).rfind("FullReport:", 0) == 0);
  s.full = "";
  CHECK(vilma::ReportShapeError(s).rfind("FullReport:", 0) == 0);
}
