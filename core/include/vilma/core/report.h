// The one shape of the project's result types (Summary, Stats, Report, Result, Counters that a
// user reads), after Ceres's Solver::Summary: counts and times as plain fields, and
//   std::string BriefReport() const;  // one line, no '\n' ("12 loops verified, 1.2 s")
//   std::string FullReport() const;   // every line ends in '\n'; what a command prints
// Programs print FullReport() (or BriefReport() followed by their own '\n'); no caller formats a
// result's fields itself. ReportShapeError checks a value against this shape (tests run it on
// every user-facing result type: tests/console/result_shape_test.cpp).
#pragma once

#include <string>
#include <type_traits>
#include <utility>

namespace vilma {

// True when T has `std::string BriefReport() const` and `std::string FullReport() const`.
template <typename T, typename = void>
struct HasReports : std::false_type {};
template <typename T>
struct HasReports<T, std::void_t<decltype(std::declval<const T&>().BriefReport()),
                                 decltype(std::declval<const T&>().FullReport())>>
    : std::bool_constant<
          std::is_same_v<decltype(std::declval<const T&>().BriefReport()), std::string> &&
          std::is_same_v<decltype(std::declval<const T&>().FullReport()), std::string>> {};

// "" when `brief` is one non-empty line without '\n' and `full` is non-empty with every line
// ending in '\n'; else what is wrong ("BriefReport: ...", "FullReport: ...").
inline std::string ReportShapeError(const std::string& brief, const std::string& full) {
  if (brief.empty()) return "BriefReport: expected one line, got an empty string";
  if (brief.find('\n') != std::string::npos) {
    return "BriefReport: expected one line without '\\n', got \"" + brief + "\"";
  }
  if (full.empty() || full.back() != '\n') {
    return "FullReport: expected lines that each end in '\\n', got \"" + full + "\"";
  }
  return "";
}

template <typename T>
std::string ReportShapeError(const T& result) {
  static_assert(HasReports<T>::value, "a result type needs BriefReport() and FullReport()");
  return ReportShapeError(result.BriefReport(), result.FullReport());
}

}  // namespace vilma
