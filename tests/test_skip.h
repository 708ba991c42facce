// Skipping a test that cannot run here (shared data, a built program or a Debian package is
// missing) so that ctest reports it as skipped, not as passed (docs/testing.md "Skipped tests").
//
// VILMA_SKIP(reason) prints "SKIPPED: <reason>", counts the skip and returns from the test;
// tests/test_main.cpp then exits with kSkipReturnCode when no check failed, which ctest turns
// into "Skipped" (SKIP_RETURN_CODE in tests/CMakeLists.txt). A failed check still wins.
// With VILMA_REQUIRE_ALL=1 in the environment (CI: scripts/test.sh) the skip is a failure:
// what CI provides (../shared/data, the built programs, scripts/debian-packages.txt) must be
// found, so a test that cannot find it is a broken test, not a skipped one.
// VILMA_SKIP_OPTIONAL(reason) is for what CI does not provide (datasets that only
// scripts/make-datasets.sh makes): skipped even under VILMA_REQUIRE_ALL.
#pragma once

#include <atomic>
#include <catch2/catch.hpp>
#include <cstdlib>
#include <string>

namespace vilma::testing {

// ctest's SKIP_RETURN_CODE (77, as automake's): the process ran, nothing failed, something
// was skipped.
constexpr int kSkipReturnCode = 77;

// Skips counted in this process (read by test_main.cpp's main()).
inline std::atomic<int>& SkipCount() {
  static std::atomic<int> count{0};
  return count;
}

// True when VILMA_REQUIRE_ALL is set to anything but "" or "0".
inline bool RequireAllTests() {
  const char* value = std::getenv("VILMA_REQUIRE_ALL");
  return value != nullptr && value[0] != '\0' && std::string(value) != "0";
}

}  // namespace vilma::testing

// Records a skip (or, under VILMA_REQUIRE_ALL, fails the test) without returning: for helper
// functions that report "cannot run" to their caller, and for the last part of a test.
#define VILMA_SKIP_NOTE(reason)                                                          \
  do {                                                                                   \
    if (::vilma::testing::RequireAllTests()) {                                           \
      FAIL("VILMA_REQUIRE_ALL is set, so this test must run, but: " << reason);          \
    }                                                                                    \
    WARN("SKIPPED: " << reason);                                                         \
    ++::vilma::testing::SkipCount();                                                     \
  } while (0)

#define VILMA_SKIP(reason) \
  do {                     \
    VILMA_SKIP_NOTE(reason); \
    return;                \
  } while (0)

#define VILMA_SKIP_OPTIONAL_NOTE(reason)                                              \
  do {                                                                                \
    WARN("SKIPPED (optional, not required by VILMA_REQUIRE_ALL): " << reason);        \
    ++::vilma::testing::SkipCount();                                                  \
  } while (0)

#define VILMA_SKIP_OPTIONAL(reason)  \
  do {                               \
    VILMA_SKIP_OPTIONAL_NOTE(reason); \
    return;                          \
  } while (0)
