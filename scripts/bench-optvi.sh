#!/usr/bin/env bash
# Visual-inertial batch optimization benchmark (docs/optimization.md, docs/benchmarks.md
# "Optimization"). Five tables:
#   1. simulated: the daemon's VI-map of each set (vilma-estimatord --input-log --save-map: the
#      VIO's poses, no ground truth used), then `optvi` with its defaults, and `lc; rtl; optvi`
#      (loop closure merges re-observed landmarks first); `eval_map` before and
#      after: vertex ATE (posyaw), rotation, biases, good landmarks' reprojection and distance to
#      the simulator's true surfaces; optvi time, ms per iteration and peak memory.
#   2. real: ../shared/data/euroc_V1_01_keyframes (100 stereo keyframes over 135 s, real IMU
#      between them): `vilma map-from-poses --perturb 0.2,3 --seed 1` (ground truth moved by
#      0.2 m / 3 deg per keyframe), then the recipe `optvi; rtl; optvi; rtl; optvi; rtl; optvi`
#      (elq with 2 observers: stereo keyframes); also the map from unperturbed ground truth
#      through one optvi (how far the optimum lies from the ground truth).
#   3. COLMAP: visual-only bundle adjustment, optv against colmap bundle_adjuster and (like for
#      like: the stereo pair held) colmap rig_bundle_adjuster.
#   4. target: ../shared/data/euroc_imu_april (real hand-held motion and IMU, AprilGrid corners
#      with known target coordinates): `load_target_recording` (corners held as landmarks, PnP
#      poses) from EuRoC's calibration (config/euroc-rig.yaml), and from it moved by 2 cm / 2 deg,
#      and with a 5 ms clock shift injected into the camera stamps; `optvi` with the extrinsics,
#      the time offset and the baseframe tilt free; `target_calibration_report`: camera poses
#      against per-frame PnP, T_I_C against the calibration.
#   5. (BENCH_LONG=1, off by default: ~25 min at load 5-7 on the shared 2 cores, the set and its
#      map made once and cached) a 10-minute mission:
#      the simulated room-long set (600 s, `scripts/make-datasets.sh --only room-long`, ~5 GB),
#      its VIO map (`vilma vio --save-map`, cached), then `optvi`, `kfh; optvi`,
#      `lc; rtl; optvi --ba_linear_solver iterative_schur` (the merged landmarks make the reduced
#      camera matrix too dense for sparse_schur) and `lc; kfh; rtl; optvi` (ROVIOLI's end-of-run
#      order): vertices, good landmarks, observations, iterations, time per iteration, peak RSS,
#      vertex ATE before/after, load average.
#
# Usage: scripts/bench-optvi.sh [SET ...]     (default: room-easy hall street)
#   VILMA_BUILD_DIR, VILMA_DATASETS, BENCH_WORK (default ${VILMA_CACHE:-~/.cache/vilma}/bench-optvi),
#   VILMA_SHARED_DATA (default ../shared/data beside the repository); BENCH_REAL=0 skips table 2,
#   BENCH_COLMAP=0 table 3 (visual-only bundle adjustment against COLMAP's bundle_adjuster),
#   BENCH_SIM=0 table 1, BENCH_TARGET=0 table 4; VIO_MAP_DAEMON_CONFIG=daemon.yaml: table 1's
#   maps built with that daemon config (e.g. mapping.map_builder without track refinement, method "none"; use
#   its own BENCH_WORK); BENCH_SIM_PIPELINES: table 1's console pipelines separated by `|`
#   (default `optvi|lc; rtl; optvi`; `optvi` alone gives issue 12's target-1 rows);
#   MOVING_MAP_CONFIG: the real moving slice's map built with that map builder YAML;
#   BENCH_LONG=1 adds table 5 (BENCH_LONG_PIPELINES: its pipelines separated by `|`, default
#   the four above). On a shared machine run it under `nice -n 10`.
set -euo pipefail

repo_dir=$(cd "$(dirname "$0")/.." && pwd)
build_dir=${VILMA_BUILD_DIR:-$repo_dir/build}
cache=${VILMA_CACHE:-$HOME/.cache/vilma}
datasets=${VILMA_DATASETS:-$cache/datasets}
work=${BENCH_WORK:-$cache/bench-optvi}
shared=${VILMA_SHARED_DATA:-$repo_dir/../shared/data}
bin=$build_dir/bin
case "${1:-}" in
  -h|--help) sed -n '2,41p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
  -*) echo "bench-optvi: unknown option '$1' (see --help)" >&2; exit 2 ;;
