#!/bin/bash
# Localization benchmark of vilma-estimatord's LOC mode (docs/benchmarks.md "Localization in the
# daemon"). For each simulated world, a map of session 0, then sessions 1 and 2 (other paths that
# revisit session 0's, other lighting) through `vilma-estimatord --input-log --localization-map`
# (deterministic). Two kinds of map (BENCH_MAP):
#   - gt:  vilma-locmap-gt (map builder with GROUND-TRUTH poses), so G = the simulator's world W;
#          global poses are evaluated with NO alignment.
#   - vio: the realistic workflow (scripts/demo.sh): the daemon maps session 0 from its LCM log
#          with `--save-map DIR` (a VI-map from the VIO, no batch optimization), and the queries
#          localize against that folder. Then G = session 0's odometry frame M0 (gravity
#          aligned, origin and yaw arbitrary) and the map carries the VIO's drift. Session 0's
#          VILMA_ODOM aligned at its start (`vilma eval --align first --json`) gives S_W_G, and
#          every query's VILMA_POSE / VILMA_LOC is evaluated with that same fixed transform
#          (`vilma eval --align-from`), nothing fitted to the query. The global error therefore
#          includes the map's own drift, printed as "map drift" (session 0's VIO ATE aligned at
#          its start; 0 for a gt map).
# Per query session and map:
#   - global RMSE: VILMA_POSE (T_G_I) against ground truth in W (gt: no alignment; vio: S_W_G);
#   - the same with the map fitted (vio, opt): S_W_G from the map's own vertex trajectory (console
#     `export_trajectory_to_csv --frame G`) aligned to session 0's ground truth with posyaw (the
#     4 DoF a VI map leaves free), still nothing fitted to the query: the query's error in a map
#     frame known as well as the map itself allows, without the start pose's error that the
#     start alignment carries along the whole map;
#   - VIO only: VILMA_ODOM of the same daemon run without a map, aligned only at its first pose
#     (`vilma eval --align first`: a robot started at a known pose), over the whole run (which
#     favours VIO: VILMA_POSE starts seconds later, when the drift has begun);
#   - recall: localization attempts (VILMA_LOC) whose pose is within 0.5 m of ground truth (in
#     W, as above), over all attempts; attempts accepted into T_G_M;
#   - the localizer stage time per query (features + Localize, wall) p50 and max.
# Prints a markdown table. Issue targets (gt map): RMSE <= 0.08 m (room), <= 0.15 m (hall),
# >= 40 % lower than VIO only, recall >= 80 %.
#
# Usage: scripts/bench-loc.sh [WORLD ...]       (room, hall, street; default: room hall)
#   BENCH_MAP        gt, vio, opt (the vio map after `lc; rtl; optvi` in the console), both
#                    (gt and vio, the default) or all
#   VILMA_BUILD_DIR  build folder with bin/vilma-{estimatord,replay,locmap-gt,lcm-poses}, bin/vilma
#   VILMA_DATASETS   datasets folder of scripts/make-datasets.sh (default
#                    ${VILMA_CACHE:-~/.cache/vilma}/datasets); missing sets are made
#   BENCH_WORK       folder for logs, maps and outputs (default ${VILMA_CACHE:-~/.cache/vilma}/bench-loc)
#   VIO_MAP_DAEMON_CONFIG  daemon config (--config) for the session-0 map run of the vio and opt
#                    maps, e.g. mapping.map_builder without track refinement (as in bench-optvi.sh;
#                    give it its own BENCH_WORK); the query runs keep the built-in config
#   BENCH_QUERY_CONFIG  daemon config (--config) for the query runs (VIO only and LOC), e.g. other
#                    T_G_M fusion options (a partial file: absent keys keep the defaults; give it
#                    its own BENCH_WORK, as outputs are reused while newer than their inputs)
# Maps, logs and daemon runs are reused while newer than their inputs and the binaries.
set -euo pipefail

for arg in "$@"; do
  case "$arg" in
    -h | --help) sed -n '2,/^set -euo/p' "$0" | grep '^#' | sed 's/^# \{0,1\}//'; exit 0 ;;
    -*) echo "bench-loc: unknown option '$arg' (see --help)" >&2; exit 2 ;;
    room | hall | street) ;;
    *) echo "bench-loc: unknown world '$arg': expected room, hall or street (see --help)" >&2; exit 2 ;;
  esac
done

