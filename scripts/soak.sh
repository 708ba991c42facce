#!/bin/bash
# Soak test (issue 18, docs/reliability.md "Soak"): the live pipeline for N minutes.
#   vilma-sim --live (room, session 1: an endless smooth path through the simulated room)
#     -> vilma-estimatord in LOC mode (a localization map of session 0) with map building,
#        streaming the mission to vilma-mapstored
# Every 10 s it samples, for each process, RSS (/proc/<pid>/status VmRSS; RssAnon too) and CPU % of one core
# (utime + stime from /proc/<pid>/stat over the interval), and the load average; the daemon's and
# mapstored's VILMA_STATUS reports (recorded with lcm-logger, read with vilma-lcm-json) add queue
# depths, drops and latency p99. Results in ~/.cache/vilma/soak/<UTC date-time>/:
#   soak.csv (one row per 10 s), soak.png (plot), report.txt (the table), machine.txt (the
#   kernel's sched_autogroup setting: see below), logs.
# The table: RSS at 5 min and at the end (growth %), CPU median, drops, latency p99 per 10-min
# window, and PASS/FAIL against issue 18's target (RSS growth <= 5 % after the first 5 minutes,
# no drop, latency p99 stable: every window's p99 <= 1.5 x the first window's + 2 ms).
#
# Usage: scripts/soak.sh [--minutes N] [--no-mapping] [--rate R]
#   --minutes N    length of the run (default 60; runs shorter than 10 min take the RSS baseline
#                  at half the run instead of at 5 min)
#   --no-mapping   LOC mode without map building / streaming (tells leaks from the map's growth)
#   --rate R       vilma-sim's playback speed factor (default 1 = real time)
#   VILMA_BUILD_DIR  build folder (default <repo>/build); VILMA_SOAK_DIR output root
#   (default ~/.cache/vilma/soak). Exit status 0 on PASS, 1 on FAIL or an error, 2 bad options.
set -euo pipefail

repo_dir=$(cd "$(dirname "$0")/.." && pwd)
bin=${VILMA_BUILD_DIR:-$repo_dir/build}/bin
root=${VILMA_SOAK_DIR:-$HOME/.cache/vilma/soak}
minutes=60
mapping=1
rate=1
while [ $# -gt 0 ]; do
  case "$1" in
    --minutes) minutes=${2:-}; shift 2 ;;
    --no-mapping) mapping=0; shift ;;
    --rate) rate=${2:-}; shift 2 ;;
    -h|--help) sed -n '2,/^set -euo/p' "$0" | sed '$d' | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "soak.sh: unknown argument $1 (see --help)" >&2; exit 2 ;;
  esac
done
[[ "$minutes" =~ ^[0-9]+$ ]] && [ "$minutes" -ge 1 ] ||
  { echo "soak.sh: --minutes: expected a positive integer, got '$minutes'" >&2; exit 2; }
[[ "$rate" =~ ^[0-9]+(\.[0-9]+)?$ ]] ||
  { echo "soak.sh: --rate: expected a positive number, got '$rate'" >&2; exit 2; }
for p in vilma-sim vilma-estimatord vilma-mapstored vilma-locmap-gt vilma-lcm-json; do
  [ -x "$bin/$p" ] || { echo "soak.sh: $bin/$p not built" >&2; exit 1; }
done
command -v lcm-logger > /dev/null || { echo "soak.sh: lcm-logger not found (Debian liblcm-bin)" >&2; exit 1; }
# Debian's python3 (python3-matplotlib) even when another python3 comes first in PATH.
python=python3
[ -x /usr/bin/python3 ] && python=/usr/bin/python3
"$python" -c "import matplotlib" 2> /dev/null ||
  { echo "soak.sh: $python has no matplotlib (Debian python3-matplotlib, scripts/debian-packages.txt)" >&2; exit 1; }

out=$root/$(date -u +%Y-%m-%dT%H%M%S)
prep=$root/prep
mkdir -p "$out/bin" "$prep"
# Private copies: a rebuild by someone else during the run must not stop or change it.
for p in vilma-sim vilma-estimatord vilma-mapstored vilma-lcm-json; do cp "$bin/$p" "$out/bin/"; done
bin_run=$out/bin

