#!/usr/bin/env bash
# Daemon stereo benchmark (issue 17): vilma-estimatord --input-log on the LCM log of a dataset
# (vilma-replay --to-log, both cameras), mono and --stereo, ATE of VILMA_ODOM against ground
# truth (vilma eval --align posyaw). Prints one table (docs/estimator.md, "Stereo in the
# daemon"): per set and mode the frames filtered, tracking poses, ATE RMSE [m], stereo / mono
# ATE ratio, worst roll/pitch error [deg], frames updated mono for a missing CAM1 image
# (frames_without_stereo), wall time of the daemon run [s] and the load average at its end.
#
# Usage: scripts/bench-daemon-stereo.sh [SET ...]   (default: hall euroc_V1_01_micro)
#   A SET is a simulated set in $VILMA_CACHE/datasets (scripts/make-datasets.sh) or a real
#   slice in ../shared/data (euroc_*: the EuRoC rig config/euroc-rig.yaml).
#   VILMA_BUILD_DIR, VILMA_CACHE, VILMA_SHARED_DATA_DIR as in scripts/bench-vio.sh.
# The logs go to $VILMA_CACHE/bench-daemon-stereo/ (removed at the end; a stereo log of the
# 120 s hall is 1.7 GB).
set -euo pipefail

repo_dir="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build_dir="${VILMA_BUILD_DIR:-$repo_dir/build}"
cache="${VILMA_CACHE:-$HOME/.cache/vilma}"
shared_dir="${VILMA_SHARED_DATA_DIR:-$repo_dir/../shared/data}"
bin="$build_dir/bin"
case "${1:-}" in -h|--help) sed -n '2,15p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//'; exit 0 ;; esac
sets=("$@")
[[ ${#sets[@]} -gt 0 ]] || sets=(hall euroc_V1_01_micro)
for b in vilma vilma-replay vilma-estimatord vilma-lcm-poses; do
  [[ -x "$bin/$b" ]] || { echo "bench-daemon-stereo.sh: $bin/$b not built" >&2; exit 1; }
done
work="$cache/bench-daemon-stereo"
rm -rf "$work"; mkdir -p "$work"
trap 'rm -rf "$work"' EXIT

echo "| dataset | mode | frames | tracking poses | ATE RMSE [m] | stereo / mono | roll/pitch err max [deg] | frames_without_stereo | daemon wall [s] | load avg |"
echo "|---|---|---|---|---|---|---|---|---|---|"
for set in "${sets[@]}"; do
  if [[ "$set" == euroc_* ]]; then dir="$shared_dir/$set"; rig="$repo_dir/config/euroc-rig.yaml"
  else dir="$cache/datasets/$set"; rig="$dir/rig.yaml"; fi
  [[ -d "$dir/mav0/cam1" ]] || { echo "bench-daemon-stereo.sh: $dir has no mav0/cam1" >&2; exit 1; }
  gt="$dir/mav0/state_groundtruth_estimate0/data.csv"
  "$bin/vilma-replay" "$dir" --to-log "$work/$set.lcmlog" --quiet > "$work/$set.replay.out" 2>&1
  mono_ate=""
  for mode in mono stereo; do
    args=(); [[ "$mode" == stereo ]] && args=(--stereo)
    start=$(date +%s.%N)
    "$bin/vilma-estimatord" --rig "$rig" --input-log "$work/$set.lcmlog" "${args[@]}" \
        --lcm-url "file://$work/$set.$mode.lcm?mode=w" > "$work/$set.$mode.out" 2>&1
    wall=$(python3 -c "import sys; print('%.1f' % ($(date +%s.%N) - $start))")
    load=$(cut -d' ' -f1 /proc/loadavg)
    "$bin/vilma-lcm-poses" "$work/$set.$mode.lcm" --channel VILMA_ODOM --out "$work/$set.$mode.txt" > /dev/null
    "$bin/vilma" eval --gt "$gt" --est "$work/$set.$mode.txt" --align posyaw --segments 1 \
        --json "$work/$set.$mode.json" > /dev/null 2>&1
    row=$(python3 - "$work/$set.$mode.json" "$work/$set.$mode.out" "$work/$set.$mode.txt" "$mono_ate" <<'PY'
import json, re, sys
j = json.load(open(sys.argv[1])); out = open(sys.argv[2]).read()
frames = re.search(r"^frames_filtered (\d+)", out, re.M).group(1)
without = re.search(r"^frames_without_stereo (\d+)", out, re.M).group(1)
poses = sum(1 for l in open(sys.argv[3]) if l.strip() and not l.startswith("#"))
ate = j["ate"]["translation_rmse_m"]; tilt = j["ate"]["roll_pitch_max_deg"]
ratio = "%.2f" % (ate / float(sys.argv[4])) if sys.argv[4] else "1"
print(f"{frames} | {poses} | {ate:.4f} | {ratio} | {tilt:.2f} | {without}")
print(ate)
PY
)
    [[ "$mode" == mono ]] && mono_ate=$(tail -1 <<< "$row")
    echo "| $set | $mode | $(head -1 <<< "$row") | $wall | $load |"
  done
  rm -f "$work/$set.lcmlog"
done
