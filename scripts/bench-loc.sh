#!/bin/bash
# Localization benchmark of vilma-estimatord's LOC mode (docs/benchmarks.md "Localization in the
# daemon"): for each simulated world, a localization map of session 0 (vilma-locmap-gt: map
# builder with ground-truth poses, so G = the simulator's world W), then sessions 1 and 2 (other
# paths that revisit session 0's, other lighting) through `vilma-estimatord --input-log
# --localization-map` (deterministic). Per query session:
#   - global RMSE: VILMA_POSE (T_G_I) against ground truth with NO alignment;
#   - VIO only: VILMA_ODOM of the same daemon run without a map, aligned only at its first pose
#     (`vilma eval --align first`: a robot started at a known pose), over the whole run (which
#     favours VIO: VILMA_POSE starts seconds later, when the drift has begun);
#   - recall: localization attempts (VILMA_LOC) whose pose is within 0.5 m of ground truth,
#     over all attempts; attempts accepted into T_G_M;
#   - the localizer stage time per query (features + Localize, wall) p50 and max.
# Prints a markdown table. Issue targets: RMSE <= 0.08 m (room), <= 0.15 m (hall), >= 40 %
# lower than VIO only, recall >= 80 %.
#
# Usage: scripts/bench-loc.sh [WORLD ...]       (default: room hall)
#   VILMA_BUILD_DIR  build folder with bin/vilma-{estimatord,replay,locmap-gt,lcm-poses}, bin/vilma
#   VILMA_DATASETS   datasets folder of scripts/make-datasets.sh (default
#                    ${VILMA_CACHE:-~/.cache/vilma}/datasets); missing sets are made
#   BENCH_WORK       folder for logs, maps and outputs (default ${VILMA_CACHE:-~/.cache/vilma}/bench-loc)
set -euo pipefail

repo_dir=$(cd "$(dirname "$0")/.." && pwd)
build_dir=${VILMA_BUILD_DIR:-$repo_dir/build}
cache=${VILMA_CACHE:-$HOME/.cache/vilma}
datasets=${VILMA_DATASETS:-$cache/datasets}
work=${BENCH_WORK:-$cache/bench-loc}
bin=$build_dir/bin
worlds=("$@")
[ ${#worlds[@]} -eq 0 ] && worlds=(room hall)
for exe in vilma-estimatord vilma-replay vilma-locmap-gt vilma-lcm-poses vilma vilma-sim; do
  [ -x "$bin/$exe" ] || { echo "bench-loc: $bin/$exe not built (set VILMA_BUILD_DIR)" >&2; exit 1; }
done
mkdir -p "$work"

map_set() { case "$1" in room) echo room-easy ;; hall) echo hall ;; *) return 1 ;; esac; }

# The datasets this run needs (make-datasets.sh skips the ones that are up to date).
needed=""
for w in "${worlds[@]}"; do
  m=$(map_set "$w") || { echo "bench-loc: unknown world '$w' (room, hall)" >&2; exit 2; }
  needed="$needed,$m,$w-s2,$w-s3"
done
VILMA_SIM=$bin/vilma-sim bash "$repo_dir/scripts/make-datasets.sh" --out "$datasets" \
  --only "${needed#,}" >&2

# value NAME FILE: the last "NAME VALUE" line of a daemon's final counters.
value() { awk -v k="$1" '$1 == k { v = $2 } END { print (v == "" ? "-" : v) }' "$2"; }
# rmse EVAL_OUTPUT: ATE translation RMSE [m].
rmse() { awk '/^ATE translation/ { print $5 }' "$1"; }