# The localization map: session 0 of the same room (20 s) with its ground-truth states.
if [ ! -f "$prep/room0.vlocmap" ]; then
  rm -rf "$prep/room0"
  "$bin/vilma-sim" room --session 0 --seed 1 --seconds 20 --out "$prep/room0" > "$prep/sim0.log"
  "$bin/vilma-locmap-gt" "$prep/room0" "$prep/room0.vlocmap.tmp" > "$prep/locmap.log"
  mv "$prep/room0.vlocmap.tmp" "$prep/room0.vlocmap"
fi

port=$(( 30000 + $$ % 20000 ))
url="udpm://239.255.76.67:$port?ttl=0&recv_buf_size=8388608"
config=$out/daemon.yaml
cp "$repo_dir/config/daemon.yaml" "$config"
if [ "$mapping" -eq 1 ]; then
  # config/daemon.yaml with map building and the stream on (the same edits as the tests).
  sed -i -e 's/^  enabled: false          # run the map-builder/  enabled: true           # run the map-builder/' \
         -e '/^  stream:/,/^    enabled:/ s/^    enabled: false/    enabled: true/' \
         -e 's/^  mission_name: ""/  mission_name: "soak"/' "$config"
  grep -q '^  enabled: true           # run the map-builder' "$config" &&
    grep -q '^    enabled: true' "$config" ||
    { echo "soak.sh: config/daemon.yaml changed: could not turn mapping and streaming on" >&2; exit 1; }
fi

pids=()
cleanup() {
  for pid in "${pids[@]}"; do kill -TERM "$pid" 2> /dev/null || true; done
  wait 2> /dev/null || true
}
trap cleanup EXIT
trap 'exit 1' INT TERM

lcm-logger --lcm-url="$url" --channel='VILMA_STATUS.*' --quiet "$out/status.lcmlog" \
  > "$out/logger.log" 2>&1 &
logger=$!; pids+=("$logger")
"$bin_run/vilma-mapstored" --root "$out/maps" --lcm-url "$url" > "$out/mapstored.log" 2>&1 &
store=$!; pids+=("$store")
for _ in $(seq 100); do grep -q ready "$out/mapstored.log" && break; sleep 0.1; done
"$bin_run/vilma-estimatord" --config "$config" --rig "$prep/room0/rig.yaml" --lcm-url "$url" \
  --localization-map "$prep/room0.vlocmap" > "$out/daemon.log" 2>&1 &
daemon=$!; pids+=("$daemon")
sleep 2
# 30 s more than the soak, so that the sim does not end before the last sample; vilma-sim
# simulates at most 3600 s, so a 60-min soak samples until 59:50.
sim_seconds=$(( minutes * 60 + 30 > 3600 ? 3600 : minutes * 60 + 30 ))
"$bin_run/vilma-sim" room --session 1 --seed 1 --seconds $sim_seconds --live \
  --rate "$rate" --lcm-url "$url" > "$out/sim.log" 2>&1 &
sim=$!; pids+=("$sim")

