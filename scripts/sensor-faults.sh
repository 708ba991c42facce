#!/bin/bash
# Sensor faults measured (issue 18, docs/reliability.md "Sensor faults"): a simulated room
# session (30 s, mono, ground truth) is replayed live over LCM loopback into vilma-estimatord,
# once clean and once per fault injected by vilma-replay --fault at 15 s (the filter tracks by
# then): camera silent 2 s, IMU gap 0.5 s, a timestamp jump of +2 s that returns after 1 s,
# a permanent jump forward (+2 s) and one back (-2 s), a duplicated burst of 1 s, the camera at
# half rate for 5 s. lcm-logger records IMU, VILMA_ODOM and VILMA_STATUS; for each fault the
# table gives the time from the fault's end (wall clock, when the replay sent it) to the next
# valid pose (VILMA_ODOM status TRACKING), the pose statuses and the daemon's states and
# messages during the fault, the counters that moved, and the position difference to the clean
# run at the first pose after the fault and at the end. Target: recovery < 1 s.
#
# Usage: scripts/sensor-faults.sh [--rate R] [--start S]
#   --rate R   replay speed factor (default 1 = real time)
#   --start S  fault start, seconds after the dataset's first stamp (default 15)
#   VILMA_BUILD_DIR build folder (default <repo>/build); output in
#   ~/.cache/vilma/sensor-faults/<UTC date-time>/ (table in report.md). Exit status 0 when every
#   fault recovered within 1 s, 1 otherwise or on an error, 2 on bad options.
set -euo pipefail

repo_dir=$(cd "$(dirname "$0")/.." && pwd)
bin=${VILMA_BUILD_DIR:-$repo_dir/build}/bin
root=$HOME/.cache/vilma/sensor-faults
rate=1
start=15
while [ $# -gt 0 ]; do
  case "$1" in
    --rate) rate=${2:-}; shift 2 ;;
    --start) start=${2:-}; shift 2 ;;
    -h|--help) sed -n '2,/^set -euo/p' "$0" | sed '$d' | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "sensor-faults.sh: unknown argument $1 (see --help)" >&2; exit 2 ;;
  esac
done
for n in "$rate" "$start"; do
  [[ "$n" =~ ^[0-9]+(\.[0-9]+)?$ ]] ||
    { echo "sensor-faults.sh: expected a non-negative number, got '$n'" >&2; exit 2; }
done
for p in vilma-sim vilma-replay vilma-estimatord vilma-lcm-json; do
  [ -x "$bin/$p" ] || { echo "sensor-faults.sh: $bin/$p not built" >&2; exit 1; }
done
command -v lcm-logger > /dev/null ||
  { echo "sensor-faults.sh: lcm-logger not found (Debian liblcm-bin)" >&2; exit 1; }
python=python3
[ -x /usr/bin/python3 ] && python=/usr/bin/python3

out=$root/$(date -u +%Y-%m-%dT%H%M%S)
mkdir -p "$out/bin"
for p in vilma-replay vilma-estimatord vilma-lcm-json; do cp "$bin/$p" "$out/bin/"; done
dataset=$root/room30
if [ ! -f "$dataset/mav0/state_groundtruth_estimate0/data.csv" ]; then
  rm -rf "$dataset"
  "$bin/vilma-sim" room --session 0 --seed 1 --seconds 30 --out "$dataset" > "$root/sim.log"
fi

# name | --fault value ("" = clean) | fault end after the dataset's first stamp [s]
end_jump=$(awk "BEGIN { print $start + 1 }")
faults=(
  "clean||"
  "camera silent 2 s|camera-drop:$start:2|$(awk "BEGIN { print $start + 2 }")"
  "IMU gap 0.5 s|imu-gap:$start:0.5|$(awk "BEGIN { print $start + 0.5 }")"
  "stamps +2 s for 1 s, then back|time-jump:$start:1:2|$end_jump"
  "stamps jump forward 2 s (permanent)|time-jump:$start:1000:2|$start"
  "stamps jump back 2 s (permanent)|time-jump:$start:1000:-2|$start"
  "duplicated burst 1 s (IMU and images)|duplicate:$start:1|$(awk "BEGIN { print $start + 1 }")"
  "camera at half rate 5 s|camera-half-rate:$start:5|$(awk "BEGIN { print $start + 5 }")"
)

port=$(( 51000 + $$ % 5000 ))
url="udpm://239.255.76.67:$port?ttl=0&recv_buf_size=8388608"
echo "sensor-faults.sh: output in $out (load average $(cut -d' ' -f1-3 /proc/loadavg))"
: > "$out/runs.txt"
k=0
for entry in "${faults[@]}"; do
  IFS='|' read -r name fault fault_end <<< "$entry"
  run=$out/run$k
  mkdir -p "$run"
  lcm-logger --lcm-url="$url" --channel='IMU|VILMA_ODOM|VILMA_STATUS' --quiet "$run/bus.lcmlog" \
    > "$run/logger.log" 2>&1 &
  logger=$!
  "$out/bin/vilma-estimatord" --rig "$dataset/rig.yaml" --lcm-url "$url" > "$run/daemon.log" 2>&1 &
  daemon=$!
  sleep 1.5
  fault_args=()
  [ -n "$fault" ] && fault_args=(--fault "$fault")
  "$out/bin/vilma-replay" "$dataset" --lcm-url "$url" --rate "$rate" "${fault_args[@]}" \
    > "$run/replay.log" 2>&1
  sleep 1.5
  kill -TERM "$daemon"; wait "$daemon" || echo "sensor-faults.sh: $name: daemon exit $?" >&2
  kill -INT "$logger"; wait "$logger" 2> /dev/null || true
  "$out/bin/vilma-lcm-json" "$run/bus.lcmlog" --channels 'VILMA_ODOM|VILMA_STATUS' \
    > "$run/bus.jsonl" 2> "$run/json.log"
  printf '%s|%s|%s|%s\n' "$name" "$fault" "$fault_end" "$run" >> "$out/runs.txt"
  echo "sensor-faults.sh: $name done"
  k=$((k + 1))
done
# IMU seq numbers (not changed by time jumps) tie the fault end to the wall clock of the log.
for d in "$out"/run[0-9]*; do
  "$python" - "$d/bus.lcmlog" > "$d/imu_wall.txt" << 'PY' || true
import struct, sys
# lcm-logger format: sync word, event number, timestamp, channel length, data length, channel,
# data (big endian). imu_t: fingerprint (8), utime (8), seq (8).
with open(sys.argv[1], "rb") as f:
    data = f.read()
i = 0
while i + 28 <= len(data):
    sync, _, ts, clen, dlen = struct.unpack(">IqqII", data[i:i + 28])
    if sync != 0xEDA1DA01:
        break
    ch = data[i + 28:i + 28 + clen].decode("ascii", "replace")
    payload = data[i + 28 + clen:i + 28 + clen + dlen]
    if ch == "IMU" and len(payload) >= 24:
        seq = struct.unpack(">q", payload[16:24])[0]
        print(seq, ts)
    i += 28 + clen + dlen
PY
done
"$python" "$repo_dir/scripts/sensor_faults_report.py" --runs "$out/runs.txt" --dataset "$dataset" \
  --start "$start" | tee "$out/report.md"
