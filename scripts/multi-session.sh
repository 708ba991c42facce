#!/usr/bin/env bash
# The paper's multi-session use case on simulation (docs/loop-closure.md "Multi-session"):
# four sessions of the room (room-easy, room-s2..s4: other paths revisiting the first, other
# lighting), each mapped by vilma-estimatord from its LCM log and streamed to vilma-mapstored
# (MULTI_SESSION_SAVE_MAP=1: the daemon's --save-map instead), then one console
# script — load_merge_all_maps; aam; lc; kfh; rtl; optvi; save — then a fifth session (room-s5)
# localized against the merged map in the daemon (LOC mode).
# Figures: every mission anchored; the ATE of ALL vertices of all missions with ONE alignment
# (posyaw of mission 0's vertices to its ground truth, applied to every mission: `vilma eval
# --align-from`); cross-mission landmarks; the fifth session's global RMSE with the same
# alignment and its recall within 0.5 m.
#
# Usage: scripts/multi-session.sh        (VILMA_BUILD_DIR, VILMA_DATASETS, BENCH_WORK as
#                                          bench-optvi.sh; default work ~/.cache/vilma/multi-session)
# kfh comes after lc (the merged landmarks keep their many observers) and before optvi: with
# every 10 Hz vertex of four sessions and 140,000 merged landmarks the reduced camera matrix is
# nearly dense (87 s per iteration); the keyframed map takes seconds.
set -euo pipefail

repo_dir=$(cd "$(dirname "$0")/.." && pwd)
build_dir=${VILMA_BUILD_DIR:-$repo_dir/build}
cache=${VILMA_CACHE:-$HOME/.cache/vilma}
datasets=${VILMA_DATASETS:-$cache/datasets}
work=${BENCH_WORK:-$cache/multi-session}
bin=$build_dir/bin
mkdir -p "$work"
# shellcheck source=lib/vio-map.sh
. "$repo_dir/scripts/lib/vio-map.sh"
sessions=(room-easy room-s2 room-s3 room-s4)
query=room-s5
VILMA_SIM=$bin/vilma-sim bash "$repo_dir/scripts/make-datasets.sh" --out "$datasets" \
  --only "room-easy,room-s2,room-s3,room-s4,$query" >&2

# 1. Each session mapped by the daemon (VIO poses, unknown baseframes) and streamed to
# vilma-mapstored (the robot's path: the mission stream over LCM, journaled and finalized by
# mapstored), from its LCM log. MULTI_SESSION_SAVE_MAP=1: the daemon's --save-map instead.
rm -rf "$work/maps" && mkdir -p "$work/maps"
if [ "${MULTI_SESSION_SAVE_MAP:-0}" = 1 ]; then
  for s in "${sessions[@]}"; do ln -s "$(vio_map "$s")" "$work/maps/$s"; done
else
  url="udpm://239.255.76.67:$((7700 + $$ % 200))?ttl=0"
  root=$work/mapstored
  rm -rf "$root" && mkdir -p "$root"
  "$bin/vilma-mapstored" --root "$root" --lcm-url "$url" > "$work/mapstored.out" 2>&1 &
  store_pid=$!
  trap 'kill $store_pid 2> /dev/null || true' EXIT
  for s in "${sessions[@]}"; do
    log=$work/$s.lcmlog
    set_log "$s" || exit 1
    python3 - "$repo_dir/config/daemon.yaml" "$work/daemon-$s.yaml" "$url" "$s" <<'PY'
import sys
text = open(sys.argv[1]).read()
for old, new in [("  enabled: false          # run the map-builder", "  enabled: true          # run the map-builder"),
                 ("    enabled: false\n    lcm_url: \"\"", "    enabled: true\n    lcm_url: \"%s\"" % sys.argv[3]),
                 ('mission_name: ""', 'mission_name: "%s"' % sys.argv[4]),
                 ("end_timeout_s: 5.0", "end_timeout_s: 120.0")]:
    if old not in text:
        sys.exit("multi-session.sh: config/daemon.yaml has no '%s'" % old)
    text = text.replace(old, new, 1)
open(sys.argv[2], "w").write(text)
PY
    "$bin/vilma-estimatord" --config "$work/daemon-$s.yaml" --rig "$datasets/$s/rig.yaml" \
      --input-log "$log" --lcm-url "file://$work/$s-odom.lcm?mode=w" > "$work/daemon-$s.out" 2>&1 ||
      { cat "$work/daemon-$s.out" >&2; exit 1; }
    grep -q "mission complete in mapstored" "$work/daemon-$s.out" ||
      { grep "stream:" "$work/daemon-$s.out" >&2; echo "multi-session.sh: $s not stored" >&2; exit 1; }
    ln -s "$root/$s" "$work/maps/$s"
  done
  kill "$store_pid" && wait "$store_pid" 2> /dev/null || true
  trap - EXIT
  echo "sessions streamed to vilma-mapstored: $(grep -c 'mission complete' "$work/mapstored.out") missions stored" >&2
