#!/bin/bash
# Replays the bundled EuRoC slice over LCM on loopback to vilma-lcm-rates and prints, per mode,
# the messages/s and MB/s sent and the messages lost by the receiver. Results: docs/benchmarks.md
# ("Replay over LCM loopback").
#
# Usage: scripts/bench-replay.sh [DATASET] [END_S]
#   DATASET  default $VILMA_SHARED_DATA_DIR/euroc_V1_01_micro (../shared/data beside the repo)
#   END_S    seconds of the dataset to replay (default 4.75: all 95 stereo pairs)
#   VILMA_BUILD_DIR  build folder with bin/vilma-replay, bin/vilma-lcm-rates (default <repo>/build)
#   BENCH_REPEAT     runs per mode (default 1)
set -euo pipefail

repo_dir=$(cd "$(dirname "$0")/.." && pwd)
build_dir=${VILMA_BUILD_DIR:-$repo_dir/build}
data_dir=${VILMA_SHARED_DATA_DIR:-$repo_dir/../shared/data}
dataset=${1:-$data_dir/euroc_V1_01_micro}
end_s=${2:-4.75}
repeat=${BENCH_REPEAT:-1}
replay=$build_dir/bin/vilma-replay
rates=$build_dir/bin/vilma-lcm-rates
for exe in "$replay" "$rates"; do
  [ -x "$exe" ] || { echo "bench-replay: $exe not built (set VILMA_BUILD_DIR)" >&2; exit 1; }
done
[ -d "$dataset/mav0" ] || { echo "bench-replay: $dataset has no mav0/" >&2; exit 1; }

work=$(mktemp -d /tmp/vilma-bench-replay.XXXXXX)
trap 'rm -rf "$work"' EXIT

# Messages in the window, from a log-file replay (no network involved).
"$replay" "$dataset" --end "$end_s" --to-log "$work/count.lcmlog" > "$work/count.out"
expected=$(awk '$1 == "total" {print $2}' "$work/count.out")
mbytes=$(awk '$1 == "total" {print $3}' "$work/count.out")

port=$(( 21000 + $$ % 20000 ))
echo "Replay of $dataset, --end $end_s: $expected messages, $mbytes MB"
echo
echo "| mode | receiver recv_buf_size | sent msg/s | sent MB/s | received | lost | lost % |"
echo "|---|---|---:|---:|---:|---:|---:|"

run() {  # run LABEL RECV_BUF_SIZE REPLAY_OPTIONS...
  local label=$1 rbuf=$2; shift 2
  port=$((port + 1))
  local url="udpm://239.255.76.67:$port?ttl=0"
  "$rates" --lcm-url "$url" --recv-buf-size "$rbuf" --quiet --expect-count "$expected" \
    --idle-timeout 2 > "$work/rates.out" 2>&1 &
  local monitor=$!
  for _ in $(seq 100); do grep -q listening "$work/rates.out" && break; sleep 0.05; done
  "$replay" "$dataset" --end "$end_s" --lcm-url "$url" "$@" > "$work/replay.out" 2>&1
  wait "$monitor" || true
  local sent_rate sent_mbps received lost
  sent_rate=$(awk '$1 == "total" {print $4}' "$work/replay.out")
  sent_mbps=$(awk '$1 == "total" {print $5}' "$work/replay.out")
  received=$(sed -n 's/^TOTAL messages=\([0-9]*\).*/\1/p' "$work/rates.out")
  lost=$((expected - received))
  printf "| %s | %s | %s | %s | %s | %s | %.1f |\n" "$label" \
    "$([ "$rbuf" = 0 ] && echo "kernel default" || echo "$rbuf")" \
    "$sent_rate" "$sent_mbps" "$received" "$lost" "$(awk -v l="$lost" -v e="$expected" 'BEGIN {print 100 * l / e}')"
}

for _ in $(seq "$repeat"); do
  run "real time (--rate 1)" 8388608 --rate 1
  run "real time (--rate 1)" 0 --rate 1
  run "--fast (default cap 100 MB/s)" 8388608 --fast
  run "--fast (default cap 100 MB/s)" 0 --fast
  run "--fast --max-mbps 0 (unpaced)" 8388608 --fast --max-mbps 0
  run "--fast --max-mbps 0 (unpaced)" 0 --fast --max-mbps 0
done
echo
echo "net.core.rmem_max = $(sysctl -n net.core.rmem_max) (recv_buf_size is capped to it)"