esac
# The sets scripts/make-datasets.sh knows.
valid_sets=" $(bash "$(dirname "$0")/make-datasets.sh" --list | awk '{print $1}' | tr '\n' ' ')"
for set_name in "$@"; do
  [[ "$valid_sets" == *" $set_name "* ]] ||
    { echo "bench-optvi: unknown set '$set_name' (expected one of:$valid_sets)" >&2; exit 2; }
done
sets=("$@")
[ ${#sets[@]} -eq 0 ] && sets=(room-easy hall street)
for exe in vilma vilma-estimatord vilma-replay vilma-sim; do
  [ -x "$bin/$exe" ] || { echo "bench-optvi: $bin/$exe is not built" >&2; exit 1; }
done
mkdir -p "$work"
# shellcheck source=lib/vio-map.sh
. "$repo_dir/scripts/lib/vio-map.sh"
list=$(IFS=,; echo "${sets[*]}")
[ "${BENCH_SIM:-1}" = 0 ] ||
  VILMA_SIM=$bin/vilma-sim bash "$repo_dir/scripts/make-datasets.sh" --out "$datasets" --only "$list" >&2

# field FILE.json KEY [STAT]: a figure of an eval_map JSON (STAT: rmse, median, ...).
field() {
  python3 -c 'import json, sys
d = json.load(open(sys.argv[1])); v = d[sys.argv[2]]
print(v[sys.argv[3]] if isinstance(v, dict) else v)' "$1" "$2" "${3:-rmse}"
}
fmt() { awk -v v="$1" -v s="${2:-1}" -v d="${3:-4}" 'BEGIN { printf "%.*f", d, v * s }'; }
# console OUT SCRIPT: `vilma console -c SCRIPT` under /usr/bin/time (peak memory into OUT.rss).
console() {
  local out=$1
  shift
  /usr/bin/time -f "%M" -o "$out.rss" "$bin/vilma" console -c "$1" > "$out" 2>&1 ||
    { cat "$out" >&2; echo "bench-optvi: console failed ($out)" >&2; exit 1; }
}
# optvi_figure OUT NAME: from the optvi report in OUT: seconds (s), ms per iteration (ms),
# iterations (it).
optvi_figure() {
  case "$2" in
    s) grep -o '^optvi: .* px, [0-9.e+-]* s$' "$1" | tail -1 | awk '{ print $(NF - 1) }' ;;
    ms) grep -o '[0-9.]* ms per iteration' "$1" | tail -1 | awk '{ print $1 }' ;;
    it) grep -o 'in [0-9]* iterations' "$1" | tail -1 | awk '{ print $2 }' ;;
  esac
}

