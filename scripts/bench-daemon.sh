#!/bin/bash
# Realtime benchmark of vilma-estimatord: a simulated set (one camera 752x480 at 20 Hz, IMU at
# 200 Hz) replayed in real time over LCM loopback -> daemon; a probe process on the same host
# measures the end-to-end latency per frame = (receive time of VILMA_ODOM) - (receive time of the
# image with the same utime on CAM0), both on its own clock (vilma-replay stamps messages with
# dataset time, so utime cannot be compared with the wall clock). CPU load of the daemon from
# /proc/PID/stat over the replay, and from its VILMA_STATUS. Results: docs/benchmarks.md
# ("Daemon").
#
# Usage: scripts/bench-daemon.sh [SECONDS] [PRESET]
#   SECONDS  length of the simulated set (default 30), PRESET vilma-sim world (default room)
#   VILMA_BUILD_DIR  build folder with bin/vilma-{estimatord,replay,sim,latency-probe}
#   VILMA_CACHE      where the simulated set is kept (default ~/.cache/vilma)
#   BENCH_REPEAT     runs (default 1)
#   BENCH_MAPPING    1: run the daemon with map building (--save-map into a scratch folder) and
#                    add the map columns: vertices, vertex rate sustained over the replay,
#                    frames dropped towards the builder, builder time per vertex, and the
#                    time from SIGTERM to exit (pipeline flush + Finish + save)
#                    (docs/benchmarks.md "Map building in the daemon")
#   BENCH_LOC        1: run the daemon in LOC mode against a localization map of the same
#                    simulated set made from its ground truth (vilma-locmap-gt), and add the
#                    localization columns: attempts, busy (skipped while the localizer worked),
#                    accepted, VILMA_POSE frames, localizer stage p50 / max
#                    (docs/benchmarks.md "Localization in the daemon")
#   BENCH_STEREO     1: the set rendered with cam1 too (vilma-sim --stereo) and the daemon run with
#                    --stereo (both cameras in the filter and, with BENCH_MAPPING, in the map)
#   BENCH_DAEMON_CONFIG  a daemon config (--config) for the runs, e.g. mapping.map_builder with track_refinement
#                    method "none" (no track refinement; docs/mapping.md "Track refinement"); default the built-in
#   BENCH_BEFORE_ESTIMATORD  another vilma-estimatord binary (e.g. the pre-split daemon of issue
#                    19, ~/.cache/vilma/issue19/baseline-bin/vilma-estimatord): each repeat runs it
#                    ("before") and then this build's ("after") on the same set with the same
#                    other programs, so both see the same machine load (ABAB...); rows carry the
#                    label and the 1-min load average at their start, and a last table gives the
#                    medians and the after/before ratios (docs/benchmarks.md "Daemon")
set -euo pipefail

repo_dir=$(cd "$(dirname "$0")/.." && pwd)
build_dir=${VILMA_BUILD_DIR:-$repo_dir/build}
cache=${VILMA_CACHE:-$HOME/.cache/vilma}
seconds=${1:-30}
preset=${2:-room}
repeat=${BENCH_REPEAT:-1}
mapping=${BENCH_MAPPING:-0}
loc=${BENCH_LOC:-0}
before_exe=${BENCH_BEFORE_ESTIMATORD:-}
bin=$build_dir/bin
if [ -n "$before_exe" ] && [ ! -x "$before_exe" ]; then
  echo "bench-daemon: BENCH_BEFORE_ESTIMATORD=$before_exe is not an executable" >&2; exit 1
fi
labels=current
[ -n "$before_exe" ] && labels="before after"
for exe in vilma-estimatord vilma-replay vilma-sim vilma-latency-probe; do
  [ -x "$bin/$exe" ] || { echo "bench-daemon: $bin/$exe not built (set VILMA_BUILD_DIR)" >&2; exit 1; }
done

stereo_args=()
dataset=$cache/bench-daemon/$preset-${seconds}s
if [ "${BENCH_STEREO:-0}" = 1 ]; then
  stereo_args=(--stereo)
  dataset=$dataset-stereo
fi
# Remade when the simulator's output changes (make-datasets.sh's SIM_VERSION).
sim_key="version=$(sed -n 's/^SIM_VERSION=//p' "$repo_dir/scripts/make-datasets.sh")"
if [ ! -f "$dataset/rig.yaml" ] || [ "$(cat "$dataset/.vilma-sim-key" 2>/dev/null)" != "$sim_key" ]
then
  echo "bench-daemon: simulating $preset, $seconds s -> $dataset" >&2
  rm -rf "$dataset"
  "$bin/vilma-sim" "$preset" --out "$dataset" --seconds "$seconds" --seed 1 "${stereo_args[@]}" \
    > /dev/null
  echo "$sim_key" > "$dataset/.vilma-sim-key"