repo_dir=$(cd "$(dirname "$0")/.." && pwd)
build_dir=${VILMA_BUILD_DIR:-$repo_dir/build}
cache=${VILMA_CACHE:-$HOME/.cache/vilma}
datasets=${VILMA_DATASETS:-$cache/datasets}
work=${BENCH_WORK:-$cache/bench-loc}
bin=$build_dir/bin
query_config=()
if [ -n "${BENCH_QUERY_CONFIG:-}" ]; then
  [ -f "$BENCH_QUERY_CONFIG" ] || { echo "bench-loc: BENCH_QUERY_CONFIG '$BENCH_QUERY_CONFIG' is not a file" >&2; exit 2; }
  query_config=(--config "$BENCH_QUERY_CONFIG")
fi

worlds=("$@")
map_kinds=${BENCH_MAP:-both}
case "$map_kinds" in
  gt | vio | opt) ;;
  both) map_kinds="gt vio" ;;
  all) map_kinds="gt vio opt" ;;
  *) echo "bench-loc: BENCH_MAP: expected gt, vio, opt, both or all, got '$map_kinds'" >&2; exit 2 ;;
esac
[ ${#worlds[@]} -eq 0 ] && worlds=(room hall)
for exe in vilma-estimatord vilma-replay vilma-locmap-gt vilma-lcm-poses vilma vilma-sim; do
  [ -x "$bin/$exe" ] || { echo "bench-loc: $bin/$exe not built (set VILMA_BUILD_DIR)" >&2; exit 1; }
done
mkdir -p "$work"

map_set() { case "$1" in room) echo room-easy ;; hall) echo hall ;; street) echo street ;; *) return 1 ;; esac; }

# The datasets this run needs (make-datasets.sh skips the ones that are up to date).
needed=""
for w in "${worlds[@]}"; do
  m=$(map_set "$w") || { echo "bench-loc: unknown world '$w' (room, hall, street)" >&2; exit 2; }
  needed="$needed,$m,$w-s2,$w-s3"
done
VILMA_SIM=$bin/vilma-sim bash "$repo_dir/scripts/make-datasets.sh" --out "$datasets" \
  --only "${needed#,}" >&2

# value NAME FILE: the last "NAME VALUE" line of a daemon's final counters.
value() { awk -v k="$1" '$1 == k { v = $2 } END { print (v == "" ? "-" : v) }' "$2"; }
# rmse EVAL_OUTPUT: ATE translation RMSE [m].
rmse() { awk '/^ATE translation/ { print $5 }' "$1"; }

