#!/usr/bin/env bash
# The paper's summarization figure on simulation (docs/summarization.md): a database of four
# mapping sessions of the room (room-easy, room-s2..s4, each mapped by vilma-estimatord, merged
# and loop-closed in the console: load_merge_all_maps; aam; lc; rtl), a fifth session (room-s5)
# as queries: every 2nd frame localized with `vilma localize` against the database's .vlocmap,
# success = within 0.5 m of the ground truth, with ONE fixed alignment (mission 0's vertices
# to its ground truth, posyaw).
# Rows: pruning fraction 0, 0.5, 0.75, 0.9, 0.95, 0.98; for ilp, random and most_observed
# (landmark_sparsify), each without and with kfh before it. Columns: landmarks kept, .vlocmap
# size, recall. Then the daemon in LOC mode on room-s5 against the full map and summarized ones
# (global RMSE with the same alignment, share of VILMA_LOC fixes within 0.5 m).
# Prints markdown tables; writes $work/summarization.csv and $work/summarization.png.
#
# Usage: scripts/bench-summarization.sh [--every N] [--fractions "0 0.5 ..."]
#   (VILMA_BUILD_DIR, VILMA_DATASETS as bench-optvi.sh; work: ~/.cache/vilma/summarization)
set -euo pipefail

repo_dir=$(cd "$(dirname "$0")/.." && pwd)
build_dir=${VILMA_BUILD_DIR:-$repo_dir/build}
cache=${VILMA_CACHE:-$HOME/.cache/vilma}
datasets=${VILMA_DATASETS:-$cache/datasets}
work=${BENCH_WORK:-$cache/summarization}
bin=$build_dir/bin
every=2
fractions="0 0.5 0.75 0.9 0.95 0.98"
while [ $# -gt 0 ]; do
  case $1 in
    --every) every=$2; shift 2 ;;
    --fractions) fractions=$2; shift 2 ;;
    -h | --help) sed -n '2,16p' "$0"; exit 0 ;;
    *) echo "bench-summarization.sh: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done
mkdir -p "$work"
# shellcheck source=lib/vio-map.sh
. "$repo_dir/scripts/lib/vio-map.sh"
sessions=(room-easy room-s2 room-s3 room-s4)
query=room-s5
VILMA_SIM=$bin/vilma-sim bash "$repo_dir/scripts/make-datasets.sh" --out "$datasets" \
  --only "room-easy,room-s2,room-s3,room-s4,$query" >&2
gt_of() { echo "$datasets/$1/mav0/state_groundtruth_estimate0/data.csv"; }

# 1. The four sessions mapped by the daemon (VIO poses, unknown baseframes).
rm -rf "$work/maps" && mkdir -p "$work/maps"
for s in "${sessions[@]}"; do ln -s "$(vio_map "$s")" "$work/maps/$s"; done