fi

work=$(mktemp -d /tmp/vilma-bench-daemon.XXXXXX)
daemon_pid=""
cleanup() {
  [ -n "$daemon_pid" ] && kill "$daemon_pid" 2>/dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT

loc_args=()
if [ "$loc" = 1 ]; then
  [ -x "$bin/vilma-locmap-gt" ] || { echo "bench-daemon: $bin/vilma-locmap-gt not built" >&2; exit 1; }
  locmap=$dataset.vlocmap
  if [ ! -f "$locmap" ] || [ "$dataset/rig.yaml" -nt "$locmap" ]; then
    "$bin/vilma-locmap-gt" "$dataset" "$locmap" >&2
  fi
  loc_args=(--localization-map "$locmap")
fi

ticks=$(getconf CLK_TCK)
cpu_ticks() { awk '{print $14 + $15}' "/proc/$1/stat"; }

if [ "$loc" = 1 ]; then
  echo "| set | frames | matched | latency p50 [ms] | p99 [ms] | max [ms] | daemon CPU (/proc) | drops | loc attempts | busy | accepted | VILMA_POSE frames | stage p50 / max [ms] |"
  echo "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
elif [ "$mapping" = 1 ]; then
  echo "| set | frames | matched | latency p50 [ms] | p99 [ms] | max [ms] | daemon CPU (/proc) | drops | vertices | vertex rate [Hz] | map frames dropped | builder per vertex mean / max [ms] | SIGTERM to exit [s] |"
  echo "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
else
  echo "| set | frames | matched | latency p50 [ms] | p99 [ms] | max [ms] | daemon CPU (/proc) | daemon CPU (status) | drops | malformed |"
  echo "|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
fi
# A table row, also kept for the medians of BENCH_BEFORE_ESTIMATORD.
row() { printf "$@" | tee -a "$work/rows"; }
port=$(( 22000 + $$ % 20000 ))
for _ in $(seq "$repeat"); do
for label in $labels; do
  estimatord=$bin/vilma-estimatord
  [ "$label" = before ] && estimatord=$before_exe
  set_label="$preset $seconds s"
  [ "${BENCH_STEREO:-0}" = 1 ] && set_label="$set_label stereo"
  [ "$label" != current ] && set_label="$set_label $label, load $(cut -d' ' -f1 /proc/loadavg)"
  port=$((port + 1))
  url="udpm://239.255.76.67:$port?ttl=0"
  map_args=()
  if [ "$mapping" = 1 ]; then rm -rf "$work/map"; map_args=(--save-map "$work/map"); fi
  config_args=()
  [ -n "${BENCH_DAEMON_CONFIG:-}" ] && config_args=(--config "$BENCH_DAEMON_CONFIG")
  "$estimatord" "${config_args[@]}" --rig "$dataset/rig.yaml" --lcm-url "$url" "${map_args[@]}" \
    "${loc_args[@]}" "${stereo_args[@]}" > "$work/daemon.out" 2>&1 &
  daemon_pid=$!
  "$bin/vilma-latency-probe" --lcm-url "$url" --idle-timeout 2 > "$work/probe.out" 2>&1 &
  probe_pid=$!
  for _ in $(seq 100); do grep -q listening "$work/probe.out" && break; sleep 0.05; done
  sleep 1  # the daemon subscribes and reports its first status
  c0=$(cpu_ticks "$daemon_pid"); t0=$(date +%s.%N)
  "$bin/vilma-replay" "$dataset" --lcm-url "$url" --quiet > "$work/replay.out" 2>&1
  c1=$(cpu_ticks "$daemon_pid"); t1=$(date +%s.%N)
  wait "$probe_pid"
  s0=$(date +%s.%N)
  kill -TERM "$daemon_pid"; wait "$daemon_pid" || true; daemon_pid=""
  s1=$(date +%s.%N)
  cpu=$(awk -v c0="$c0" -v c1="$c1" -v t0="$t0" -v t1="$t1" -v hz="$ticks" \
    'BEGIN {printf "%.0f%%", 100 * (c1 - c0) / hz / (t1 - t0)}')
  get() { awk -v k="$1" '$1 == k {print $2}' "$work/probe.out"; }
  lat() { awk -v k="$1" '$1 == "latency_ms" {for (i = 2; i < NF; i += 2) if ($i == k) print $(i + 1)}' "$work/probe.out"; }
  matched=$(awk '$1 == "images" {print $6}' "$work/probe.out")
  frames=$(awk '$1 == "images" {print $4}' "$work/probe.out")
  status_cpu=$(awk '$1 == "status_cpu_load" {printf "%.0f%%", 100 * $2}' "$work/probe.out")
  rep() { awk -v k="$1" '$1 == k {print $2}' "$work/daemon.out"; }
  if [ "$loc" = 1 ]; then
    stage=$(awk -v m="$(rep loc_stage_us_p50)" -v x="$(rep loc_stage_us_max)" 'BEGIN {printf "%.1f / %.1f", m / 1000, x / 1000}')
    row "| %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s |\n" "$set_label" \
      "$frames" "$matched" "$(lat p50)" "$(lat p99)" "$(lat max)" "$cpu" "$(get drops)" \
      "$(rep loc_attempts)" "$(rep loc_busy)" "$(rep loc_tgm_updates)" "$(rep loc_poses_published)" "$stage"
  elif [ "$mapping" = 1 ]; then
    rep() { awk -v k="$1" '$1 == k {print $2}' "$work/daemon.out"; }
    vertices=$(rep map_vertices)
    rate=$(awk -v v="$vertices" -v t0="$t0" -v t1="$t1" 'BEGIN {printf "%.1f", v / (t1 - t0)}')
    per_vertex=$(awk -v m="$(rep map_vertex_us_mean)" -v x="$(rep map_vertex_us_max)" 'BEGIN {printf "%.1f / %.1f", m / 1000, x / 1000}')
    stop_s=$(awk -v a="$s0" -v b="$s1" 'BEGIN {printf "%.2f", b - a}')
    row "| %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s | %s |\n" "$set_label" \
      "$frames" "$matched" "$(lat p50)" "$(lat p99)" "$(lat max)" "$cpu" "$(get drops)" "$vertices" \
      "$rate" "$(rep map_frames_dropped)" "$per_vertex" "$stop_s"
    grep '^vilma-estimatord: map:' "$work/daemon.out" >&2 || true
  else
    row "| %s | %s | %s | %s | %s | %s | %s | %s | %s | %s |\n" "$set_label" "$frames" \
      "$matched" "$(lat p50)" "$(lat p99)" "$(lat max)" "$cpu" "$status_cpu" "$(get drops)" \
      "$(get malformed_messages)"
  fi
done
done
if [ -n "$before_exe" ]; then
  # Medians per label of latency p50 / p99 / max and /proc CPU, and after / before.
  echo
  echo "| medians of $repeat runs each | latency p50 [ms] | p99 [ms] | max [ms] | daemon CPU (/proc) |"
  echo "|---|---:|---:|---:|---:|"
  awk -F'|' '
    function median(list, n,   a, i, j, t) {
      n = split(list, a, " ")
      for (i = 2; i <= n; i++) for (j = i; j > 1 && a[j - 1] > a[j]; j--) { t = a[j]; a[j] = a[j - 1]; a[j - 1] = t }
      return n % 2 ? a[(n + 1) / 2] : (a[n / 2] + a[n / 2 + 1]) / 2
    }
    $2 ~ / before,| after,/ {
      l = ($2 ~ / before,/) ? "before" : "after"
      p50[l] = p50[l] " " $5; p99[l] = p99[l] " " $6; mx[l] = mx[l] " " $7
      cpu = $8; gsub(/[ %]/, "", cpu); c[l] = c[l] " " cpu
    }
    END {
      for (k = 1; k <= 2; k++) {
        l = k == 1 ? "before" : "after"
        m[l, 1] = median(p50[l]); m[l, 2] = median(p99[l]); m[l, 3] = median(mx[l]); m[l, 4] = median(c[l])
        printf "| %s | %.2f | %.2f | %.2f | %.0f%% |\n", l, m[l, 1], m[l, 2], m[l, 3], m[l, 4]
      }
      printf "| after / before | %.2f | %.2f | %.2f | %.2f |\n", m["after", 1] / m["before", 1],
        m["after", 2] / m["before", 2], m["after", 3] / m["before", 3], m["after", 4] / m["before", 4]
    }' "$work/rows"
fi