# CPU ticks (utime + stime), RSS and its anonymous part (RssAnon: heap and stacks, without the
# resident pages of mapped files such as the shared libraries) [kB] of a process; "0 0 0" once
# it is gone.
proc_sample() {
  local stat mem
  stat=$(cat "/proc/$1/stat" 2> /dev/null) || { echo "0 0 0"; return; }
  stat=${stat##*) }  # the fields after "(comm) ", which may hold spaces
  mem=$(awk '/^VmRSS:/ { r = $2 } /^RssAnon:/ { a = $2 } END { print r + 0, a + 0 }' \
    "/proc/$1/status" 2> /dev/null || echo "0 0")
  awk -v mem="$mem" '{ print $12 + $13, mem }' <<< "$stat"
}
tck=$(getconf CLK_TCK)
names=(sim daemon mapstored)
procs=("$sim" "$daemon" "$store")
header="t_s,wall_us,load1"
for n in "${names[@]}"; do header+=",${n}_rss_mb,${n}_cpu_pct"; done
for n in "${names[@]}"; do header+=",${n}_anon_mb"; done
echo "$header" > "$out/proc.csv"
declare -A last_ticks
for i in "${!procs[@]}"; do read -r t _ _ < <(proc_sample "${procs[$i]}"); last_ticks[$i]=$t; done
start_ns=$(date +%s%N); last_ns=$start_ns
echo "soak.sh: $minutes min, output in $out (load average now: $(cut -d' ' -f1-3 /proc/loadavg))"
# With the kernel's autogroups on (as on this machine), every session (terminal, ssh login, job
# started with setsid) is one scheduling group with an equal share of the CPU: nice and
# SCHED_IDLE of other sessions' processes then do not yield to the soak. Measured 2026-11-27:
# beside SCHED_IDLE work of two other sessions, 927 drops in 40 min and p99 up to 1.9 s; after
# autogroups were turned off mid-run, 9 drops in the next 10 min, then none, p99 median 10.7 ms.
# Recorded in machine.txt and the report, and warned about.
autogroup=$(cat /proc/sys/kernel/sched_autogroup_enabled 2> /dev/null || echo "n/a")
echo "kernel.sched_autogroup_enabled=$autogroup, soak processes at nice $(nice)" > "$out/machine.txt"
if [ "$autogroup" = "1" ]; then
  echo "soak.sh: warning: kernel.sched_autogroup_enabled=1: processes of other sessions get an equal" \
       "share of the CPU whatever their nice or SCHED_IDLE; run the soak on an idle machine or" \
       "disable autogroups (root: sysctl kernel.sched_autogroup_enabled=0)" >&2
fi
samples=$(( minutes * 6 < (sim_seconds - 5) / 10 ? minutes * 6 : (sim_seconds - 5) / 10 ))
for k in $(seq 1 "$samples"); do
  target_ns=$(( start_ns + k * 10000000000 ))
  now_ns=$(date +%s%N)
  [ "$now_ns" -lt "$target_ns" ] && sleep "$(awk "BEGIN { print ($target_ns - $now_ns) / 1e9 }")"
  now_ns=$(date +%s%N)
  row="$(( (now_ns - start_ns) / 1000000000 )),$(( now_ns / 1000 )),$(cut -d' ' -f1 /proc/loadavg)"
  anon_columns=""
  for i in "${!procs[@]}"; do
    read -r ticks rss anon < <(proc_sample "${procs[$i]}")
    cpu=$(awk -v d=$(( ticks - ${last_ticks[$i]} )) -v w=$(( now_ns - last_ns )) -v t="$tck" \
      'BEGIN { printf "%.1f", (w > 0 ? 100 * d / t / (w / 1e9) : 0) }')
    last_ticks[$i]=$ticks
    row+=",$(awk -v r="$rss" 'BEGIN { printf "%.1f", r / 1024 }'),$cpu"
    anon_columns+=",$(awk -v r="${anon:-0}" 'BEGIN { printf "%.1f", r / 1024 }')"
  done
  row+=$anon_columns
  last_ns=$now_ns
  echo "$row" >> "$out/proc.csv"
  for i in "${!procs[@]}"; do
    kill -0 "${procs[$i]}" 2> /dev/null ||
      { echo "soak.sh: ${names[$i]} exited early (see $out/${names[$i]}.log)" >&2; exit 1; }
  done
  [ $((k % 30)) -eq 0 ] && echo "soak.sh: $((k / 6)) min: $(tail -1 "$out/proc.csv")"
done

# Stop: the simulator first, then the daemon (flushes and ends the mission), mapstored, logger.
kill -TERM "$sim" 2> /dev/null || true; wait "$sim" 2> /dev/null || true
kill -TERM "$daemon" 2> /dev/null || true
daemon_status=0; wait "$daemon" || daemon_status=$?
sleep 1
kill -TERM "$store" 2> /dev/null || true; wait "$store" 2> /dev/null || true
kill -INT "$logger" 2> /dev/null || true; wait "$logger" 2> /dev/null || true
trap - EXIT
[ "$daemon_status" -eq 0 ] || echo "soak.sh: vilma-estimatord exited with $daemon_status" >&2

"$bin_run/vilma-lcm-json" "$out/status.lcmlog" --channels 'VILMA_STATUS' > "$out/status.jsonl"
verdict=0
"$python" "$repo_dir/scripts/soak_report.py" --proc "$out/proc.csv" --status "$out/status.jsonl" \
  --csv "$out/soak.csv" --plot "$out/soak.png" --minutes "$minutes" \
  --title "$([ "$mapping" -eq 1 ] && echo "sim -> estimatord (LOC + mapping) -> mapstored" ||
             echo "sim -> estimatord (LOC, no mapping)")" | tee "$out/report.txt" || verdict=$?
echo "machine: $(cat "$out/machine.txt"), $(nproc) cores" | tee -a "$out/report.txt"
exit "$verdict"
