#!/usr/bin/env bash
# Raw map size per minute of data (docs/mapping.md "Compact maps", docs/summarization.md): the
# room sessions mapped by vilma-estimatord (--input-log --save-map) with the map builder's
# compact = none | tracks | good, mono (cam0 only) and stereo; then each map after
# `kfh; lsparsify --lsparsify_keep_fraction=0.1; compact_map` (the map-maintenance pipeline).
# With --multi-session, the four-session database (room-easy, room-s2..s4) is also built from
# the "good" maps (aam; lc) and the fifth session localized against it, to show what the
# smallest raw maps cost loop closure.
# Prints markdown tables.
#
# Usage: scripts/bench-map-size.sh [--multi-session]
#   (VILMA_BUILD_DIR, VILMA_DATASETS as bench-optvi.sh; work: ~/.cache/vilma/map-size)
set -euo pipefail

repo_dir=$(cd "$(dirname "$0")/.." && pwd)
build_dir=${VILMA_BUILD_DIR:-$repo_dir/build}
cache=${VILMA_CACHE:-$HOME/.cache/vilma}
datasets=${VILMA_DATASETS:-$cache/datasets}
work=${BENCH_WORK:-$cache/map-size}
bin=$build_dir/bin
multi=0
case ${1:-} in
  --multi-session) multi=1 ;;
  -h | --help) sed -n '2,13p' "$0"; exit 0 ;;
  "") ;;
  *) echo "bench-map-size.sh: unknown argument '$1' (see --help)" >&2; exit 2 ;;
esac
mkdir -p "$work"
# shellcheck source=lib/vio-map.sh
. "$repo_dir/scripts/lib/vio-map.sh"
sessions=(room-easy)
[ "$multi" = 1 ] && sessions=(room-easy room-s2 room-s3 room-s4)
only=$(IFS=,; echo "${sessions[*]},room-s5")
VILMA_SIM=$bin/vilma-sim bash "$repo_dir/scripts/make-datasets.sh" --out "$datasets" --only "$only" >&2

# daemon.yaml and map_builder.yaml copies for one variant: CAMERAS ("[]" or "[0]") and COMPACT.
make_config() {
  local name=$1 cameras=$2 compact=$3
  sed -e "s/^cameras: \[\]/cameras: $cameras/" -e "s/^compact: \"[a-z]*\"/compact: \"$compact\"/" \
    "$repo_dir/config/map_builder.yaml" > "$work/map_builder-$name.yaml"
  sed -e "s|^  map_builder: \"\"|  map_builder: \"map_builder-$name.yaml\"|" \
    "$repo_dir/config/daemon.yaml" > "$work/daemon-$name.yaml"
  grep -q "map_builder-$name.yaml" "$work/daemon-$name.yaml" ||
    { echo "bench-map-size.sh: could not set map_builder in a copy of config/daemon.yaml" >&2; exit 1; }
}

# map SET VARIANT: the daemon's map of SET with VARIANT's config ($work/SET-VARIANT).
map() {
  local set=$1 name=$2 log=$work/$1.lcmlog out=$work/$1-$2
  set_log "$set" || exit 1
  if [ ! -e "$out/manifest.yaml" ] || [ "$bin/vilma-estimatord" -nt "$out/manifest.yaml" ]; then
    rm -rf "$out"
    "$bin/vilma-estimatord" --config "$work/daemon-$name.yaml" --rig "$datasets/$set/rig.yaml" \
      --input-log "$log" --lcm-url "file://$out.lcm?mode=w" --save-map "$out" > "$out.out" 2>&1 ||
      { cat "$out.out" >&2; exit 1; }
  fi
}

mb() { du -sb "$1" | awk '{ printf "%.2f", $1 / 1e6 }'; }
minutes() { awk -F, 'NR > 1 { if (!t0) t0 = $1; t1 = $1 } END { printf "%.3f", (t1 - t0) / 6e10 }' \
  "$datasets/$1/mav0/cam0/data.csv"; }

echo "| map (room-easy, 90 s) | cameras | compact | raw MB | MB/min | good landmarks | keypoints | after kfh; lsparsify 0.1; compact_map: MB | MB/min |"
echo "|---|---|---|---:|---:|---:|---:|---:|---:|"
m=$(minutes room-easy)
for cams in mono stereo; do
  for compact in none tracks good; do
    name=$cams-$compact
    make_config "$name" "$([ $cams = mono ] && echo '[0]' || echo '[]')" "$compact"
    map room-easy "$name"
    stats=$("$bin/vilma" console -c "load $work/room-easy-$name --map_key=m; mission_stats; \
      kfh; lsparsify --lsparsify_keep_fraction=0.1; compact_map; \
      save --out=$work/room-easy-$name-summarized --overwrite" 2>&1) ||
      { echo "$stats" >&2; exit 1; }
    good=$(echo "$stats" | awk '/^  landmarks / { gsub(/[(,]/, " "); print $4; exit }')
    keypoints=$(echo "$stats" | awk '/^  keypoints / { print $2; exit }')
    raw=$(mb "$work/room-easy-$name")
    small=$(mb "$work/room-easy-$name-summarized")
    awk -v c=$cams -v k=$compact -v r="$raw" -v s="$small" -v m="$m" -v g="$good" -v kp="$keypoints" \
      'BEGIN { printf "| room-easy | %s | %s | %s | %.1f | %s | %s | %s | %.2f |\n", c, k, r, r / m, g, kp, s, s / m }'
  done
done

if [ "$multi" = 1 ]; then
  echo
  echo "| four-session database from stereo maps, compact = | anchored | loops verified | landmarks merged | room-s5 recall within 0.5 m |"
  echo "|---|---:|---:|---:|---:|"
  for compact in tracks good; do
    name=stereo-$compact
    rm -rf "$work/maps-$compact" && mkdir -p "$work/maps-$compact"
    for s in "${sessions[@]}"; do
      map "$s" "$name"
      ln -s "$work/$s-$name" "$work/maps-$compact/$s"
    done
    rm -rf "$work/traj-$compact" && mkdir -p "$work/traj-$compact"
    "$bin/vilma" console -c "load_merge_all_maps $work/maps-$compact --map_key=db; aam; lc; rtl; ms; \
      ettc --out=$work/traj-$compact --format=asl --frame=G; summary_map $work/db-$compact.vlocmap" \
      > "$work/db-$compact.out" 2>&1 || { cat "$work/db-$compact.out" >&2; exit 1; }
    mission0=$(grep -o '^[0-9a-f]\{8\} ' "$work/db-$compact.out" | head -1 | tr -d ' ')
    "$bin/vilma" eval --gt "$datasets/room-easy/mav0/state_groundtruth_estimate0/data.csv" \
      --est "$(ls "$work/traj-$compact"/*"$mission0"*)" --align posyaw \
      --json "$work/alignment-$compact.json" > /dev/null
    "$bin/vilma" localize "$datasets/room-s5" "$work/db-$compact.vlocmap" --every 2 \
      --align-from "$work/alignment-$compact.json" --quiet > "$work/db-$compact.localize" 2>&1
    anchored=$(grep -c -- '-> anchored' "$work/db-$compact.out" || true)
    loops=$(awk '/^lc: / { print $5; exit }' "$work/db-$compact.out")
    merged=$(grep -o '[0-9]* landmarks merged' "$work/db-$compact.out" | head -1 | awk '{ print $1 }')
    recall=$(localize_recall "$work/db-$compact.localize")
    echo "| $compact | $anchored of 3 | $loops | $merged | $recall % |"
  done
fi
