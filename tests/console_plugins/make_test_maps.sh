#!/usr/bin/env bash
# Makes the console tests' small real maps: two 10 s sessions of the simulated room (session 1
# revisits session 0's path under other lighting), each mapped by vilma-estimatord from its LCM
# log with --save-map, as a robot would map them; and a third, session 2, with another rig (a
# stereo pair) in OUT_DIR/maps-stereo/. Deterministic (fixed seeds, --input-log).
#   make_test_maps.sh BIN_DIR OUT_DIR
# Writes OUT_DIR/datasets/session{0,1} (ASL, ground truth), OUT_DIR/maps/session{0,1} (map
# folders) and OUT_DIR/done last.
# The maps keep bad landmarks and tracked keypoints (map builder compact: "tracks", not the
# default "good"), so that the landmark commands (rbl, itl, elq verdicts) and loop closure within
# a 10 s mission have something to work on.
set -euo pipefail
bin=$1
out=$2
repo=$(cd "$(dirname "$0")/../.." && pwd)
rm -rf "$out"
mkdir -p "$out/datasets" "$out/maps" "$out/maps-stereo" "$out/work"
sed -e 's/^compact: "good"/compact: "tracks"/' "$repo/config/map_builder.yaml" \
  > "$out/work/map_builder.yaml"
sed -e 's|^  map_builder: ""|  map_builder: "map_builder.yaml"|' "$repo/config/daemon.yaml" \
  > "$out/work/daemon.yaml"
grep -q '^compact: "tracks"' "$out/work/map_builder.yaml"
grep -q 'map_builder: "map_builder.yaml"' "$out/work/daemon.yaml"
for s in 0 1 2; do
  args=(room --out "$out/datasets/session$s" --seconds 10 --seed 3)
  [ "$s" -gt 0 ] && args+=(--session "$s" --revisit 0)
  maps=$out/maps
  [ "$s" = 2 ] && args+=(--stereo) && maps=$out/maps-stereo
  "$bin/vilma-sim" "${args[@]}" > "$out/work/sim$s.out" 2>&1
  "$bin/vilma-replay" "$out/datasets/session$s" --to-log "$out/work/session$s.lcmlog" --quiet \
    > "$out/work/replay$s.out" 2>&1
  "$bin/vilma-estimatord" --config "$out/work/daemon.yaml" --rig "$out/datasets/session$s/rig.yaml" \
    --input-log "$out/work/session$s.lcmlog" --lcm-url "file://$out/work/odom$s.lcm?mode=w" \
    --save-map "$maps/session$s" > "$out/work/daemon$s.out" 2>&1
done
rm -f "$out"/work/*.lcmlog
touch "$out/done"
