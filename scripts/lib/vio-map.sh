# Shared by the map benchmarks (bench-kfh.sh, bench-optvi.sh, bench-loc.sh, ...): a simulated
# set's LCM log and the VI-map vilma-estimatord builds from it (`--input-log --save-map`, the
# VIO's poses, no ground truth used), both cached and remade when older than their inputs.
# Needs: bin (build/bin), datasets, work. Source it; it defines functions only.

# stale OUTPUT INPUT...: true when OUTPUT is missing or older than one of the INPUTs.
stale() {
  local out=$1
  shift
  [ -e "$out" ] || return 0
  local f
  for f in "$@"; do [ "$f" -nt "$out" ] && return 0; done
  return 1
}

# set_log SET: makes $work/SET.lcmlog, SET's LCM log (vilma-replay --to-log). A log is 0.9-1.7
# GB and the same for every work folder, so there is one copy per set, $VILMA_LOG_CACHE/SET.lcmlog
# (default: a folder beside the datasets folder, DATASETS-lcmlogs), written under a temporary name
# and renamed (a killed run leaves no half log), remade when older than the set's sim.yaml; the
# work folder gets a hard link to it (a copy across file systems). Benchmarks that compare daemon
# configs in several work folders then do not fill the disk with copies.
set_log() {
  local set=$1 shared_dir=${VILMA_LOG_CACHE:-${datasets%/}-lcmlogs}
  local shared=$shared_dir/$1.lcmlog log=$work/$1.lcmlog
  mkdir -p "$shared_dir" "$work"
  if stale "$shared" "$datasets/$set/sim.yaml"; then
    "$bin/vilma-replay" "$datasets/$set" --to-log "$shared.tmp.$$" --quiet >&2 ||
      { rm -f "$shared.tmp.$$"; echo "set_log: vilma-replay failed ($set)" >&2; return 1; }
    mv -f "$shared.tmp.$$" "$shared"
  fi
  if [ ! "$log" -ef "$shared" ]; then
    ln -f "$shared" "$log" 2> /dev/null || cp -p "$shared" "$log"
  fi
}

# vio_map SET: prints the folder of SET's daemon-built VI-map ($work/SET-map; the daemon's
# output in $work/SET-map.out, its poses in $work/SET-map.lcm). VIO_MAP_DAEMON_CONFIG: a daemon
# config (--config; e.g. its mapping.map_builder with track refinement), default the built-in.
vio_map() {
  local set=$1 log=$work/$1.lcmlog map=$work/$1-map
  local config=() inputs=("$log" "$bin/vilma-estimatord")
  if [ -n "${VIO_MAP_DAEMON_CONFIG:-}" ]; then
    config=(--config "$VIO_MAP_DAEMON_CONFIG")
    inputs+=("$VIO_MAP_DAEMON_CONFIG")
  fi
  set_log "$set" || return 1
  if stale "$map.out" "${inputs[@]}" || [ -z "$(ls -A "$map" 2> /dev/null)" ]; then
    rm -rf "$map" "$map.out" "$map.lcm"  # --save-map wants an absent or empty folder
    "$bin/vilma-estimatord" "${config[@]}" --rig "$datasets/$set/rig.yaml" --input-log "$log" \
      --lcm-url "file://$map.lcm?mode=w" --save-map "$map" > "$map.out.tmp" 2>&1 ||
      { cat "$map.out.tmp" >&2; echo "vio_map: vilma-estimatord failed ($set)" >&2; return 1; }
    mv "$map.out.tmp" "$map.out"
  fi
  echo "$map"
}

# ate_rmse EVAL_OUTPUT: the ATE translation RMSE [m] of a `vilma eval` output.
ate_rmse() { awk '/^ATE translation/ { print $5 }' "$1"; }

# localize_recall OUTPUT: the recall within 0.5 m [%] of a `vilma localize` output (the first
# "(x %)" of its recall line).
localize_recall() {
  awk '/recall +within 0.5 m:/ { for (i = 2; i <= NF; ++i) if ($i ~ /^%\)/) { gsub(/\(/, "", $(i-1)); print $(i-1); exit } }' "$1"
}
