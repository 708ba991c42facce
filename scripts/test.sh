#!/usr/bin/env bash
# Installs what is missing, builds, and runs the whole test suite (ctest). Ends with ctest's
# summary; exits non-zero when a test fails. Extra arguments go to ctest (e.g. -L core).
#   --clang   build with clang++ instead (in <repo>/build-clang, unless VILMA_BUILD_DIR is
#             set) with -Werror=parentheses, then run the suite there (docs/testing.md)
# Under CI (CI=true) with the shared data beside the checkout, VILMA_REQUIRE_ALL=1 turns a test
# that skips (data, program or Debian package not found) into a failure (docs/testing.md).
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"

if [ "${1:-}" = "--clang" ]; then
  shift
  # CC/CXX and CXXFLAGS are read by CMake when it configures a new build folder.
  export CC=clang CXX=clang++ CXXFLAGS="${CXXFLAGS:-} -Werror=parentheses"
  export VILMA_BUILD_DIR="${VILMA_BUILD_DIR:-$repo/build-clang}"
fi
build="${VILMA_BUILD_DIR:-$repo/build}"
"$repo/scripts/setup.sh"

if [ "${CI:-}" = "true" ] && [ -z "${VILMA_REQUIRE_ALL:-}" ]; then
  if [ -d "$repo/../shared/data" ]; then
    export VILMA_REQUIRE_ALL=1
    echo "test.sh: CI with ../shared/data: VILMA_REQUIRE_ALL=1 (a skipped test fails)"
  else
    echo "test.sh: CI without ../shared/data: tests that need it are reported as skipped"
  fi
fi

cd "$build"
ctest --output-on-failure -j "${VILMA_JOBS:-2}" --timeout 600 "$@"