echo "| world | query | map landmarks | VILMA_POSE frames | global RMSE, no alignment [m] | VIO only, aligned at start, whole run [m] | LOC vs VIO | recall (within 0.5 m / attempts) | accepted / attempts | stage p50 / max [ms] |"
echo "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|"
for w in "${worlds[@]}"; do
  m=$(map_set "$w")
  map=$work/$m.vlocmap
  if [ ! -f "$map" ] || [ ! -f "$work/$m.locmap.out" ] || [ "$datasets/$m/sim.yaml" -nt "$map" ]; then
    "$bin/vilma-locmap-gt" "$datasets/$m" "$map" > "$work/$m.locmap.out" 2>&1
  fi
  landmarks=$(grep -o '[0-9]* landmarks' "$work/$m.locmap.out" | head -1 | cut -d' ' -f1)
  for q in "$w-s2" "$w-s3"; do
    set_dir=$datasets/$q
    gt=$set_dir/mav0/state_groundtruth_estimate0/data.csv
    log=$work/$q.lcmlog
    if [ ! -f "$log" ] || [ "$set_dir/sim.yaml" -nt "$log" ]; then
      "$bin/vilma-replay" "$set_dir" --to-log "$log" --quiet
    fi
    for mode in loc vio; do
      args=(--rig "$set_dir/rig.yaml" --input-log "$log" --lcm-url "file://$work/$q-$mode.lcm?mode=w")
      [ "$mode" = loc ] && args+=(--localization-map "$map")
      rm -f "$work/$q-$mode.lcm"
      "$bin/vilma-estimatord" "${args[@]}" > "$work/$q-$mode.out" 2>&1
    done
    "$bin/vilma-lcm-poses" "$work/$q-loc.lcm" --out "$work/$q-pose.txt" > /dev/null 2>&1 || true
    "$bin/vilma-lcm-poses" "$work/$q-vio.lcm" --channel VILMA_ODOM --out "$work/$q-odom.txt" > /dev/null
    "$bin/vilma-lcm-poses" "$work/$q-loc.lcm" --channel VILMA_LOC --out "$work/$q-loc.txt" \
      > "$work/$q-loc.summary" 2>&1 || true
    attempts=$(value loc_attempts "$work/$q-loc.out")
    accepted=$(value loc_tgm_updates "$work/$q-loc.out")
    stage_p50=$(value loc_stage_us_p50 "$work/$q-loc.out")
    stage_max=$(value loc_stage_us_max "$work/$q-loc.out")
    frames=0 loc_rmse=- vio_rmse=- ratio=- within=0
    if [ -s "$work/$q-pose.txt" ]; then
      frames=$(grep -vc '^#' "$work/$q-pose.txt")
      "$bin/vilma" eval --gt "$gt" --est "$work/$q-pose.txt" --align none > "$work/$q-pose.eval"
      loc_rmse=$(rmse "$work/$q-pose.eval")
    fi
    "$bin/vilma" eval --gt "$gt" --est "$work/$q-odom.txt" --align first > "$work/$q-odom.eval"
    vio_rmse=$(rmse "$work/$q-odom.eval")
    if [ "$loc_rmse" != - ]; then
      ratio=$(awk -v a="$loc_rmse" -v b="$vio_rmse" 'BEGIN { printf "%.0f %% lower", 100 * (1 - a / b) }')
    fi
    if [ -s "$work/$q-loc.txt" ]; then
      "$bin/vilma" eval --gt "$gt" --est "$work/$q-loc.txt" --align none --within 0.5 \
        > "$work/$q-loc.eval"
      within=$(awk '/^within 0.50 m:/ { print $4 }' "$work/$q-loc.eval")
    fi
    recall=-
    [ "$attempts" != - ] && [ "$attempts" -gt 0 ] &&
      recall="$within / $attempts = $(awk -v a="$within" -v b="$attempts" 'BEGIN { printf "%.1f %%", 100 * a / b }')"
    echo "| $w | $q | $landmarks | $frames | $loc_rmse | $vio_rmse | $ratio | $recall | $accepted / $attempts | $(awk -v a="$stage_p50" -v b="$stage_max" 'BEGIN { printf "%.1f / %.1f", a / 1000, b / 1000 }') |"
  done
done
