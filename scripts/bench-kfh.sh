#!/usr/bin/env bash
# Keyframing benchmark (docs/keyframing.md, docs/benchmarks.md "Keyframing"): the daemon's VI-map
# of a simulated set (vilma-estimatord --input-log --save-map: the VIO's poses, 10 Hz vertices),
# keyframed by `vilma console` with kfh's defaults (maplab's: 0.75 m, 20 deg, every 10th, 20
# shared landmarks), then checked: map consistent, distinct IMU samples conserved, the kept
# vertices' poses unchanged — their ATE (posyaw, fitted to the vertices evaluated) before kfh
# equals the ATE after; the map's vertices, landmarks, observations and size on disk before/after.
#
# Usage: scripts/bench-kfh.sh [SET ...]         (default: room-easy, the 90 s room)
#   VILMA_BUILD_DIR  build folder (default build/)
#   VILMA_DATASETS   datasets of scripts/make-datasets.sh (default ${VILMA_CACHE:-~/.cache/vilma}/datasets)
#   BENCH_WORK       logs, maps, outputs (default ${VILMA_CACHE:-~/.cache/vilma}/bench-kfh)
# Prints a markdown table. Maps and logs are reused while newer than their inputs.
set -euo pipefail

repo_dir=$(cd "$(dirname "$0")/.." && pwd)
build_dir=${VILMA_BUILD_DIR:-$repo_dir/build}
cache=${VILMA_CACHE:-$HOME/.cache/vilma}
datasets=${VILMA_DATASETS:-$cache/datasets}
work=${BENCH_WORK:-$cache/bench-kfh}
bin=$build_dir/bin
sets=("$@")
[ ${#sets[@]} -eq 0 ] && sets=(room-easy)
for exe in vilma vilma-estimatord vilma-replay vilma-sim; do
  [ -x "$bin/$exe" ] || { echo "bench-kfh: $bin/$exe is not built" >&2; exit 1; }
done
mkdir -p "$work"
# shellcheck source=lib/vio-map.sh
. "$repo_dir/scripts/lib/vio-map.sh"
list=$(IFS=,; echo "${sets[*]}")
VILMA_SIM=$bin/vilma-sim bash "$repo_dir/scripts/make-datasets.sh" --out "$datasets" --only "$list" >&2

# stat NAME FILE: the "total" row column NAME of a map_stats output (vertex, landmark, good, obs).
stat() {
  awk -v k="$1" '$1 == "mission" { for (i = 1; i <= NF; ++i) col[$i] = i }
                 $1 == "total" { v = $(col[k]) } END { print v }' "$2"
}
# keep_times EST KEPT: the rows of EST (EuRoC CSV) whose time is a row of KEPT.
keep_times() {
  awk -F, 'NR == FNR { if ($1 !~ /^#/) keep[$1] = 1; next } $1 ~ /^#/ || keep[$1]' "$2" "$1"
}
mb() { awk -v b="$(du -sb "$1" | cut -f1)" 'BEGIN { printf "%.2f", b / 1e6 }'; }

echo "| set | vertices before -> after | landmarks (good) before -> after | observations before -> after | map on disk [MB] before -> after | distinct IMU samples before -> after | ATE all vertices before [m] | ATE kept vertices before / after [m] | consistent | kfh [s] |"
echo "|---|---|---|---|---|---|---|---|---|---|"
for set in "${sets[@]}"; do
  map=$(vio_map "$set")
  out=$work/$set-kfh
  rm -rf "$out" "$out".*
  "$bin/vilma" console -c "load $map; ms; ettc --out=$out.before.csv --format=asl --frame=G; \
    kfh; cmc; ettc --out=$out.after.csv --format=asl --frame=G; ms; save --out=$out" \
    > "$out.console" 2>&1 || { cat "$out.console" >&2; echo "bench-kfh: console failed ($set)" >&2; exit 1; }
  awk '/^> ms/ { n++ } n == 1' "$out.console" | awk '/^> kfh/ { exit } { print }' > "$out.ms-before"
  awk '/^> ms/ { n++ } n == 2' "$out.console" > "$out.ms-after"
  gt=$datasets/$set/mav0/state_groundtruth_estimate0/data.csv
  keep_times "$out.before.csv" "$out.after.csv" > "$out.before-kept.csv"
  for f in before before-kept after; do
    "$bin/vilma" eval --gt "$gt" --est "$out.$f.csv" > "$out.$f.eval"
  done
  samples=$(grep -o 'IMU samples [0-9]* -> [0-9]*' "$out.console" | head -1 | sed 's/IMU samples //')
  seconds=$(awk '/^  \(kfh: / { gsub(/[()s]/, "", $2); print $2 }' "$out.console")
  consistent=$(grep -q '^map is consistent' "$out.console" && echo yes || echo NO)
  printf '| %s | %s -> %s | %s (%s) -> %s (%s) | %s -> %s | %s -> %s | %s | %s | %s / %s | %s | %s |\n' \
    "$set" "$(stat vertex "$out.ms-before")" "$(stat vertex "$out.ms-after")" \
    "$(stat landmark "$out.ms-before")" "$(stat good "$out.ms-before")" \
    "$(stat landmark "$out.ms-after")" "$(stat good "$out.ms-after")" \
    "$(stat obs "$out.ms-before")" "$(stat obs "$out.ms-after")" \
    "$(mb "$map")" "$(mb "$out")" "$samples" \
    "$(ate_rmse "$out.before.eval")" "$(ate_rmse "$out.before-kept.eval")" \
    "$(ate_rmse "$out.after.eval")" "$consistent" "$seconds"
done
