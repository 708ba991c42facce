#!/usr/bin/env bash
# Localizer acceptance benchmark (docs/localizer.md, "Acceptance: a wrong pose is never
# accepted"; issue 17 part 2): precision and recall of `Localizer::Localize` per data set.
# Prints one markdown table; every row is a data set:
#   - kitti *: the hard cases of eval/localization/kitti_scenarios.h made from the real KITTI slice
#     ../shared/data/kitti_slices/KITTI_sequence_1 (maps built with the ground-truth poses);
#   - euroc even-odd / halves (+ swapped-80, corner, few-keypoints): the 100 real EuRoC V1_01
#     stereo keyframes (../shared/data/euroc_V1_01_keyframes): a map of the even keyframes
#     (or of the first 50) from `vilma map-from-poses` (ground-truth poses, G = W) and
#     `vilma locmap build`, queried with the odd keyframes (or the last 50), which it never saw;
#   - euroc moving / micro: the other real V1_01 slices (../shared/data/euroc_V1_01_moving: 90
#     consecutive frames in motion; euroc_V1_01_micro: the static start, every 5th frame) against
#     a map of the keyframes more than 1 s away from both slices' time spans (95 of 100), so no
#     query image is in the map;
#   - sim room-s2..s5 (+ swapped-80): the simulated sessions of scripts/make-datasets.sh, every
#     10th frame, against a ground-truth map of room-easy (vilma-locmap-gt).
# Columns: queries; possible (a correct answer is in the matches: >= 12 reproject within 4 px
# under the ground truth); accepted (status ok); accepted wrong (> 0.3 m or > 2 deg); recall =
# accepted correct / possible; median error of the accepted; rejection reasons.
#
# Usage: scripts/bench-localizer-acceptance.sh [--config LOCALIZER.yaml] [--features F.yaml]
#                                             [--queries]
#   --features F.yaml      other query features for the EuRoC and sim rows (like
#                          config/localization_features.yaml; KITTI has its own profile)
#   --queries              also print every query's line (status, errors, every gate's value)
#                          before its data set's row
#   VILMA_BUILD_DIR        build folder (bin/vilma-loc-acceptance, bin/vilma, bin/vilma-locmap-gt)
#   VILMA_SHARED_DATA_DIR  real slices (default ../shared/data beside the repository)
#   VILMA_DATASETS         simulated sets (default ~/.cache/vilma/datasets; missing ones are
#                          made with scripts/make-datasets.sh)
#   BENCH_WORK             maps and outputs (default ~/.cache/vilma/loc-acceptance)
#   BENCH_SETS             subset: any of "kitti euroc sim" (default all three)
# Takes ~5 minutes on 2 cores (maps are reused while newer than their inputs and binaries).
set -euo pipefail

repo_dir=$(cd "$(dirname "$0")/.." && pwd)
build_dir=${VILMA_BUILD_DIR:-$repo_dir/build}
cache=${VILMA_CACHE:-$HOME/.cache/vilma}
shared=${VILMA_SHARED_DATA_DIR:-$repo_dir/../shared/data}
datasets=${VILMA_DATASETS:-$cache/datasets}
work=${BENCH_WORK:-$cache/loc-acceptance}
sets=${BENCH_SETS:-kitti euroc sim}
bin=$build_dir/bin
config=()
features=()
while [ $# -gt 0 ]; do
  case "$1" in
    --config) [ $# -ge 2 ] || { echo "bench-localizer-acceptance: --config: expected a file" >&2; exit 2; }
              config+=(--config "$2"); shift 2 ;;
    --features) [ $# -ge 2 ] || { echo "bench-localizer-acceptance: --features: expected a file" >&2; exit 2; }
                features+=(--features "$2"); shift 2 ;;
    --queries) config+=(--queries); shift ;;
    -h | --help) sed -n '2,/^set -euo/p' "$0" | grep '^#' | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "bench-localizer-acceptance: unknown argument '$1'" >&2; exit 2 ;;
  esac
done
for exe in vilma-loc-acceptance vilma vilma-locmap-gt; do
  [ -x "$bin/$exe" ] || { echo "bench-localizer-acceptance: $bin/$exe not built" >&2; exit 1; }
done
mkdir -p "$work"
acc=$bin/vilma-loc-acceptance

# stale OUTPUT INPUT...: true when OUTPUT is missing or older than an input.
stale() {
  local out=$1
  shift
  [ -e "$out" ] || return 0
  local f
  for f in "$@"; do [ "$f" -nt "$out" ] && return 0; done
  return 1
}

# subset_dataset SRC DST FILTER: an ASL folder DST whose cam0/cam1 data.csv keep the rows
# (after the header) that FILTER selects: "even" (row number n, 0-based, even), "first50"
# (n < 50) or "away" (stamp more than 1 s outside the spans of the moving and micro slices);
# images, IMU, ground truth and calibration are links into SRC.
subset_dataset() {
  local src=$1 dst=$2 filter=$3 cam spans=""
  if [ "$filter" = away ]; then
    # explicit exits: euroc_map runs in a command substitution, where bash clears set -e
    spans=$(span_of moving euroc_V1_01_moving) || exit 1
    spans="$spans $(span_of micro euroc_V1_01_micro)" || exit 1
  fi
  rm -rf "$dst"
  mkdir -p "$dst/mav0"
  for d in imu0 state_groundtruth_estimate0; do ln -s "$src/mav0/$d" "$dst/mav0/$d"; done
  [ -e "$src/mav0/body.yaml" ] && ln -s "$src/mav0/body.yaml" "$dst/mav0/body.yaml"
  for cam in cam0 cam1; do
    mkdir -p "$dst/mav0/$cam"
    ln -s "$src/mav0/$cam/data" "$dst/mav0/$cam/data"
    [ -e "$src/mav0/$cam/sensor.yaml" ] && ln -s "$src/mav0/$cam/sensor.yaml" "$dst/mav0/$cam/sensor.yaml"
    # shellcheck disable=SC2086  # $spans is a list of awk -v assignments
    awk -F, -v F="$filter" $spans '
      NR == 1 { print; next }
      F == "even" && (NR - 2) % 2 == 0 { print }
      F == "first50" && NR - 2 < 50 { print }
      F == "away" && ($1 + 0 < moving_first - 1e9 || $1 + 0 > moving_last + 1e9) &&
                     ($1 + 0 < micro_first - 1e9 || $1 + 0 > micro_last + 1e9) { print }' \
      "$src/mav0/$cam/data.csv" > "$dst/mav0/$cam/data.csv"
  done
}

