#!/usr/bin/env bash
# Dense reconstruction benchmark (docs/dense.md, docs/benchmarks.md "Dense reconstruction").
#
# Simulated room (room-easy, stereo), 5 cm voxels, 0.15 m truncation, judged against the
# simulator's true surfaces (eval_mesh: accuracy = mesh vertices to the surfaces, completeness =
# seen surface within 5 cm of the mesh):
#   gt-true     map from the ground-truth poses (every 5th frame), depth ray-cast in the world
#               (attach_true_depth): the TSDF stage alone
#   gt-stereo   the same map, SGBM depth (stereo_dense_reconstruction): stereo + TSDF
#   gt-hh       the same, tuned for accuracy: SGBM with 8 paths (--sgbm_mode hh), 7 px blocks,
#               surface seen by fewer than 9 depth maps left out (--dense_mesh_min_weight 9)
#   opt-stereo  the daemon's VIO map of room-easy, kfh; optvi (its own poses), SGBM depth,
#               aligned to the ground truth by its vertices (posyaw)
#   opt-hh      the same map with gt-hh's settings
# Real data, no true surfaces: depth consistency of neighbouring keyframes, timings, a picture:
#   euroc       ../shared/data/euroc_V1_01_keyframes, map from the ground-truth poses
#   kitti       ../shared/data/kitti_slices/KITTI_sequence_1 (vilma dense-kitti, given poses)
# Prints a markdown table; pictures go to $work/*.png (docs/images/ has copies).
#
# Usage: scripts/bench-dense.sh [--only ROW[,ROW...]]
#   VILMA_BUILD_DIR (build), VILMA_DATASETS (~/.cache/vilma/datasets), VILMA_SHARED_DATA_DIR
#   (../shared/data); work: ~/.cache/vilma/dense-bench
set -euo pipefail

repo_dir=$(cd "$(dirname "$0")/.." && pwd)
build_dir=${VILMA_BUILD_DIR:-$repo_dir/build}
cache=${VILMA_CACHE:-$HOME/.cache/vilma}
datasets=${VILMA_DATASETS:-$cache/datasets}
shared=${VILMA_SHARED_DATA_DIR:-$repo_dir/../shared/data}
work=${BENCH_WORK:-$cache/dense-bench}
bin=$build_dir/bin
only="gt-true,gt-stereo,gt-hh,opt-stereo,opt-hh,euroc,kitti"
while [ $# -gt 0 ]; do
  case $1 in
    --only) only=$2; shift 2 ;;
    -h | --help) sed -n '2,24p' "$0"; exit 0 ;;
    *) echo "bench-dense.sh: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done
wants() { [[ ",$only," == *",$1,"* ]]; }
mkdir -p "$work"
# shellcheck source=lib/vio-map.sh
. "$repo_dir/scripts/lib/vio-map.sh"
VILMA_SIM=$bin/vilma-sim bash "$repo_dir/scripts/make-datasets.sh" --out "$datasets" \
  --only room-easy >&2
room=$datasets/room-easy
tsdf="create_tsdf_from_depth_resource --dense_tsdf_voxel_size_m 0.05 \
  --dense_tsdf_truncation_distance_m 0.15"
accurate_depth="stereo_dense_reconstruction --sgbm_mode hh --sgbm_block_size 7"

# console ROW MAP COMMANDS: runs the console on MAP, output in $work/ROW.out.
console() {
  local row=$1 map=$2
  shift 2
  "$bin/vilma" console "$map" -c "$*" > "$work/$row.out" 2>&1 ||
    { cat "$work/$row.out" >&2; echo "bench-dense.sh: $row failed" >&2; exit 1; }
}
# Figures of a row's output (empty when the row has no such figure).
depth_ms() { sed -n 's/.*, \([0-9.]*\) ms median per map).*/\1/p' "$1" | tail -1; }
fuse_ms() { sed -n 's/.*MiB, \([0-9.]*\) ms median per integration.*/\1/p' "$1" | tail -1; }
tsdf_mib() { sed -n 's/^TSDF: .* volume units, \([0-9.]*\) MiB.*/\1/p' "$1" | tail -1; }
consistency() { sed -n 's/.*points: median \([0-9.]*\) m, p90 [0-9.]* m, median relative \([0-9.]*\) %.*/\1 m (\2 %)/p' "$1" | tail -1; }
json_field() { python3 -c "import json,sys; print('%.${3:-4}f' % json.load(open(sys.argv[1]))[sys.argv[2]])" "$1" "$2"; }

rows=()
add_row() { rows+=("| $1 | $2 | $3 | $4 | $5 | $6 | $7 | $8 |"); }
mesh_row() {  # ROW DESCRIPTION: a row judged against the true surfaces
  local row=$1 json=$work/$1.json
  local acc_med acc_p90 comp
  acc_med=$(python3 -c "import json; print('%.2f' % (100 * json.load(open('$json'))['accuracy_median_m']))")
  acc_p90=$(python3 -c "import json; print('%.2f' % (100 * json.load(open('$json'))['accuracy_p90_m']))")
  comp=$(python3 -c "import json; print('%.1f' % (100 * json.load(open('$json'))['completeness']))")
  add_row "$2" "$acc_med / $acc_p90" "$comp" "$(depth_ms "$work/$row.out")" \
    "$(fuse_ms "$work/$row.out")" "$(tsdf_mib "$work/$row.out")" \
    "$(consistency "$work/$row.out")" "$(json_field "$json" mesh_vertices 0)"
}

