#!/bin/bash
# Residual error of the drivers' clock synchronization (core/clock_sync.h) on simulated device
# clocks: 200 Hz samples for 60 s, exponential transport delay of the given mean plus 1 % delay
# spikes of 10-30 ms, drift 0 or 50 ppm, three seeds each; error = |mapped host time - true host
# time of the event| of every sample after 2 s. Deterministic (fixed seeds).
# Then, where vilma-usb-imu is built, the same filter end to end: the real driver on a
# pseudo-terminal fed by a simulated MicroStrain GX5 (200 Hz, +50 ppm clock) for 10 s: stamp
# error against the simulator's event times, estimated skew, sample-to-publish latency (this one
# depends on the machine's load).
# Prints the markdown tables of docs/drivers.md ("Clock synchronization") and docs/benchmarks.md.
#
# Usage: scripts/bench-clock-sync.sh
#   VILMA_BUILD_DIR  build folder with bin/vilma_core_tests, bin/vilma_drivers_tests and
#                    bin/vilma-usb-imu (default <repo>/build)
set -euo pipefail

repo_dir=$(cd "$(dirname "$0")/.." && pwd)
build_dir=${VILMA_BUILD_DIR:-$repo_dir/build}
tests=$build_dir/bin/vilma_core_tests
[ -x "$tests" ] || { echo "bench-clock-sync: $tests not built (set VILMA_BUILD_DIR)" >&2; exit 1; }
# The table is a hidden Catch2 test case (tag [.clock_sync_bench]) beside the unit tests, so
# that it runs the very simulator the tests assert on.
"$tests" "[.clock_sync_bench]" --success 2>&1 | grep '^|'

drivers_tests=$build_dir/bin/vilma_drivers_tests
if [ -x "$build_dir/bin/vilma-usb-imu" ] && [ -x "$drivers_tests" ]; then
  echo
  echo "vilma-usb-imu on a pty, simulated GX5 at 200 Hz, +50 ppm, 10 s:"
  echo
  "$drivers_tests" "[.usb_imu_bench]" 2>&1 | grep '^|'
else
  echo "(vilma-usb-imu not built: no end-to-end figures)" >&2
fi