# span_of NAME SLICE: awk assignments NAME_first / NAME_last = the first and last cam0 stamps
# [ns] of a real slice (as doubles: 1 s windows need no more than 256 ns).
span_of() {
  local csv=$shared/$2/mav0/cam0/data.csv
  [ -f "$csv" ] || { echo "bench-localizer-acceptance: $csv missing" >&2; exit 1; }
  awk -F, -v N="$1" 'NR > 1 && $1 ~ /^[0-9]+$/ { if (first == "") first = $1; last = $1 }
    END { printf "-v %s_first=%s -v %s_last=%s", N, first, N, last }' "$csv"
}

# euroc_map NAME FILTER: the .vlocmap of the keyframes FILTER selects (ground-truth poses).
euroc_map() {
  local name=$1 filter=$2 kf=$shared/euroc_V1_01_keyframes
  local map=$work/euroc-$name.vlocmap
  if stale "$map" "$bin/vilma" "$kf/mav0/cam0/data.csv"; then
    subset_dataset "$kf" "$work/euroc-$name-data" "$filter" || exit 1
    rm -rf "$work/euroc-$name-vimap"
    "$bin/vilma" map-from-poses "$work/euroc-$name-data" --out "$work/euroc-$name-vimap" \
      > "$work/euroc-$name-vimap.out" 2>&1 || { cat "$work/euroc-$name-vimap.out" >&2; exit 1; }
    "$bin/vilma" locmap build "$work/euroc-$name-vimap" "$map" > "$work/euroc-$name-locmap.out" 2>&1 ||
      { cat "$work/euroc-$name-locmap.out" >&2; exit 1; }
  fi
  echo "$map"
}

"$acc" header
for set in $sets; do
  case "$set" in
    kitti)
      kitti=$shared/kitti_slices/KITTI_sequence_1
      [ -d "$kitti" ] || { echo "bench-localizer-acceptance: $kitti missing" >&2; exit 1; }
      "$acc" kitti "$kitti" "${config[@]}"
      ;;
    euroc)
      kf=$shared/euroc_V1_01_keyframes
      [ -d "$kf" ] || { echo "bench-localizer-acceptance: $kf missing" >&2; exit 1; }
      even=$(euroc_map even even)
      first=$(euroc_map first50 first50)
      "$acc" asl "$kf" "$even" --first 1 --every 2 --name "euroc even-odd" "${config[@]}" "${features[@]}"
      "$acc" asl "$kf" "$first" --first 50 --name "euroc halves" "${config[@]}" "${features[@]}"
      "$acc" asl "$kf" "$even" --first 1 --every 2 --swap 0.8 --name "euroc even-odd swapped-80" "${config[@]}" "${features[@]}"
      "$acc" asl "$kf" "$even" --first 1 --every 2 --box 0,0,0.4,0.5 --name "euroc even-odd corner" "${config[@]}" "${features[@]}"
      "$acc" asl "$kf" "$even" --first 1 --every 2 --max-keypoints 60 --name "euroc even-odd few-keypoints" "${config[@]}" "${features[@]}"
      away=$(euroc_map away away)
      "$acc" asl "$shared/euroc_V1_01_moving" "$away" --name "euroc moving" "${config[@]}" "${features[@]}"
      "$acc" asl "$shared/euroc_V1_01_micro" "$away" --every 5 --name "euroc micro" "${config[@]}" "${features[@]}"
      ;;
    sim)
      VILMA_SIM=$bin/vilma-sim bash "$repo_dir/scripts/make-datasets.sh" --out "$datasets" \
        --only room-easy,room-s2,room-s3,room-s4,room-s5 > /dev/null
      map=$work/room-easy-gt.vlocmap
      if stale "$map" "$bin/vilma-locmap-gt" "$datasets/room-easy/sim.yaml"; then
        "$bin/vilma-locmap-gt" "$datasets/room-easy" "$map" > "$work/room-easy-gt.out" 2>&1 ||
          { cat "$work/room-easy-gt.out" >&2; exit 1; }
      fi
      for q in room-s2 room-s3 room-s4 room-s5; do
        "$acc" asl "$datasets/$q" "$map" --every 10 --name "sim $q" "${config[@]}" "${features[@]}"
      done
      "$acc" asl "$datasets/room-s2" "$map" --every 10 --swap 0.8 --name "sim room-s2 swapped-80" "${config[@]}" "${features[@]}"
      ;;
    *) echo "bench-localizer-acceptance: BENCH_SETS: unknown set '$set' (kitti euroc sim)" >&2; exit 2 ;;
  esac
done