[ "${BENCH_SIM:-1}" = 0 ] && sets=()
if [ ${#sets[@]} -gt 0 ]; then
echo "### Simulated: daemon VI-maps (VIO poses) -> optvi, and lc; rtl; optvi"
echo
echo "| set | pipeline | vertices | good landmarks | ATE [m] VIO -> after (ratio) | rotation [deg] | gyro bias err [rad/s] | accel bias err [m/s^2] | landmarks to surfaces, median [cm] | reprojection RMSE [px] | optvi [s] (iterations, ms/iteration) | console [s] | peak RSS [MB] |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|"
for set in "${sets[@]}"; do
  map=$(vio_map "$set")
  d=$datasets/$set
  IFS='|' read -r -a pipelines <<< "${BENCH_SIM_PIPELINES:-optvi|lc; rtl; optvi}"
  for pipeline in "${pipelines[@]}"; do
    pipeline=$(echo "$pipeline" | sed 's/^ *//; s/ *$//')
    out=$work/$set-$(echo "$pipeline" | tr -d ' ;')
    start_s=$(date +%s.%N)
    console "$out.console" "load $map; eval_map $d --json=$out.before.json; $pipeline; \
      eval_map $d --json=$out.after.json; cmc; save --out=$out.map --overwrite"
    seconds=$(awk -v a="$start_s" -v b="$(date +%s.%N)" 'BEGIN { printf "%.1f", b - a }')
    b=$out.before.json a=$out.after.json
    printf '| %s | `%s` | %s | %s | %s -> %s (%s) | %s -> %s | %s -> %s | %s -> %s | %s -> %s | %s -> %s | %s (%s, %s) | %s | %s |\n' \
      "$set" "$pipeline" "$(field "$b" vertices)" "$(field "$a" good_landmarks)" \
      "$(fmt "$(field "$b" ate_translation_m)")" "$(fmt "$(field "$a" ate_translation_m)")" \
      "$(awk -v x="$(field "$a" ate_translation_m)" -v y="$(field "$b" ate_translation_m)" 'BEGIN { printf "%.2f", x / y }')" \
      "$(fmt "$(field "$b" ate_rotation_deg)" 1 3)" "$(fmt "$(field "$a" ate_rotation_deg)" 1 3)" \
      "$(fmt "$(field "$b" gyro_bias_error median)" 1 5)" "$(fmt "$(field "$a" gyro_bias_error median)" 1 5)" \
      "$(fmt "$(field "$b" accel_bias_error median)" 1 4)" "$(fmt "$(field "$a" accel_bias_error median)" 1 4)" \
      "$(fmt "$(field "$b" surface_distance_m median)" 100 2)" "$(fmt "$(field "$a" surface_distance_m median)" 100 2)" \
      "$(fmt "$(field "$b" reprojection_px)" 1 3)" "$(fmt "$(field "$a" reprojection_px)" 1 3)" \
      "$(fmt "$(optvi_figure "$out.console" s)" 1 1)" "$(optvi_figure "$out.console" it)" \
      "$(fmt "$(optvi_figure "$out.console" ms)" 1 0)" "$seconds" \
      "$(awk -v k="$(cat "$out.console.rss")" 'BEGIN { printf "%.0f", k / 1024 }')"
  done
done
fi

kf=$shared/euroc_V1_01_keyframes
if [ "${BENCH_REAL:-1}" = 0 ]; then
  :
elif [ ! -d "$kf" ]; then
  echo "bench-optvi: $kf missing: no real-data table" >&2
else
  echo
  echo "### Real: EuRoC V1_01, 100 stereo keyframes, real IMU between them"
  echo
  echo "| start | map | ATE [m] before -> after | rotation [deg] | gyro bias err [rad/s] | accel bias err [m/s^2] | reprojection RMSE [px] | good landmarks after | console [s] |"
  echo "|---|---|---|---|---|---|---|---|---|"
  for start in perturbed gt; do
    map=$work/euroc-kf-$start
    if stale "$map/manifest.yaml" "$bin/vilma" || [ ! -d "$map" ]; then
      rm -rf "$map"
      args=()
      [ "$start" = perturbed ] && args=(--perturb 0.2,3 --seed 1)
      "$bin/vilma" map-from-poses "$kf" --out "$map" "${args[@]}" > "$map.out" 2>&1 ||
        { cat "$map.out" >&2; exit 1; }
    fi
    out=$work/euroc-kf-$start-optvi
    if [ "$start" = perturbed ]; then
      recipe="optvi --evaluate_quality=false; rtl; optvi --evaluate_quality=false; rtl; \
        optvi --evaluate_quality=false; rtl; optvi"
      label="0.2 m / 3 deg off, optvi; rtl x3; optvi"
    else
      recipe="optvi"
      label="ground truth, optvi"
    fi
    start_s=$(date +%s.%N)
    console "$out.console" "load $map; set elq_min_observers 2; eval_map $kf --json=$out.before.json; \
      $recipe; eval_map $kf --json=$out.after.json; cmc"
    seconds=$(awk -v a="$start_s" -v b="$(date +%s.%N)" 'BEGIN { printf "%.1f", b - a }')
    b=$out.before.json a=$out.after.json
    printf '| %s | map-from-poses | %s -> %s | %s -> %s | %s -> %s | %s -> %s | %s -> %s | %s | %s |\n' \
      "$label" "$(fmt "$(field "$b" ate_translation_m)")" "$(fmt "$(field "$a" ate_translation_m)")" \
      "$(fmt "$(field "$b" ate_rotation_deg)" 1 3)" "$(fmt "$(field "$a" ate_rotation_deg)" 1 3)" \
      "$(fmt "$(field "$b" gyro_bias_error median)" 1 5)" "$(fmt "$(field "$a" gyro_bias_error median)" 1 5)" \
      "$(fmt "$(field "$b" accel_bias_error median)" 1 4)" "$(fmt "$(field "$a" accel_bias_error median)" 1 4)" \
      "$(fmt "$(field "$b" reprojection_px)" 1 3)" "$(fmt "$(field "$a" reprojection_px)" 1 3)" \
      "$(field "$a" good_landmarks)" "$seconds"
  done
fi

# 2b. The VIO's own map of the real moving slice (vilma vio --save-map: the filter's poses, the
#     map builder's landmarks), then optvi: the vertex ATE (posyaw) against the slice's ground truth.
moving=$shared/euroc_V1_01_moving
if [ "${BENCH_REAL:-1}" != 0 ] && [ -d "$moving" ]; then
  out=$work/euroc-moving
  rm -rf "$out.map"
  moving_args=()
  [ -n "${MOVING_MAP_CONFIG:-}" ] && moving_args=(--map-config "$MOVING_MAP_CONFIG")
  "$bin/vilma" vio "$moving" --out "$out.txt" --save-map "$out.map" "${moving_args[@]}" \
    > "$out.vio" 2>&1 ||
    { cat "$out.vio" >&2; exit 1; }
  start_s=$(date +%s.%N)
  console "$out.console" "load $out.map; eval_map $moving --json=$out.before.json; optvi; \
    eval_map $moving --json=$out.after.json; cmc"
  seconds=$(awk -v a="$start_s" -v b="$(date +%s.%N)" 'BEGIN { printf "%.1f", b - a }')
  b=$out.before.json a=$out.after.json
  echo
  echo "### Real: EuRoC V1_01 moving (90 frames, 4.45 s): the VIO's map -> optvi"
  echo
  echo "| map | vertices | good landmarks after | ATE [m] VIO -> optvi | rotation [deg] | reprojection RMSE [px] | console [s] |"
  echo "|---|---|---|---|---|---|---|"
  printf '| vilma vio --save-map | %s | %s | %s -> %s | %s -> %s | %s -> %s | %s |\n' \
    "$(field "$b" vertices)" "$(field "$a" good_landmarks)" \
    "$(fmt "$(field "$b" ate_translation_m)")" "$(fmt "$(field "$a" ate_translation_m)")" \
    "$(fmt "$(field "$b" ate_rotation_deg)" 1 3)" "$(fmt "$(field "$a" ate_rotation_deg)" 1 3)" \
    "$(fmt "$(field "$b" reprojection_px)" 1 3)" "$(fmt "$(field "$a" reprojection_px)" 1 3)" "$seconds"
fi

# 4. Camera-IMU calibration on the AprilGrid recording (docs/optimization.md "Target
#    calibration"). The time offset t_d (t_imu = t_cam + t_d) is optvi's estimate; with the
#    stamps shifted by +5 ms the expected t_d is (the recording's own) - 5 ms.
april=$shared/euroc_imu_april
rig=$repo_dir/config/euroc-rig.yaml
if [ "${BENCH_TARGET:-1}" != 0 ] && [ -d "$april" ]; then
  echo
  echo "### Real IMU, known target: euroc_imu_april (72 s hand-held, AprilGrid corners held as landmarks)"
  echo
  echo "| start | vertices | observations | optvi: cam0 poses vs PnP, RMS [mm / deg] | cam1 poses vs PnP [mm / deg] | T_I_C cam0 vs EuRoC calibration [deg / mm] before -> after | T_I_C cam1 [deg / mm] before -> after | t_d cam0 / cam1 [ms] | reprojection RMSE [px] | optvi [s] (iterations, s/iteration) | peak RSS [MB] |"
  echo "|---|---|---|---|---|---|---|---|---|---|---|"
  for start in calibration perturbed perturbed-shift5ms; do
    args=""
    label="EuRoC calibration, t_d 0"
    case "$start" in
      perturbed) args="--perturb_extrinsics_m 0.02 --perturb_extrinsics_deg 2"
                 label="calibration moved 2 cm / 2 deg" ;;
      perturbed-shift5ms) args="--perturb_extrinsics_m 0.02 --perturb_extrinsics_deg 2 --camera_time_shift_ms 5"
                 label="moved 2 cm / 2 deg, stamps +5 ms" ;;
    esac
    out=$work/april-$start
    console "$out.console" "ltr $april --rig $rig $args; tcr --reference_rig $rig; \
      optvi --ba_fix_landmarks --ba_fix_extrinsics=false --ba_estimate_time_offset \
        --ba_estimate_baseframe_tilt --ba_outlier_rejection=false --evaluate_quality=false \
        --ba_linear_solver sparse_normal_cholesky; save --out=$out.map --overwrite"
    td0=$(grep -o 'camera 0: T_I_C moved .*time offset [-0-9.e]* -> [-0-9.e]* ms' "$out.console" | awk '{ print $(NF - 1) }')
    td1=$(grep -o 'camera 1: T_I_C moved .*time offset [-0-9.e]* -> [-0-9.e]* ms' "$out.console" | awk '{ print $(NF - 1) }')
    # The report after: the map's poses carried over the estimated offset.
    "$bin/vilma" console -c "load $out.map; tcr --reference_rig $rig --time_offset_ms $td0" \
      > "$out.after" 2>&1 ||
      { cat "$out.after" >&2; exit 1; }
    pnp() { grep "^camera $2 (" "$1" | sed -E 's/.*position RMS ([0-9.]+) mm.*rotation RMS ([0-9.]+) deg.*/\1 \/ \2/'; }
    tic() { grep "^camera cam$2: T_I_C" "$1" | sed -E 's/.*rotation ([0-9.]+) deg, translation ([0-9.]+) mm.*/\1 \/ \2/'; }
    optvi_line=$(grep '^optvi:' "$out.console")
    printf '| %s | %s | %s | %s | %s | %s -> %s | %s -> %s | %s / %s | %s | %s (%s, %s) | %s |\n' "$label" \
      "$(awk '/^vertices/ { print $2 }' "$out.console")" \
      "$(grep -o 'observations [0-9]*' "$out.console" | head -1 | awk '{ print $2 }')" \
      "$(pnp "$out.after" 0)" "$(pnp "$out.after" 1)" \
      "$(tic "$out.console" 0)" "$(tic "$out.after" 0)" "$(tic "$out.console" 1)" "$(tic "$out.after" 1)" \
      "$(fmt "$td0" 1 2)" "$(fmt "$td1" 1 2)" \
      "$(echo "$optvi_line" | grep -o 'RMSE [0-9.]* -> [0-9.]*' | awk '{ print $2 " -> " $4 }')" \
      "$(fmt "$(optvi_figure "$out.console" s)" 1 1)" "$(optvi_figure "$out.console" it)" \
      "$(fmt "$(optvi_figure "$out.console" ms)" 0.001 2)" \
      "$(awk -v k="$(cat "$out.console.rss")" 'BEGIN { printf "%.0f", k / 1024 }')"
  done
