#!/bin/bash
# Latency of the camera drivers: from a frame's end of exposure (the buffer's arrival stamp on
# the host) to its image_t arriving at an LCM subscriber on the same host (loopback), measured
# by vilma-frame-latency. vilma-aravis runs Aravis's in-process fake camera (--fake), whose
# clock is this host's CLOCK_REALTIME, so no clock error enters the figure. Prints the markdown
# table of docs/drivers.md ("Latency") and docs/benchmarks.md.
#
# Usage: scripts/bench-drivers.sh [SECONDS]
#   SECONDS          measurement per row (default 10)
#   VILMA_BUILD_DIR  build folder with bin/vilma-aravis, bin/vilma-frame-latency (default <repo>/build)
set -euo pipefail

repo_dir=$(cd "$(dirname "$0")/.." && pwd)
build_dir=${VILMA_BUILD_DIR:-$repo_dir/build}
seconds=${1:-10}
aravis=$build_dir/bin/vilma-aravis
latency=$build_dir/bin/vilma-frame-latency
for exe in "$aravis" "$latency"; do
  [ -x "$exe" ] || { echo "bench-drivers: $exe not built (needs libaravis-dev; set VILMA_BUILD_DIR)" >&2; exit 1; }
done

work=$(mktemp -d /tmp/vilma-bench-drivers.XXXXXX)
trap 'rm -rf "$work"' EXIT
port=$(( 22000 + $$ % 20000 ))

echo "| driver | source | format -> published | size | rate [Hz] | frames | latency p50 [ms] | p99 [ms] | max [ms] | driver-internal p50 / p99 [ms] |"
echo "|---|---|---|---|---:|---:|---:|---:|---:|---|"

aravis_row() {  # aravis_row WIDTH HEIGHT RATE PIXEL_FORMAT [DRIVER OPTIONS...]
  local w=$1 h=$2 rate=$3 format=$4; shift 4
  port=$((port + 1))
  local url="udpm://239.255.76.67:$port?ttl=0"
  # The subscriber listens a little longer than the driver publishes; the first 5 frames
  # (camera start) are left out.
  "$latency" --lcm-url "$url" --seconds "$(awk -v s="$seconds" 'BEGIN {print s + 2}')" \
    --min-frames 10 > "$work/latency.out" 2>&1 &
  local subscriber=$!
  sleep 0.5
  # Status every 0.5 s so that the last OK report holds the driver's own latency window.
  "$aravis" --fake --lcm-url "$url" --width "$w" --height "$h" --frame-rate-hz "$rate" \
    --pixel-format "$format" --exposure-us 10000 --gain 0 --seconds "$seconds" "$@" \
    > "$work/aravis.out" 2>&1
  wait "$subscriber" || { cat "$work/latency.out" >&2; return 1; }
  local line frames hz p50 p99 max
  line=$(grep '^channel' "$work/latency.out")
  frames=$(sed -n 's/.*: \([0-9]*\) frames.*/\1/p' <<< "$line")
  hz=$(sed -n 's/.* frames, \([0-9.]*\) Hz.*/\1/p' <<< "$line")
  p50=$(sed -n 's/.*p50 \([0-9.]*\) ms.*/\1/p' <<< "$line")
  p99=$(sed -n 's/.*p99 \([0-9.]*\) ms.*/\1/p' <<< "$line")
  max=$(sed -n 's/.*max \([0-9.-]*\) ms.*/\1/p' <<< "$line")
  local internal
  internal=$(sed -n 's/.*latency to publish p50 \([0-9.]*\) ms, p99 \([0-9.]*\) ms.*/\1 \/ \2/p' "$work/aravis.out")
  local published
  published=$([ "$format" = Mono8 ] && echo GRAY8 || echo "GRAY8 ($format converted)")
  echo "| vilma-aravis | fake camera | $format -> ${published%% *} | ${w}x${h} | $hz | $frames | $p50 | $p99 | $max | ${internal:-n/a} |"
}

aravis_row 752 480 20 Mono8
aravis_row 752 480 20 BayerRG8
aravis_row 752 480 20 Mono16
aravis_row 1920 1200 30 Mono8