# loc_stats LOG: "inliers_p50 matches_p50" over the VILMA_LOC attempts whose status is "ok"
# (RANSAC inliers, 2D-3D matches), read straight from the LCM log (event: sync 0xEDA1DA01,
# event number, time, channel length, data length, channel, data; localization_t big-endian
# after its 8-byte fingerprint, msgs/lcm/vilma/localization_t.lcm).
loc_stats() {
  python3 - "$1" << 'PY'
import struct, sys
def median(v):
    v = sorted(v)
    return "-" if not v else (v[len(v) // 2] if len(v) % 2 else 0.5 * (v[len(v) // 2 - 1] + v[len(v) // 2]))
inliers, matches = [], []
with open(sys.argv[1], "rb") as f:
    data = f.read()
pos = 0
while pos + 28 <= len(data):
    sync, _, _, clen, dlen = struct.unpack_from(">IqqII", data, pos)
    if sync != 0xEDA1DA01:
        break
    pos += 28
    channel = data[pos:pos + clen].decode()
    msg = data[pos + clen:pos + clen + dlen]
    pos += clen + dlen
    if channel != "VILMA_LOC":
        continue
    o = 8 + 16  # fingerprint, utime, seq
    strings = []
    for _ in range(2):
        (n,) = struct.unpack_from(">i", msg, o)
        strings.append(msg[o + 4:o + 4 + n - 1].decode())
        o += 4 + n
    _, n_matches, n_inliers = struct.unpack_from(">iii", msg, o)
    if strings[0] == "ok":
        inliers.append(n_inliers)
        matches.append(n_matches)
print(median(inliers), median(matches))
PY
}

# stale OUTPUT INPUT... (and vio_map, ate_rmse), shared with the map benchmarks.
# shellcheck source=lib/vio-map.sh
. "$repo_dir/scripts/lib/vio-map.sh"

# make_log SET: the set's LCM log $work/SET.lcmlog (set_log: one shared copy per set).
make_log() { set_log "$1" > /dev/null || exit 1; }

# daemon_run NAME SET [ARGS...]: vilma-estimatord on SET's log, outputs to $work/NAME.{lcm,out};
# skipped when they are newer than the log and the daemon binary (and any map in ARGS).
daemon_run() {
  local name=$1 set=$2
  shift 2
  local deps=("$work/$set.lcmlog" "$bin/vilma-estimatord")
  local a
  for a in "$@"; do [ -e "$a" ] && deps+=("$a"); done
  if stale "$work/$name.out" "${deps[@]}" || [ ! -s "$work/$name.lcm" ]; then
    rm -f "$work/$name.lcm"
    "$bin/vilma-estimatord" --rig "$datasets/$set/rig.yaml" --input-log "$work/$set.lcmlog" \
      --lcm-url "file://$work/$name.lcm?mode=w" "$@" > "$work/$name.out.tmp" 2>&1 ||
      { cat "$work/$name.out.tmp" >&2; echo "bench-loc: vilma-estimatord failed ($name)" >&2; exit 1; }
    mv "$work/$name.out.tmp" "$work/$name.out"
  fi
}

echo "| world | map | query | map landmarks | map drift (session 0 VIO, aligned at start) [m] | VILMA_POSE frames | global RMSE [m] (gt: no alignment; vio: map's start alignment) | global RMSE [m], map fitted (posyaw over its vertices) | VIO only, aligned at start, whole run [m] | LOC vs VIO | recall (within 0.5 m / attempts) | accepted / attempts | inliers / matches p50 (ok attempts) | stage p50 / max [ms] |"
echo "|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|"
for w in "${worlds[@]}"; do
  m=$(map_set "$w")
  for kind in $map_kinds; do
    # map_ref: what --localization-map gets; align: how the global poses are evaluated.
    drift=0
    if [ "$kind" = gt ]; then
      map_ref=$work/$m.vlocmap
      if stale "$work/$m.locmap.out" "$datasets/$m/sim.yaml" "$bin/vilma-locmap-gt" ||
         [ ! -f "$map_ref" ]; then
        "$bin/vilma-locmap-gt" "$datasets/$m" "$map_ref" > "$work/$m.locmap.out" 2>&1
      fi
      align=(--align none)
      align_fit=(--align none)
    else
      # Session 0 mapped by the daemon from its LCM log, as scripts/demo.sh does.
      make_log "$m"
      map_ref=$work/$m-map
      map_config=() map_inputs=("$work/$m.lcmlog" "$bin/vilma-estimatord")
      if [ -n "${VIO_MAP_DAEMON_CONFIG:-}" ]; then
        map_config=(--config "$VIO_MAP_DAEMON_CONFIG")
        map_inputs+=("$VIO_MAP_DAEMON_CONFIG")
      fi
      if stale "$work/$m-map.out" "${map_inputs[@]}" ||
         [ -z "$(ls -A "$map_ref" 2> /dev/null)" ]; then
        rm -rf "$map_ref" "$work/$m-map.out"  # --save-map wants an absent or empty folder
        daemon_run "$m-map" "$m" "${map_config[@]}" --save-map "$map_ref"
      fi
      map_line=$(grep -o 'map: [0-9]* vertices, [0-9]* landmarks ([0-9]* good)' "$work/$m-map.out" || true)
      echo "bench-loc: $m, daemon's VI-map $map_ref: ${map_line#map: }" >&2
      "$bin/vilma-lcm-poses" "$work/$m-map.lcm" --channel VILMA_ODOM --out "$work/$m-map-odom.txt" \
        > /dev/null
      # S_W_G: session 0's odometry frame M0 = the map's G, aligned at session 0's first pose.
      "$bin/vilma" eval --gt "$datasets/$m/mav0/state_groundtruth_estimate0/data.csv" \
        --est "$work/$m-map-odom.txt" --align first --json "$work/$m-map-align.json" \
        > "$work/$m-map-odom.eval"
      drift=$(rmse "$work/$m-map-odom.eval")
      align=(--align-from "$work/$m-map-align.json")
      if [ "$kind" = opt ]; then
        # The same map after the console's `lc; rtl; optvi` (docs/optimization.md). Its gauge
        # keeps the first vertex's position and heading in M (the pose of session 0's first
        # odometry message), so G and the alignment stay the VIO map's.
        if stale "$work/$m-map-opt.out" "$work/$m-map.out" "$bin/vilma" ||
           [ ! -d "$work/$m-map-opt" ]; then
          "$bin/vilma" console -c "load $map_ref; lc; rtl; optvi; save --out=$work/$m-map-opt \
            --overwrite" > "$work/$m-map-opt.out.tmp" 2>&1 ||
            { cat "$work/$m-map-opt.out.tmp" >&2; echo "bench-loc: console failed ($m)" >&2; exit 1; }
          mv "$work/$m-map-opt.out.tmp" "$work/$m-map-opt.out"
        fi
        map_ref=$work/$m-map-opt
      fi
      # S_W_G fitted: the map's vertices (T_G_I) aligned to session 0's ground truth (posyaw).
      if stale "$map_ref-traj.txt" "$map_ref/manifest.yaml" "$bin/vilma"; then
        "$bin/vilma" console -c "load $map_ref; export_trajectory_to_csv --out=$map_ref-traj.txt \
          --format=tum --frame=G" > "$map_ref-traj.out" 2>&1 ||
          { cat "$map_ref-traj.out" >&2; echo "bench-loc: trajectory export failed ($m)" >&2; exit 1; }
      fi
      "$bin/vilma" eval --gt "$datasets/$m/mav0/state_groundtruth_estimate0/data.csv" \
        --est "$map_ref-traj.txt" --align posyaw --json "$map_ref-fit.json" > "$map_ref-fit.eval"
      align_fit=(--align-from "$map_ref-fit.json")
    fi
    for q in "$w-s2" "$w-s3"; do
      set_dir=$datasets/$q
      gt=$set_dir/mav0/state_groundtruth_estimate0/data.csv
      make_log "$q"
      daemon_run "$q-vio" "$q" "${query_config[@]}"
      daemon_run "$q-loc-$kind" "$q" "${query_config[@]}" --localization-map "$map_ref"
      out=$work/$q-loc-$kind
      "$bin/vilma-lcm-poses" "$out.lcm" --out "$out-pose.txt" > /dev/null 2>&1 || rm -f "$out-pose.txt"
      "$bin/vilma-lcm-poses" "$work/$q-vio.lcm" --channel VILMA_ODOM --out "$work/$q-odom.txt" > /dev/null
      "$bin/vilma-lcm-poses" "$out.lcm" --channel VILMA_LOC --out "$out-loc.txt" \
        > "$out-loc.summary" 2>&1 || rm -f "$out-loc.txt"
      landmarks=$(grep -o 'localization map [^:]*: [0-9]* landmarks' "$out.out" | awk '{ print $(NF - 1) }')
      attempts=$(value loc_attempts "$out.out")
      accepted=$(value loc_tgm_updates "$out.out")
      stage_p50=$(value loc_stage_us_p50 "$out.out")
      stage_max=$(value loc_stage_us_max "$out.out")
      read -r inliers matches < <(loc_stats "$out.lcm")
      frames=0 loc_rmse=- loc_fit_rmse=- ratio=- within=0
      if [ -s "$out-pose.txt" ]; then
        frames=$(grep -vc '^#' "$out-pose.txt")
        "$bin/vilma" eval --gt "$gt" --est "$out-pose.txt" "${align[@]}" > "$out-pose.eval"
        loc_rmse=$(rmse "$out-pose.eval")
        "$bin/vilma" eval --gt "$gt" --est "$out-pose.txt" "${align_fit[@]}" > "$out-pose-fit.eval"
        loc_fit_rmse=$(rmse "$out-pose-fit.eval")
      fi
      "$bin/vilma" eval --gt "$gt" --est "$work/$q-odom.txt" --align first > "$work/$q-odom.eval"
      vio_rmse=$(rmse "$work/$q-odom.eval")
      if [ "$loc_rmse" != - ]; then
        ratio=$(awk -v a="$loc_rmse" -v b="$vio_rmse" 'BEGIN { d = 100 * (1 - a / b); printf "%.0f %% %s", (d < 0 ? -d : d), (d < 0 ? "higher" : "lower") }')
      fi
      if [ -s "$out-loc.txt" ]; then
        "$bin/vilma" eval --gt "$gt" --est "$out-loc.txt" "${align[@]}" --within 0.5 \
          > "$out-loc.eval"
        within=$(awk '/^within 0.50 m:/ { print $4 }' "$out-loc.eval")
      fi
      recall=-
      [ "$attempts" != - ] && [ "$attempts" -gt 0 ] &&
        recall="$within / $attempts = $(awk -v a="$within" -v b="$attempts" 'BEGIN { printf "%.1f %%", 100 * a / b }')"
      echo "| $w | $kind | $q | $landmarks | $drift | $frames | $loc_rmse | $loc_fit_rmse | $vio_rmse | $ratio | $recall | $accepted / $attempts | $inliers / $matches | $(awk -v a="$stage_p50" -v b="$stage_max" 'BEGIN { printf "%.1f / %.1f", a / 1000, b / 1000 }') |"
    done
  done
done