fi

# 5. A 10-minute mission (docs/optimization.md "A 10-minute mission"): the VIO's map of the
#    600 s room set, cached in $work/room-long-map (remade when older than the set or vilma).
if [ "${BENCH_LONG:-0}" = 1 ]; then
  VILMA_SIM=$bin/vilma-sim bash "$repo_dir/scripts/make-datasets.sh" --out "$datasets" \
    --only room-long >&2
  d=$datasets/room-long
  map=$work/room-long-map
  if stale "$map.out" "$d/sim.yaml" "$bin/vilma" || [ -z "$(ls -A "$map" 2> /dev/null)" ]; then
    rm -rf "$map" "$map.out"
    /usr/bin/time -f "%e %M" -o "$map.time" "$bin/vilma" vio "$d" --out "$map.txt" \
      --save-map "$map" > "$map.out.tmp" 2>&1 ||
      { cat "$map.out.tmp" >&2; echo "bench-optvi: vilma vio failed (room-long)" >&2; exit 1; }
    mv "$map.out.tmp" "$map.out"
  fi
  read -r vio_s vio_kb < "$map.time"
  echo
  echo "### A 10-minute mission: room-long (600 s), the VIO's map (vilma vio --save-map: $vio_s s, peak RSS $(awk -v k="$vio_kb" 'BEGIN { printf "%.0f", k / 1024 }') MB, map $(du -sm "$map" | cut -f1) MB)"
  echo
  echo "| pipeline | vertices | good landmarks | observations | ATE [m] VIO -> after | optvi [s] | iterations | s per iteration | console [s] | peak RSS [MB] | load average start / end |"
  echo "|---|---:|---:|---:|---|---:|---:|---:|---:|---:|---|"
  IFS='|' read -r -a long_pipelines <<< \
    "${BENCH_LONG_PIPELINES:-optvi|kfh; optvi|lc; rtl; optvi --ba_linear_solver iterative_schur|lc; kfh; rtl; optvi}"
  for pipeline in "${long_pipelines[@]}"; do
    out=$work/room-long-$(echo "$pipeline" | sed -E 's/--ba_linear_solver //; s/[ ;]+//g')
    load_start=$(cut -d' ' -f1 /proc/loadavg)
    start_s=$(date +%s.%N)
    console "$out.console" "load $map; eval_map $d --json=$out.before.json; $pipeline; \
      eval_map $d --json=$out.after.json; cmc"
    seconds=$(awk -v a="$start_s" -v b="$(date +%s.%N)" 'BEGIN { printf "%.1f", b - a }')
    load_end=$(cut -d' ' -f1 /proc/loadavg)
    b=$out.before.json a=$out.after.json
    vertices=$(field "$b" vertices)
    [ "$(field "$a" vertices)" != "$vertices" ] && vertices="$vertices -> $(field "$a" vertices)"
    observations=$(grep -o 'residuals: reprojection [0-9]*' "$out.console" | tail -1 | awk '{ print $3 }')
    iterations=$(optvi_figure "$out.console" it)
    printf '| `%s` | %s | %s | %s | %s -> %s | %s | %s | %s | %s | %s | %s / %s |\n' \
      "$pipeline" "$vertices" "$(field "$a" good_landmarks)" "$observations" \
      "$(fmt "$(field "$b" ate_translation_m)")" "$(fmt "$(field "$a" ate_translation_m)")" \
      "$(fmt "$(optvi_figure "$out.console" s)" 1 1)" "$iterations" \
      "$(fmt "$(optvi_figure "$out.console" ms)" 0.001 2)" "$seconds" \
      "$(awk -v k="$(cat "$out.console.rss")" 'BEGIN { printf "%.0f", k / 1024 }')" \
      "$load_start" "$load_end"
  done
