#!/usr/bin/env bash
# Installs what is missing, builds, and runs the whole test suite (ctest). Ends with ctest's
# summary; exits non-zero when a test fails. Extra arguments go to ctest (e.g. -L core).
set -euo pipefail
repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${VILMA_BUILD_DIR:-$repo/build}"
"$repo/scripts/setup.sh"
cd "$build"
ctest --output-on-failure -j "${VILMA_JOBS:-2}" --timeout 600 "$@"
