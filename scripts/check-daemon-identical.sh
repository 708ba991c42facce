#!/bin/bash
# Checks that vilma-estimatord's --input-log output has not changed (issue 19: the daemon split
# into stages must be behaviour-identical). Runs the daemon on the demo's LCM logs in four modes
#   vo       session 0 (30 s stereo room), odometry only
#   map      session 0 with --save-map (the demo's mapping run)
#   loc      session 1 (20 s, revisit) against the demo's processed map (LOC mode)
#   locmap   session 1, LOC mode and --save-map together
# decodes VILMA_ODOM, VILMA_POSE and VILMA_LOC exactly (every double as a C99 hex float; only
# VILMA_LOC's stage_ms, a wall time, is left out), keeps the deterministic counters of the
# daemon's final report (those named *_us_* are timings and are left out) and a listing of the
# saved map's files with their checksums, and compares all of it with a reference recorded
# before (exit 1 on a difference; every mode is compared, not only up to the first difference).
# Counters are compared by name: each counter of the reference must have the same value, and
# counters the daemon gained since (listed as "added") are not a difference.
#
# Usage: scripts/check-daemon-identical.sh [--record] [--ref DIR] [--bin DIR] [--out DIR] [--config FILE]
#   --record   write the reference instead of comparing with it
#   --ref DIR  the reference (default $VILMA_CACHE/issue19/before)
#   --bin DIR  folder with vilma-estimatord (default build/bin)
#   --out DIR  where this run's outputs go (default $VILMA_CACHE/issue19/after)
#   --config FILE  daemon options for every run (--config of vilma-estimatord), e.g. to switch
#              off a library change made after the reference (docs/design.md, issue 19)
# Inputs: the demo's logs ($VILMA_CACHE/demo/map-then-localize/session{0,1}.lcmlog, made by
# scripts/demo.sh); the processed map is copied into the reference folder at --record so that a
# later demo run cannot change the input of the LOC runs.
set -euo pipefail

repo_dir=$(cd "$(dirname "$0")/.." && pwd)
cache=${VILMA_CACHE:-$HOME/.cache/vilma}
demo=$cache/demo/map-then-localize
ref=$cache/issue19/before
bin=$repo_dir/build/bin
out=
config=()
record=0
while [ $# -gt 0 ]; do
  case $1 in
    --record) record=1 ;;
    --ref) ref=$2; shift ;;
    --bin) bin=$2; shift ;;
    --out) out=$2; shift ;;
    --config) config=(--config "$2"); shift ;;
    -h|--help) sed -n '2,/^set -e/p' "$0" | sed '$d; s/^# \{0,1\}//'; exit 0 ;;
    *) echo "check-daemon-identical: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
  shift
done
[ $record = 1 ] && out=$ref
out=${out:-$cache/issue19/after}
exe=$bin/vilma-estimatord
[ -x "$exe" ] || { echo "check-daemon-identical: $exe not built" >&2; exit 1; }
for f in "$demo/session0.lcmlog" "$demo/session1.lcmlog" "$cache/demo/room-demo/rig.yaml" \
         "$demo/session1/rig.yaml"; do
  [ -e "$f" ] || { echo "check-daemon-identical: $f missing: run scripts/demo.sh first" >&2; exit 1; }
done
if [ $record = 1 ]; then
  rm -rf "$ref" && mkdir -p "$ref"
  cp -r "$demo/map-processed" "$ref/locmap-input"
  # Which logs the reference was made from (a re-made demo log must give the same bytes).
  (cd "$demo" && sha256sum session0.lcmlog session1.lcmlog) > "$ref/inputs.sha256"
else
  [ -d "$ref/locmap-input" ] || { echo "check-daemon-identical: no reference in $ref (--record first)" >&2; exit 1; }
  (cd "$demo" && sha256sum --quiet -c "$ref/inputs.sha256") ||
    { echo "check-daemon-identical: the demo's logs changed since the reference was recorded" >&2; exit 1; }
  rm -rf "$out" && mkdir -p "$out"
fi

# decode LOG CHANNEL...: one text line per message of the channels, in log order.
decode() {
  python3 - "$@" <<'PY'
import struct, sys
log, channels = sys.argv[1], set(sys.argv[2:])
def hexes(b, off, n):
    v = struct.unpack_from('>%dd' % n, b, off)
    return ' '.join(float.hex(x) for x in v), off + 8 * n
def string(b, off):
    (n,) = struct.unpack_from('>i', b, off)
    return b[off + 4:off + 4 + n - 1].decode(), off + 4 + n
def pose(b):
    off = 8  # fingerprint
    utime, seq = struct.unpack_from('>qq', b, off); off += 16
    parent, off = string(b, off); child, off = string(b, off)
    fields = []
    for n in (3, 4, 3, 3, 36):
        s, off = hexes(b, off, n); fields.append(s)
    (status,) = struct.unpack_from('>i', b, off)
    return '%d %d %s %s status %d | %s' % (utime, seq, parent, child, status, ' | '.join(fields))
def loc(b):
    off = 8
    utime, seq = struct.unpack_from('>qq', b, off); off += 16
    status, off = string(b, off); decision, off = string(b, off)
    k, m, i = struct.unpack_from('>iii', b, off); off += 12
    fields = []
    for n in (3, 4, 36):
        s, off = hexes(b, off, n); fields.append(s)
    # stage_ms (wall time) is not compared.
    return '%d %d %s %s kp %d matches %d inliers %d | %s' % (utime, seq, status, decision, k, m, i, ' | '.join(fields))
with open(log, 'rb') as f:
    data = f.read()
off = 0
while off < len(data):
    sync, _, _, clen, dlen = struct.unpack_from('>IqqIi', data, off)
    if sync != 0xEDA1DA01:
        sys.exit('%s: bad sync word at byte %d' % (log, off))
    off += 28
    channel = data[off:off + clen].decode(); off += clen
    payload = data[off:off + dlen]; off += dlen
    if channel in channels:
        print(channel, loc(payload) if channel == 'VILMA_LOC' else pose(payload))
PY
}