fi

# 3. Speed against COLMAP's bundle_adjuster (Debian colmap 3.8) on the same visual-only problem:
#    the room's daemon map exported with export_colmap (OPENCV cameras, intrinsics held on both
#    sides), 30 iterations at most each. COLMAP prints its cost as sqrt(cost / residuals) =
#    (RMSE per observation) / 2; both are shown as RMSE per observation [px].
[ "${BENCH_COLMAP:-1}" = 0 ] && exit 0
command -v colmap > /dev/null || { echo "bench-optvi: colmap missing: no COLMAP table" >&2; exit 0; }
VILMA_SIM=$bin/vilma-sim bash "$repo_dir/scripts/make-datasets.sh" --out "$datasets" --only room-easy >&2
map=$(vio_map room-easy)
cmp=$work/colmap-compare
rm -rf "$cmp" && mkdir -p "$cmp/ba"
"$bin/vilma" console -c "load $map; export_colmap --out=$cmp/model --export_images=false" \
  > "$cmp/export.out" 2>&1
/usr/bin/time -f "%e %M" -o "$cmp/colmap.time" colmap bundle_adjuster --input_path "$cmp/model" \
  --output_path "$cmp/ba" --BundleAdjustment.refine_focal_length 0 \
  --BundleAdjustment.refine_extra_params 0 --BundleAdjustment.max_num_iterations 30 \
  > "$cmp/colmap.out" 2>&1