# 2. The databases: merged, anchored, loop-closed (full); the same keyframed (kfh).
if stale "$work/db-kfh/done" "${work}"/*-map.out "$bin/vilma"; then
  rm -rf "$work/db-full" "$work/db-kfh" "$work/traj" && mkdir -p "$work/traj"
  "$bin/vilma" console -c "load_merge_all_maps $work/maps --map_key=db; aam; lc; rtl; ms; \
    ettc --out=$work/traj --format=asl --frame=G; save --out=$work/db-full; kfh; rtl; ms; \
    save --out=$work/db-kfh" > "$work/db.out" 2>&1 || { cat "$work/db.out" >&2; exit 1; }
  touch "$work/db-kfh/done"
fi
# The one alignment: mission 0 (room-easy, loaded first) against its ground truth.
mission0=$(grep -o '^[0-9a-f]\{8\} ' "$work/db.out" | head -1 | tr -d ' ')
"$bin/vilma" eval --gt "$(gt_of room-easy)" --est "$(ls "$work/traj"/*"$mission0"*)" \
  --align posyaw --json "$work/alignment.json" > "$work/alignment.txt"

# 3. Every summarized variant: one console run per database (copy, lsparsify, summary_map).
csv=$work/summarization.csv
echo "database,method,pruning,landmarks,vlocmap_mb,recall_percent" > "$csv"
for db in full kfh; do
  script=$work/variants-$db.vilma
  echo "load $work/db-$db --map_key=db" > "$script"
  for p in $fractions; do
    for method in ilp random most_observed; do
      name=$db-$method-$p
      keep=$(awk -v p="$p" 'BEGIN { printf "%.4f", 1 - p }')
      {
        echo "copy_map v; select v"
        if [ "$p" != 0 ]; then
          echo "lsparsify --lsparsify_keep_fraction=$keep --lsparsify_method=$method"
        fi
        echo "summary_map $work/$name.vlocmap"
        echo "select db; delete_map v"
      } >> "$script"
      if [ "$p" = 0 ]; then break; fi  # nothing pruned: one row
    done
  done
  "$bin/vilma" console --script "$script" > "$work/variants-$db.out" 2>&1 ||
    { cat "$work/variants-$db.out" >&2; exit 1; }
  for p in $fractions; do
    for method in ilp random most_observed; do
      name=$db-$method-$p
      "$bin/vilma" localize "$datasets/$query" "$work/$name.vlocmap" --every "$every" \
        --align-from "$work/alignment.json" --quiet > "$work/$name.localize" 2>&1 ||
        { cat "$work/$name.localize" >&2; exit 1; }
      landmarks=$("$bin/vilma" locmap info "$work/$name.vlocmap" | awk '/^  landmarks/ { print $2 }')
      mb=$(awk -v b="$(stat -c %s "$work/$name.vlocmap")" 'BEGIN { printf "%.2f", b / 1e6 }')
      echo "$db,$method,$p,$landmarks,$mb,$(localize_recall "$work/$name.localize")" >> "$csv"
      if [ "$p" = 0 ]; then break; fi
    done
  done
done

echo "| database | pruning | landmarks (ilp) | .vlocmap MB (ilp) | recall ilp | recall random | recall most observed |"
echo "|---|---:|---:|---:|---:|---:|---:|"
for db in full kfh; do
  for p in $fractions; do
    awk -F, -v db="$db" -v p="$p" '
      $1 == db && $3 == p { l[$2] = $4; m[$2] = $5; r[$2] = $6 }
      END {
        if (p == 0) { r["random"] = r["ilp"]; r["most_observed"] = r["ilp"] }
        printf "| %s | %s | %s | %s | %s %% | %s %% | %s %% |\n", db, p, l["ilp"], m["ilp"],
               r["ilp"], r["random"], r["most_observed"]
      }' "$csv"
  done
done
# 4. The daemon (LOC mode) on room-s5 against the full map and summarized ones.
set_log "$query" || exit 1
echo
echo "| vilma-estimatord LOC mode, room-s5 against | .vlocmap MB | global RMSE [m] | VILMA_LOC fixes within 0.5 m |"
echo "|---|---:|---:|---|"
for variant in full-ilp-0 kfh-ilp-0 full-ilp-0.9 kfh-ilp-0.9 kfh-ilp-0.95; do
  [ -e "$work/$variant.vlocmap" ] || continue
  "$bin/vilma-estimatord" --rig "$datasets/$query/rig.yaml" --input-log "$work/$query.lcmlog" \
    --localization-map "$work/$variant.vlocmap" --lcm-url "file://$work/$variant-loc.lcm?mode=w" \
    > "$work/$variant-loc.out" 2>&1 || { cat "$work/$variant-loc.out" >&2; exit 1; }
  "$bin/vilma-lcm-poses" "$work/$variant-loc.lcm" --out "$work/$variant-pose.txt" > /dev/null
  "$bin/vilma-lcm-poses" "$work/$variant-loc.lcm" --channel VILMA_LOC \
    --out "$work/$variant-locfix.txt" > /dev/null 2>&1 || true
  "$bin/vilma" eval --gt "$(gt_of "$query")" --est "$work/$variant-pose.txt" \
    --align-from "$work/alignment.json" > "$work/$variant-pose.eval"
  within="no fix"
  if [ -s "$work/$variant-locfix.txt" ]; then
    "$bin/vilma" eval --gt "$(gt_of "$query")" --est "$work/$variant-locfix.txt" \
      --align-from "$work/alignment.json" --within 0.5 > "$work/$variant-locfix.eval"
    within=$(grep '^within' "$work/$variant-locfix.eval" | head -1)
  fi
  mb=$(awk -v b="$(stat -c %s "$work/$variant.vlocmap")" 'BEGIN { printf "%.2f", b / 1e6 }')
  echo "| $variant | $mb | $(ate_rmse "$work/$variant-pose.eval") | $within |"
done
echo
py=/usr/bin/python3; [ -x "$py" ] || py=python3  # Debian's, with python3-matplotlib
"$py" "$repo_dir/scripts/plot_summarization.py" "$csv" "$work/summarization.png" ||
  echo "(no plot: python3-matplotlib missing)"
echo "plot: $work/summarization.png"
