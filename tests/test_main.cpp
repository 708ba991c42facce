// Catch2's main, plus the skip exit code: a run in which nothing failed but a test was skipped
// (tests/test_skip.h) exits with kSkipReturnCode, which ctest reports as "Skipped".
#define CATCH_CONFIG_RUNNER
#include <catch2/catch.hpp>

#include "test_skip.h"

int main(int argc, char* argv[]) {
  const int failed = Catch::Session().run(argc, argv);
  if (failed != 0) return failed == vilma::testing::kSkipReturnCode ? failed + 1 : failed;
  return vilma::testing::SkipCount() > 0 ? vilma::testing::kSkipReturnCode : 0;
}