# Like for like: vilma holds the stereo rig's extrinsics, so COLMAP's rig_bundle_adjuster with the
# relative pose held (refine_relative_poses 0) solves the same problem. Its rig config groups images
# into snapshots by the name after a per-camera prefix: <vertex>_cam<k>.png becomes cam<k>/<vertex>.png.
mkdir -p "$cmp/rig-model" "$cmp/rig-ba"
cp "$cmp/model/cameras.txt" "$cmp/model/points3D.txt" "$cmp/rig-model/"
sed -E 's/^([0-9]+ ([^ ]+ ){8})([0-9a-f]+)_cam([0-9]+)\.png$/\1cam\4\/\3.png/' "$cmp/model/images.txt" \
  > "$cmp/rig-model/images.txt"
cat > "$cmp/rig.json" << 'RIG'
[ { "ref_camera_id": 1,
    "cameras": [ { "camera_id": 1, "image_prefix": "cam0/" }, { "camera_id": 2, "image_prefix": "cam1/" } ] } ]
RIG
/usr/bin/time -f "%e %M" -o "$cmp/colmap-rig.time" colmap rig_bundle_adjuster --input_path "$cmp/rig-model" \
  --output_path "$cmp/rig-ba" --rig_config_path "$cmp/rig.json" --estimate_rig_relative_poses 1 \
  --RigBundleAdjustment.refine_relative_poses 0 --BundleAdjustment.refine_focal_length 0 \
  --BundleAdjustment.refine_extra_params 0 --BundleAdjustment.max_num_iterations 30 \
  > "$cmp/colmap-rig.out" 2>&1