# The room map from the ground-truth poses (every 5th frame), with its images.
gt_map=$work/room-gt5
if wants gt-true || wants gt-stereo || wants gt-hh; then
  if stale "$gt_map/done" "$room/sim.yaml" "$bin/vilma"; then
    rm -rf "$gt_map"
    "$bin/vilma" map-from-poses "$room" --out "$gt_map" --every 5 > "$work/room-gt5.out" 2>&1
    "$bin/vilma" console "$gt_map" -c "attach_images $room; save --overwrite" \
      >> "$work/room-gt5.out" 2>&1
    touch "$gt_map/done"
  fi
fi
if wants gt-true; then
  console gt-true "$gt_map" "attach_true_depth $room --max_depth_m 6; $tsdf \
    --dense_depth_filter_neighbours 0 --dense_mesh_min_weight 0; depth_consistency; \
    eval_mesh $room --align none --json $work/gt-true.json"
  mesh_row gt-true "room, true poses, true depth (TSDF alone)"
fi
if wants gt-stereo; then
  console gt-stereo "$gt_map" "stereo_dense_reconstruction; depth_consistency; $tsdf; \
    export_tsdf $work/room.ply; eval_mesh $room --align none --json $work/gt-stereo.json \
    --error_mesh_output_file $work/room-error.ply; \
    render_mesh $work/room.ply $work/room.png --view custom --elevation_deg 60 \
      --clip_above_z_m 2.5; \
    render_mesh $work/room-error.ply $work/room-error.png --view custom --elevation_deg 60 \
      --clip_above_z_m 2.5"
  mesh_row gt-stereo "room, true poses, SGBM depth (defaults)"
fi
if wants gt-hh; then
  console gt-hh "$gt_map" "$accurate_depth; depth_consistency; $tsdf --dense_mesh_min_weight 9; \
    eval_mesh $room --align none --json $work/gt-hh.json"
  mesh_row gt-hh "room, true poses, SGBM hh 7 px, mesh min weight 9"
fi
if wants opt-stereo; then
  vio=$(vio_map room-easy)
  console opt-stereo "$vio" "kfh; optvi; eval_map $room; attach_images $room; \
    stereo_dense_reconstruction; depth_consistency; $tsdf; \
    eval_mesh $room --json $work/opt-stereo.json"
  mesh_row opt-stereo "room, VIO map after kfh; optvi, SGBM depth (posyaw-aligned)"
fi
if wants opt-hh; then
  vio=$(vio_map room-easy)
  console opt-hh "$vio" "kfh; optvi; attach_images $room; $accurate_depth; depth_consistency; \
    $tsdf --dense_mesh_min_weight 9; eval_mesh $room --json $work/opt-hh.json"
  mesh_row opt-hh "room, VIO map after kfh; optvi, SGBM hh 7 px, mesh min weight 9"
fi
if wants euroc; then
  euroc=$shared/euroc_V1_01_keyframes
  if stale "$work/euroc-kf/done" "$bin/vilma"; then
    rm -rf "$work/euroc-kf"
    "$bin/vilma" map-from-poses "$euroc" --out "$work/euroc-kf" > "$work/euroc-kf.out" 2>&1
    "$bin/vilma" console "$work/euroc-kf" -c "attach_images $euroc \
      --max_time_difference_s 0.01; save --overwrite" >> "$work/euroc-kf.out" 2>&1
    touch "$work/euroc-kf/done"
  fi
  console euroc "$work/euroc-kf" "stereo_dense_reconstruction; depth_consistency; $tsdf \
    --dense_tsdf_max_depth_m 5; export_tsdf $work/euroc.ply; \
    render_mesh $work/euroc.ply $work/euroc.png"
  add_row "EuRoC V1_01 keyframes (real), true poses, SGBM depth" "-" "-" \
    "$(depth_ms "$work/euroc.out")" "$(fuse_ms "$work/euroc.out")" "$(tsdf_mib "$work/euroc.out")" \
    "$(consistency "$work/euroc.out")" \
    "$(sed -n 's/^wrote .*: \([0-9]*\) vertices.*/\1/p' "$work/euroc.out")"
fi
if wants kitti; then
  "$bin/vilma" dense-kitti "$shared/kitti_slices/KITTI_sequence_1" --out "$work/kitti.ply" \
    --render "$work/kitti.png" > "$work/kitti.out"
  add_row "KITTI sequence 1 (real), given poses, SGBM depth, 10 cm voxels" "-" "-" \
    "$(sed -n 's/^depth per frame *\([0-9.]*\) ms.*/\1/p' "$work/kitti.out")" \
    "$(sed -n 's/^integration per frame *\([0-9.]*\) ms.*/\1/p' "$work/kitti.out")" \
    "$(sed -n 's/^TSDF .* units, \([0-9.]*\) MiB/\1/p' "$work/kitti.out")" \
    "$(consistency "$work/kitti.out")" \
    "$(sed -n 's/^mesh *\([0-9]*\) vertices.*/\1/p' "$work/kitti.out")"
fi

echo "| data, poses, depth | accuracy median / p90 [cm] | completeness [%] | depth map [ms] | integration [ms] | TSDF [MiB] | depth consistency median | mesh vertices |"
echo "|---|---|---|---|---|---|---|---|"
printf '%s\n' "${rows[@]}"