# run NAME RIG LOG [daemon options...]
run() {
  local name=$1 rig=$2 log=$3
  shift 3
  local dir=$out/$name
  mkdir -p "$dir"
  local t0=$SECONDS
  "$exe" "${config[@]}" --rig "$rig" --input-log "$log" --lcm-url "file://$dir/out.lcmlog?mode=w" "$@" \
    > "$dir/daemon.out" 2> "$dir/daemon.err" ||
    { tail -5 "$dir/daemon.err" >&2; echo "check-daemon-identical: $name: the daemon failed" >&2; return 1; }
  decode "$dir/out.lcmlog" VILMA_ODOM VILMA_POSE VILMA_LOC > "$dir/decoded.txt"
  # The final counters ("name value" lines after "stopped:"), timings left out.
  sed -n '/^vilma-estimatord: stopped:/,$p' "$dir/daemon.out" | grep -v '_us_' \
    | grep -v 'end of mission took' > "$dir/counters.txt" || true
  if [ -d "$dir/map" ]; then
    (cd "$dir/map" && find . -type f | sort | xargs sha256sum) > "$dir/map.sha256"
  fi
  rm -f "$dir/out.lcmlog"
  printf '%-7s %5d lines decoded (%s ODOM, %s POSE, %s LOC), %3d s\n' "$name" \
    "$(wc -l < "$dir/decoded.txt")" "$(grep -c '^VILMA_ODOM' "$dir/decoded.txt" || true)" \
    "$(grep -c '^VILMA_POSE' "$dir/decoded.txt" || true)" "$(grep -c '^VILMA_LOC' "$dir/decoded.txt" || true)" \
    $((SECONDS - t0))
}

s0=$demo/session0.lcmlog
s1=$demo/session1.lcmlog
rig0=$cache/demo/room-demo/rig.yaml
rig1=$demo/session1/rig.yaml
run vo "$rig0" "$s0"
run map "$rig0" "$s0" --save-map "$out/map/map"
run loc "$rig1" "$s1" --localization-map "$ref/locmap-input"
run locmap "$rig1" "$s1" --localization-map "$ref/locmap-input" --save-map "$out/locmap/map"

if [ $record = 1 ]; then
  echo "check-daemon-identical: reference recorded in $ref"
  exit 0
fi
# compare_counters REF OUT: every line of the reference (the summary line and each "name value"
# counter) must be in this run's report with the same value, in the same order; counters added
# to the daemon since the reference was recorded (e.g. map_vertices_held, frames_without_stereo)
# are listed but are not a difference: the reference stays the pre-change run, never re-recorded
# with the binary under test.
compare_counters() {
  python3 - "$1" "$2" <<'PY'
import sys
ref = [l.rstrip('\n') for l in open(sys.argv[1])]
out = [l.rstrip('\n') for l in open(sys.argv[2])]
def key(line):
    return line if line.startswith('vilma-estimatord:') else line.split(' ')[0]
out_keys = [key(l) for l in out]
ref_keys = set(key(l) for l in ref)
bad = [('-', l) for l in ref if l not in out]
kept = [l for l in out if key(l) in ref_keys]
if not bad and kept != ref:
    bad.append(('order', 'the shared counters are in another order'))
for what, line in bad:
    print('  %s %s' % (what, line))
for l in out:
    if key(l) not in ref_keys:
        print('  added (not in the reference): %s' % l)
sys.exit(1 if bad else 0)
PY
}

status=0
for name in vo map loc locmap; do
  for f in decoded.txt counters.txt map.sha256; do
    [ -e "$ref/$name/$f" ] || [ -e "$out/$name/$f" ] || continue
    if [ $f = counters.txt ] && [ -e "$ref/$name/$f" ] && [ -e "$out/$name/$f" ]; then
      if report=$(compare_counters "$ref/$name/$f" "$out/$name/$f"); then
        echo "identical: $name/$f ($(grep -c '^  added' <<< "$report" || true) counters added since the reference)"
      else
        echo "DIFFERENT: $name/$f"
        grep -v '^  added' <<< "$report" | head -20
        status=1
      fi
    elif diff -q "$ref/$name/$f" "$out/$name/$f" > /dev/null 2>&1; then
      echo "identical: $name/$f"
    else
      echo "DIFFERENT: $name/$f"
      diff "$ref/$name/$f" "$out/$name/$f" | head -20 || true
      status=1
    fi
  done
done
exit $status