# The same objective as COLMAP's (its default trivial loss, every observation weighted alike):
# without the two flags optv weighs each keypoint by its stored sigma (0.15 px for refined ones,
# the map builder's default since 2026-11-28) under a Cauchy loss at 3 sigma, a different problem.
console "$cmp/optv.console" "load $map; optv --ba_outlier_rejection=false --evaluate_quality=false --keypoint_sigma_px 1 --ba_robust_loss none"
read -r colmap_s colmap_kb < "$cmp/colmap.time"
colmap_iterations=$(awk '/Iterations :/ { print $3 }' "$cmp/colmap.out" | tail -1)
colmap_initial=$(awk '/Initial cost :/ { print 2 * $4 }' "$cmp/colmap.out" | tail -1)
colmap_final=$(awk '/Final cost :/ { print 2 * $4 }' "$cmp/colmap.out" | tail -1)
optv_line=$(grep '^optv:' "$cmp/optv.console")
optv_s=$(echo "$optv_line" | awk '{ print $(NF - 1) }')
optv_before=$(echo "$optv_line" | grep -o 'RMSE [0-9.]* -> [0-9.]*' | awk '{ print $2 }')
optv_after=$(echo "$optv_line" | grep -o 'RMSE [0-9.]* -> [0-9.]*' | awk '{ print $4 }')
optv_iterations=$(echo "$optv_line" | grep -o 'in [0-9]* iterations' | awk '{ print $2 }')
echo
echo "### Visual-only bundle adjustment: vilma optv vs COLMAP bundle_adjuster and rig_bundle_adjuster (room, 1,796 images, 12,799 points, 149,410 observations)"
echo
echo "| solver | iterations | wall [s] | s per iteration | RMSE per observation before -> after [px] | peak RSS [MB] |"
echo "|---|---:|---:|---:|---|---:|"
printf '| COLMAP 3.8 bundle_adjuster (2 threads) | %s | %s | %s | %s -> %s | %s |\n' "$colmap_iterations" \
  "$colmap_s" "$(awk -v s="$colmap_s" -v n="$colmap_iterations" 'BEGIN { printf "%.2f", s / n }')" \
  "$(fmt "$colmap_initial" 1 3)" "$(fmt "$colmap_final" 1 3)" "$(awk -v k="$colmap_kb" 'BEGIN { printf "%.0f", k / 1024 }')"
read -r rig_s rig_kb < "$cmp/colmap-rig.time"
rig_iterations=$(awk '/Iterations :/ { print $3 }' "$cmp/colmap-rig.out" | tail -1)
rig_initial=$(awk '/Initial cost :/ { print 2 * $4 }' "$cmp/colmap-rig.out" | tail -1)
rig_final=$(awk '/Final cost :/ { print 2 * $4 }' "$cmp/colmap-rig.out" | tail -1)
printf '| COLMAP 3.8 rig_bundle_adjuster, stereo pair held (2 threads) | %s | %s | %s | %s -> %s | %s |\n' "$rig_iterations" \
  "$rig_s" "$(awk -v s="$rig_s" -v n="$rig_iterations" 'BEGIN { printf "%.2f", s / n }')" \
  "$(fmt "$rig_initial" 1 3)" "$(fmt "$rig_final" 1 3)" "$(awk -v k="$rig_kb" 'BEGIN { printf "%.0f", k / 1024 }')"
printf '| vilma optv (1 thread) | %s | %s | %s | %s -> %s | %s |\n' "$optv_iterations" \
  "$(fmt "$optv_s" 1 1)" "$(awk -v s="$optv_s" -v n="$optv_iterations" 'BEGIN { printf "%.2f", s / n }')" \
  "$(fmt "$optv_before" 1 3)" "$(fmt "$optv_after" 1 3)" \
  "$(awk -v k="$(cat "$cmp/optv.console.rss")" 'BEGIN { printf "%.0f", k / 1024 }')"
