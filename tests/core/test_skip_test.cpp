// The skip machinery of the test suite itself (tests/test_skip.h, tests/test_main.cpp): this
// binary runs its own hidden test cases and checks the exit codes ctest sees.
#include "test_skip.h"

#include <sys/wait.h>
#include <unistd.h>

#include <catch2/catch.hpp>
#include <cstdlib>
#include <string>

namespace vilma {
namespace {

TEST_CASE("skip self-test: skips", "[.skip_selftest]") {
  VILMA_SKIP("self-test of VILMA_SKIP");
  FAIL("not reached");
}

TEST_CASE("skip self-test: optional skip", "[.skip_selftest_optional]") {
  VILMA_SKIP_OPTIONAL("self-test of VILMA_SKIP_OPTIONAL");
  FAIL("not reached");
}

TEST_CASE("skip self-test: a failure before the skip", "[.skip_selftest_fail]") {
  CHECK(1 + 1 == 3);
  VILMA_SKIP("self-test: skipped after a failed check");
}

// Exit status of this binary run on `spec` with `env` before it (e.g. "VILMA_REQUIRE_ALL=1").
int RunSelf(const std::string& env, const std::string& spec) {
  char exe[4096];
  const ssize_t n = ::readlink("/proc/self/exe", exe, sizeof(exe) - 1);
  REQUIRE(n > 0);
  exe[n] = '\0';
  const std::string command = "env -u VILMA_REQUIRE_ALL " + env + " '" + std::string(exe) +
                              "' '" + spec + "' > /dev/null 2>&1";
  const int status = std::system(command.c_str());
  REQUIRE(WIFEXITED(status));
  return WEXITSTATUS(status);
}

TEST_CASE("VILMA_SKIP exits 77 (ctest: skipped), VILMA_REQUIRE_ALL=1 makes it a failure",
          "[test_skip]") {
  CHECK(RunSelf("", "[.skip_selftest]") == testing::kSkipReturnCode);
  CHECK(RunSelf("VILMA_REQUIRE_ALL=1", "[.skip_selftest]") == 1);
  CHECK(RunSelf("VILMA_REQUIRE_ALL=0", "[.skip_selftest]") == testing::kSkipReturnCode);
  // What CI does not provide may be skipped even there.
  CHECK(RunSelf("VILMA_REQUIRE_ALL=1", "[.skip_selftest_optional]") == testing::kSkipReturnCode);
  // A failed check wins over a skip.
  CHECK(RunSelf("", "[.skip_selftest_fail]") == 1);
  // Nothing skipped: 0.
  CHECK(RunSelf("", "[test_skip_none]") == 0);
}

TEST_CASE("skip self-test: passes", "[test_skip_none]") { CHECK(testing::kSkipReturnCode == 77); }

}  // namespace
}  // namespace vilma