fi

# 2. One console script over the merged map.
rm -rf "$work/merged" "$work/traj" && mkdir -p "$work/traj"
start=$(date +%s.%N)
/usr/bin/time -f "%M" -o "$work/console.rss" "$bin/vilma" console -c "load_merge_all_maps $work/maps; \
  aam; lc; kfh; rtl; optvi; ms; print_baseframes; \
  ettc --out=$work/traj --format=asl --frame=G; cmc; save --out=$work/merged" \
  > "$work/console.out" 2>&1 || { cat "$work/console.out" >&2; exit 1; }
console_s=$(awk -v a="$start" -v b="$(date +%s.%N)" 'BEGIN { printf "%.0f", b - a }')

# 3. ONE alignment for the whole map: mission 0 (room-easy, the first loaded) to its ground truth.
mapfile -t trajectories < <(ls "$work/traj"/*)
order=$(grep -o '^[0-9a-f]\{8\} ' "$work/console.out" | head -4 | tr -d ' ')
gt_of() { echo "$datasets/$1/mav0/state_groundtruth_estimate0/data.csv"; }
first=$(ls "$work/traj"/*"$(echo "$order" | head -1)"* 2> /dev/null || echo "${trajectories[0]}")
"$bin/vilma" eval --gt "$(gt_of room-easy)" --est "$first" --align posyaw \
  --json "$work/alignment.json" > "$work/eval-0.txt"
echo "| mission (session) | vertices | ATE with the map's one alignment [m] |"
echo "|---|---:|---:|"
all_sq=0 all_n=0
i=0
for s in "${sessions[@]}"; do
  id=$(echo "$order" | sed -n "$((i + 1))p")
  traj=$(ls "$work/traj"/*"$id"* 2> /dev/null || true)
  if [ -z "$traj" ]; then echo "| $s | - | (no trajectory) |"; i=$((i + 1)); continue; fi
  "$bin/vilma" eval --gt "$(gt_of "$s")" --est "$traj" --align-from "$work/alignment.json" \
    > "$work/eval-$s.txt"
  n=$(grep -vc '^#' "$traj")
  r=$(ate_rmse "$work/eval-$s.txt")
  echo "| $id ($s) | $n | $r |"
  all_sq=$(awk -v a="$all_sq" -v r="$r" -v n="$n" 'BEGIN { print a + r * r * n }')
  all_n=$((all_n + n))
  i=$((i + 1))
done
echo "| all missions together | $all_n | $(awk -v a="$all_sq" -v n="$all_n" 'BEGIN { printf "%.4f", sqrt(a / n) }') |"
echo
grep -E '^aam:|^  mission .* (anchored|NOT)|^lc:|^optvi:|cross-mission' "$work/console.out" | sed 's/^/    /'
echo "    console: $console_s s, peak RSS $(awk -v k="$(cat "$work/console.rss")" 'BEGIN { printf "%.0f", k / 1024 }') MB"

# 4. The fifth session localized against the merged map.
set_log "$query" || exit 1
"$bin/vilma-estimatord" --rig "$datasets/$query/rig.yaml" --input-log "$work/$query.lcmlog" \
  --localization-map "$work/merged" --lcm-url "file://$work/$query-loc.lcm?mode=w" \
  > "$work/$query-loc.out" 2>&1
"$bin/vilma-lcm-poses" "$work/$query-loc.lcm" --out "$work/$query-pose.txt" > /dev/null
"$bin/vilma-lcm-poses" "$work/$query-loc.lcm" --channel VILMA_LOC --out "$work/$query-loc.txt" \
  > /dev/null 2>&1 || true
"$bin/vilma" eval --gt "$(gt_of "$query")" --est "$work/$query-pose.txt" \
  --align-from "$work/alignment.json" > "$work/$query-pose.eval"
"$bin/vilma" eval --gt "$(gt_of "$query")" --est "$work/$query-loc.txt" \
  --align-from "$work/alignment.json" --within 0.5 > "$work/$query-loc.eval"
echo
echo "fifth session ($query) in LOC mode: global RMSE $(ate_rmse "$work/$query-pose.eval") m (the map's alignment); $(grep '^within' "$work/$query-loc.eval")"
