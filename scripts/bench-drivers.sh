#!/bin/bash
# Latency of the camera drivers: from a frame's end of exposure to its image_t arriving at an
# LCM subscriber on the same host (loopback), measured by vilma-frame-latency. vilma-aravis
# runs Aravis's in-process fake camera (--fake) and, where aravis-tools is installed, the fake
# GigE Vision camera on loopback; both stamp frames with this host's CLOCK_REALTIME, so no
# clock error enters the figure. vilma-v4l2 runs its in-process fake V4L2 camera (--fake),
# whose stamps are this host's CLOCK_MONOTONIC mapped to CLOCK_REALTIME. The last column is the driver's own view (buffer arrival ->
# LCM publish, from its status window). Prints the markdown
# table of docs/drivers.md ("Latency") and docs/benchmarks.md.
#
# Usage: scripts/bench-drivers.sh [SECONDS]
#   SECONDS          measurement per row (default 10)
#   VILMA_BUILD_DIR  build folder with bin/vilma-aravis, bin/vilma-v4l2, bin/vilma-frame-latency
#                    (default <repo>/build)
set -euo pipefail

repo_dir=$(cd "$(dirname "$0")/.." && pwd)
build_dir=${VILMA_BUILD_DIR:-$repo_dir/build}
seconds=${1:-10}
aravis=$build_dir/bin/vilma-aravis
v4l2=$build_dir/bin/vilma-v4l2
latency=$build_dir/bin/vilma-frame-latency
for exe in "$aravis" "$latency" "$v4l2"; do
  [ -x "$exe" ] || { echo "bench-drivers: $exe not built (needs libaravis-dev; set VILMA_BUILD_DIR)" >&2; exit 1; }
done

work=$(mktemp -d /tmp/vilma-bench-drivers.XXXXXX)
trap 'rm -rf "$work"' EXIT
port=$(( 22000 + $$ % 20000 ))

echo "| driver | source | format -> published | size | rate [Hz] | frames | latency p50 [ms] | p99 [ms] | max [ms] | driver-internal p50 / p99 [ms] |"
echo "|---|---|---|---|---:|---:|---:|---:|---:|---|"

aravis_row() {  # aravis_row SOURCE WIDTH HEIGHT RATE PIXEL_FORMAT [DRIVER OPTIONS...]
  local source=$1 w=$2 h=$3 rate=$4 format=$5; shift 5
  port=$((port + 1))
  local url="udpm://239.255.76.67:$port?ttl=0"
  # The subscriber listens a little longer than the driver publishes; the first 5 frames
  # (camera start) are left out.
  "$latency" --lcm-url "$url" --seconds "$(awk -v s="$seconds" 'BEGIN {print s + 2}')" \
    --skip 20 --min-frames 10 > "$work/latency.out" 2>&1 &
  local subscriber=$!
  sleep 0.5
  # Status every 0.5 s so that the last OK report holds the driver's own latency window.
  "$aravis" --lcm-url "$url" --width "$w" --height "$h" --frame-rate-hz "$rate" \
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
  echo "| vilma-aravis | $source | $format -> ${published%% *} | ${w}x${h} | $hz | $frames | $p50 | $p99 | $max | ${internal:-n/a} |"
}

aravis_row "in-process fake camera" 752 480 20 Mono8 --fake
aravis_row "in-process fake camera" 752 480 20 BayerRG8 --fake
aravis_row "in-process fake camera" 752 480 20 Mono16 --fake
aravis_row "in-process fake camera" 1920 1200 30 Mono8 --fake
# The GigE Vision path (GVCP/GVSP over loopback UDP) with aravis-tools' fake GigE camera.
if command -v arv-fake-gv-camera-0.8 > /dev/null; then
  arv-fake-gv-camera-0.8 --interface 127.0.0.1 --serial BENCH$$ > "$work/fake-gv.out" 2>&1 &
  fake_gv=$!
  sleep 0.5
  aravis_row "arv-fake-gv-camera (GigE Vision, loopback)" 752 480 20 Mono8 --device BENCH$$
  kill "$fake_gv"
  wait "$fake_gv" 2> /dev/null || true
fi

# vilma-v4l2 with its in-process fake camera (--fake): V4L2 semantics (mmap ring, DQBUF,
# start-of-exposure stamps on CLOCK_MONOTONIC), the conversion to GRAY8 (MJPG: decoded).
v4l2_row() {  # v4l2_row FOURCC WIDTH HEIGHT RATE
  local format=$1 w=$2 h=$3 rate=$4
  port=$((port + 1))
  local url="udpm://239.255.76.67:$port?ttl=0"
  "$latency" --lcm-url "$url" --seconds "$(awk -v s="$seconds" 'BEGIN {print s + 2}')" \
    --skip 20 --min-frames 10 > "$work/latency.out" 2>&1 &
  local subscriber=$!
  sleep 0.5
  "$v4l2" --fake --lcm-url "$url" --formats "$format" --size "${w}x${h}" --fps "$rate" \
    --require-size --require-fps --exposure 10000 --seconds "$seconds" > "$work/v4l2.out" 2>&1
  wait "$subscriber" || { cat "$work/latency.out" "$work/v4l2.out" >&2; return 1; }
  local line frames hz p50 p99 max internal
  line=$(grep '^channel' "$work/latency.out")
  frames=$(sed -n 's/.*: \([0-9]*\) frames.*/\1/p' <<< "$line")
  hz=$(sed -n 's/.* frames, \([0-9.]*\) Hz.*/\1/p' <<< "$line")
  p50=$(sed -n 's/.*p50 \([0-9.]*\) ms.*/\1/p' <<< "$line")
  p99=$(sed -n 's/.*p99 \([0-9.]*\) ms.*/\1/p' <<< "$line")
  max=$(sed -n 's/.*max \([0-9.-]*\) ms.*/\1/p' <<< "$line")
  internal=$(sed -n 's/.*latency to publish p50 \([0-9.]*\) ms, p99 \([0-9.]*\) ms.*/\1 \/ \2/p' "$work/v4l2.out")
  echo "| vilma-v4l2 | in-process fake camera | $format -> GRAY8 | ${w}x${h} | $hz | $frames | $p50 | $p99 | $max | ${internal:-n/a} |"
}

v4l2_row GREY 752 480 20
v4l2_row GREY 640 480 60
v4l2_row Y16 640 480 30
v4l2_row YUYV 640 480 30
v4l2_row MJPG 640 480 30
v4l2_row MJPG 1280 720 30
