#!/usr/bin/env bash
# Makes vilma's fixed, seeded synthetic benchmark datasets with vilma-sim (docs/simulator.md).
#
#   scripts/make-datasets.sh [--out DIR] [--only NAME[,NAME...]] [--mono] [--list] [--force]
#
# Default folder: ${VILMA_CACHE:-$HOME/.cache/vilma}/datasets (never the repository). Each set
# is an ASL/EuRoC folder DIR/NAME/ (mav0/..., rig.yaml, sim.yaml). The long sets (ON_DEMAND:
# room-long, 10 minutes, ~5 GB) are made only when named in --only. Sets that already exist with
# the same parameters are skipped (the key is stored in NAME/.vilma-sim-key); a set is written
# into NAME.partial/ and renamed when complete, so an interrupted run leaves nothing half-made.
# The vilma-sim binary is looked up in $VILMA_SIM, $VILMA_BUILD_DIR/bin, /work/build-sim/bin,
# <repo>/build/bin, then PATH.
set -euo pipefail

# revisit: 0 = the session draws its own path; S0 > 0 = it revisits session 0's path (made
# with --seconds S0; vilma-sim --revisit), so that re-localization has something to find.
# name        preset     seed session seconds revisit
SETS=(
  "room-easy  room       1    0       90      0"
  "room-fast  room-fast  1    0       60      0"
  "hall       hall       1    0       120     0"
  "street     street     1    0       120     0"
  "room-s2    room       1    1       60      90"
  "room-s3    room       1    2       60      90"
  "room-s4    room       1    3       60      90"
  "room-s5    room       1    4       60      90"
  "hall-s2    hall       1    1       60      120"
  "hall-s3    hall       1    2       60      120"
  "street-s2  street     1    1       60      120"
  "street-s3  street     1    2       60      120"
)
# Made only when named in --only: a 10-minute mission (bench-optvi.sh BENCH_LONG=1).
ON_DEMAND=(
  "room-long  room       1    0       600     0"
)
# Bump when the simulator's output changes, so that old caches are remade.
SIM_VERSION=2
# Bump when GenerateRevisitTrajectory changes (only the revisiting sets are remade).
REVISIT_VERSION=2

repo_dir="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
out_dir="${VILMA_CACHE:-$HOME/.cache/vilma}/datasets"
only=""
stereo="--stereo"
force=0
list=0

usage() { sed -n '2,12p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//'; }

while [[ $# -gt 0 ]]; do
  case "$1" in
    --out) out_dir="$2"; shift 2 ;;
    --only) only="$2"; shift 2 ;;
    --mono) stereo=""; shift ;;
    --force) force=1; shift ;;
    --list) list=1; shift ;;
    -h|--help) usage; exit 0 ;;
    *) echo "make-datasets.sh: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done

if [[ $list -eq 1 ]]; then
  printf '%s\n' "${SETS[@]}"
  printf '%s  (only with --only)\n' "${ON_DEMAND[@]}"
  exit 0
fi
all_sets=("${SETS[@]}")
if [[ -n "$only" ]]; then all_sets+=("${ON_DEMAND[@]}"); fi

find_sim() {
  local candidates=()
  [[ -n "${VILMA_SIM:-}" ]] && candidates+=("$VILMA_SIM")
  [[ -n "${VILMA_BUILD_DIR:-}" ]] && candidates+=("$VILMA_BUILD_DIR/bin/vilma-sim")
  candidates+=("/work/build-sim/bin/vilma-sim" "$repo_dir/build/bin/vilma-sim")
  for c in "${candidates[@]}"; do
    if [[ -x "$c" ]]; then echo "$c"; return 0; fi
  done
  command -v vilma-sim || return 1
}
sim="$(find_sim)" || {
  echo "make-datasets.sh: vilma-sim not found; build it (cmake --build BUILD --target vilma-sim)" \
       "or set VILMA_SIM / VILMA_BUILD_DIR" >&2
  exit 1
}

mkdir -p "$out_dir"
echo "datasets: $out_dir (vilma-sim: $sim)"
for line in "${all_sets[@]}"; do
  read -r name preset seed session seconds revisit <<<"$line"
  if [[ -n "$only" && ",$only," != *",$name,"* ]]; then continue; fi
  key="version=$SIM_VERSION preset=$preset seed=$seed session=$session seconds=$seconds stereo=${stereo:+1}"
  revisit_args=()
  if [[ "$revisit" != "0" ]]; then
    key="$key revisit=$revisit revisit_version=$REVISIT_VERSION"
    revisit_args=(--revisit "$revisit")
  fi
  dir="$out_dir/$name"
  if [[ $force -eq 0 && -f "$dir/.vilma-sim-key" && "$(cat "$dir/.vilma-sim-key")" == "$key" \
        && -f "$dir/mav0/imu0/data.csv" ]]; then
    echo "$name: up to date ($key)"
    continue
  fi
  echo "$name: making ($key)"
  rm -rf "$dir.partial"
  "$sim" "$preset" --out "$dir.partial" --seed "$seed" --session "$session" \
         --seconds "$seconds" $stereo "${revisit_args[@]}"
  echo "$key" > "$dir.partial/.vilma-sim-key"
  rm -rf "$dir"
  mv "$dir.partial" "$dir"
  echo "$name: $(du -sh "$dir" | cut -f1)"
done
