#!/usr/bin/env bash
# vilma's main job on embedded defaults, end to end:
#   1. set up (install what is missing, build);
#   2. replay the bundled EuRoC slice over LCM while a subscriber prints per-channel rates,
#      and run a camera driver (vilma-v4l2 with its fake camera) the same way;
#   3. simulate a room session (ground truth included) and replay it over LCM the same way;
#   4. run the visual-inertial odometry on it (vilma vio) and evaluate the trajectory against
#      the simulator's ground truth (vilma eval: ATE/RPE table, JSON and a plot);
#   5. run the odometry on the real EuRoC slice (static start: drift and tilt);
#   6. map then localize: vilma-estimatord builds a VI-map of the room session (--save-map),
#   7. processes the map in the console (vilma console --script: statistics, landmark quality,
#      keyframing, consistency, exports to CSV / TUM / PLY / COLMAP, a PNG and an HTML view,
#      dense reconstruction: stereo depth, TSDF, a mesh and its picture),
#   8. then localizes a second session of the same room against the processed map
#      (--localization-map) and publishes VILMA_POSE, evaluated against its ground truth.
# Generated data goes to ${VILMA_CACHE:-~/.cache/vilma}/demo, never into the repository.
set -euo pipefail

repo="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build="${VILMA_BUILD_DIR:-$repo/build}"
bin="$build/bin"
cache="${VILMA_CACHE:-$HOME/.cache/vilma}/demo"
euroc="${VILMA_DEMO_DATASET:-$repo/../shared/data/euroc_V1_01_micro}"
# A port of its own so the demo does not mix with a robot's bus on the default port.
url="udpm://239.255.76.67:7671?ttl=0&recv_buf_size=8388608"

step() { printf '\n== %s\n' "$*"; }

step "setup: install missing packages and build"
"$repo/scripts/setup.sh"
mkdir -p "$cache"

# Replays the first SECONDS of DATASET over LCM in real time while vilma-lcm-rates prints
# per-channel rates; it stops 3 s after the last message and reports losses (seq gaps).
replay_and_watch() {
  local dataset="$1" seconds="$2"
  "$bin/vilma-lcm-rates" --lcm-url "$url" --idle-timeout 3 --duration 120 --quiet &
  local monitor=$!
  sleep 0.5
  "$bin/vilma-replay" "$dataset" --end "$seconds" --lcm-url "$url" --quiet
  wait "$monitor"
}

if [ -d "$euroc/mav0" ]; then
  step "replay: the bundled EuRoC V1_01 slice (stereo 752x480 @ 20 Hz + IMU @ 200 Hz) over LCM"
  "$bin/vilma" rig check "$repo/config/euroc-rig.yaml" | grep -E '^# (imu|camera|baseline)'
  replay_and_watch "$euroc" 4.75
else
  echo "demo: $euroc not found (the bundled EuRoC slice); skipping its replay"
fi

if [ -x "$bin/vilma-v4l2" ]; then
  # A camera driver as on a robot (docs/drivers.md): the V4L2 driver with its built-in fake
  # camera publishes CAM0 (and VILMA_STATUS_CAM0) for 3 s; on a robot it is
  # `vilma-v4l2 --device /dev/v4l/by-id/...` (vilma-v4l2 --list shows the cameras).
  step "driver: vilma-v4l2 --fake (a V4L2 camera without hardware) on LCM for 3 s"
  "$bin/vilma-lcm-rates" --lcm-url "$url" --idle-timeout 3 --duration 60 --quiet &
  monitor=$!
  sleep 0.5
  "$bin/vilma-v4l2" --fake --size 752x480 --fps 20 --exposure 4000 --seconds 3 --lcm-url "$url"
  wait "$monitor"
  "$bin/vilma-v4l2" --list || true
fi

step "simulate: 30 s of the 'room' world, stereo, with ground truth (vilma-sim)"
sim="$cache/room-demo"
# Remade when the simulator's output changes (make-datasets.sh's SIM_VERSION) or it is incomplete.
sim_key="version=$(sed -n 's/^SIM_VERSION=//p' "$repo/scripts/make-datasets.sh") room seed=7 seconds=30 stereo"
if [ ! -f "$sim/mav0/state_groundtruth_estimate0/data.csv" ] ||
   [ "$(cat "$sim/.vilma-sim-key" 2>/dev/null)" != "$sim_key" ]; then
  rm -rf "$sim"
  "$bin/vilma-sim" room --out "$sim" --seconds 30 --seed 7 --stereo
  echo "$sim_key" > "$sim/.vilma-sim-key"
fi
"$bin/vilma" rig check "$sim/rig.yaml" | grep -E '^# (imu|camera|baseline)'

step "replay: the simulated session over LCM"
replay_and_watch "$sim" 10

step "odometry: vilma vio on the simulated session (monocular cam0 + IMU)"
"$bin/vilma" vio "$sim" --out "$cache/room-demo-vio.txt"

step "evaluate: ATE/RPE against the simulator's ground truth (position + yaw alignment)"
"$bin/vilma" eval --gt "$sim/mav0/state_groundtruth_estimate0/data.csv" \
    --est "$cache/room-demo-vio.txt" --align posyaw --segments 2,5,10 \
    --json "$cache/room-demo-eval.json" --plot "$cache/room-demo-eval.png"

if [ -d "$euroc/mav0" ]; then
  step "odometry on real data: the EuRoC slice (the vehicle stands still for these 4.75 s)"
  "$bin/vilma" vio "$euroc" --out "$cache/euroc-vio.txt"
  # Aligned at the first pose: a fit over 1.7 cm of path cannot fix the yaw (posyaw printed an
  # arbitrary 93 deg here), while the first pose gives the drift since the start.
  "$bin/vilma" eval --gt "$euroc/mav0/state_groundtruth_estimate0/data.csv" \
      --est "$cache/euroc-vio.txt" --align first --segments 1
fi

step "map: vilma-estimatord --save-map on the room session (from its LCM log)"
loc="$cache/map-then-localize"
rm -rf "$loc" && mkdir -p "$loc"
"$bin/vilma-replay" "$sim" --to-log "$loc/session0.lcmlog" --quiet
"$bin/vilma-estimatord" --rig "$sim/rig.yaml" --input-log "$loc/session0.lcmlog" \
    --save-map "$loc/map" --lcm-url "file://$loc/out0.lcmlog?mode=w" > "$loc/daemon0.log" 2>&1
grep -E '^vilma-estimatord: map:' "$loc/daemon0.log" || tail -5 "$loc/daemon0.log"

step "console: process the map offline (vilma console --script, docs/console.md)"
mkdir -p "$loc/console"
cat > "$loc/process.vilma" <<SCRIPT
# The demo's map processing: each command echoes with its wall time; the first failure stops.
load $loc/map --map_key=room
map_stats
check_map_consistency
print_baseframes
# Landmark quality from scratch, positions from all observations, landmarks for free tracks.
reset_landmark_quality
evaluate_landmark_quality
retriangulate_landmarks
initialize_track_landmarks
# Visual-inertial bundle adjustment (IMU preintegration + reprojection), then judged against the
# simulator's ground truth.
optimize_visual_inertial
eval_map $sim
export_trajectory_to_csv --out=$loc/console/room-vio.txt --format=tum --frame=M
csv_export --out=$loc/console/csv
export_landmarks_ply --out=$loc/console/landmarks.ply --color_by=quality
export_colmap --out=$loc/console/colmap --export_images=false
export_ncamera_calibration --out=$loc/console/rig
plot_map --out=$loc/console/map.png --title="demo room"
export_html --out=$loc/console/map.html --title="demo room"
save --out=$loc/map-processed
# A keyframed copy (maplab's keyframe heuristic), bad landmarks removed: 5-10x smaller on disk.
copy_map room-keyframed
select room-keyframed
keyframe_heuristic
evaluate_landmark_quality --elq_min_observers=2
remove_bad_landmarks
map_stats
check_map_consistency
save --out=$loc/map-keyframed
# Dense reconstruction of the keyframed map (docs/dense.md): its stereo images from the dataset,
# SGBM depth per keyframe, TSDF fusion with the optimized poses, a mesh judged against the
# simulator's true surfaces, and a picture of it with the ceiling cut off.
attach_images $sim
stereo_dense_reconstruction
depth_consistency
create_tsdf_from_depth_resource --dense_tsdf_voxel_size_m=0.05 --dense_tsdf_truncation_distance_m=0.15
export_tsdf --dense_result_mesh_output_file=$loc/console/room-mesh.ply
eval_mesh $sim
render_mesh $loc/console/room-mesh.ply $loc/console/room-mesh.png --view=custom --elevation_deg=60 --clip_above_z_m=2.5
list
SCRIPT
"$bin/vilma" console --script "$loc/process.vilma"
ls "$loc/console"

step "localize: a second session of the same room (coming back along the first one's path, other lighting) against the processed map"
"$bin/vilma-sim" room --session 1 --revisit 30 --out "$loc/session1" --seconds 20 --seed 7 > /dev/null
"$bin/vilma-replay" "$loc/session1" --to-log "$loc/session1.lcmlog" --quiet
"$bin/vilma-estimatord" --rig "$loc/session1/rig.yaml" --input-log "$loc/session1.lcmlog" \
    --localization-map "$loc/map-processed" --lcm-url "file://$loc/out1.lcmlog?mode=w" \
    > "$loc/daemon1.log" 2>&1
grep -E '^ *loc_(attempts|initialized|poses_published|tgm_updates|stage_us_p50)' "$loc/daemon1.log" || true
"$bin/vilma-lcm-poses" "$loc/out1.lcmlog" --channel VILMA_POSE --out "$loc/pose.txt"
# Every localization attempt (VILMA_LOC): recall = attempts with a pose within 0.5 m / attempts.
"$bin/vilma-lcm-poses" "$loc/out1.lcmlog" --channel VILMA_LOC --out "$loc/loc.txt" 2> /dev/null \
    | tee "$loc/loc-summary.txt"
# G is the map's frame (the first session's odometry frame). It is tied to the simulator's world
# once, by the first session's odometry aligned at its start; the second session's global poses
# are then evaluated with that fixed transform, nothing fitted to them.
"$bin/vilma-lcm-poses" "$loc/out0.lcmlog" --channel VILMA_ODOM --out "$loc/odom0.txt" > /dev/null
"$bin/vilma" eval --gt "$sim/mav0/state_groundtruth_estimate0/data.csv" --est "$loc/odom0.txt" \
    --align first --segments 1 --json "$loc/map-alignment.json" > /dev/null
"$bin/vilma" eval --gt "$loc/session1/mav0/state_groundtruth_estimate0/data.csv" \
    --est "$loc/pose.txt" --align-from "$loc/map-alignment.json" --segments 1 | sed -n '1,9p'
"$bin/vilma" eval --gt "$loc/session1/mav0/state_groundtruth_estimate0/data.csv" \
    --est "$loc/loc.txt" --align-from "$loc/map-alignment.json" --segments 1 --within 0.5 \
    | grep '^within'

step "on a robot: sensor drivers next to vilma-estimatord (docs/drivers.md)"
# The same pipeline with hardware: the drivers publish CAM0 / IMU on the default LCM URL
# (utime = CLOCK_REALTIME [us], accelerations in m/s^2, rates in rad/s, images GRAY8), the
# estimator subscribes. Once per robot: the LCM receive-buffer limit (docs/lcm.md) and the
# drivers' udev rules, then the systemd units of config/systemd/.
cat <<'ROBOT'
  sudo tee /etc/sysctl.d/60-vilma-lcm.conf <<< 'net.core.rmem_max = 16777216' && sudo sysctl --system
  sudo cp config/udev/99-vilma-usb-imu.rules /etc/udev/rules.d/ && sudo udevadm control --reload-rules
  vilma-usb-imu --serial /dev/serial/by-id/usb-...-if00 --family gx5 --rate-hz 200 &   # IMU
  vilma-estimatord --config /etc/vilma/daemon.yaml --rig /etc/vilma/rig.yaml           # odometry
  lcm-spy / vilma-lcm-rates: IMU at 200 Hz, VILMA_STATUS_IMU state OK
ROBOT
if [ -x "$bin/vilma-usb-imu" ]; then
  "$bin/vilma-usb-imu" --list --vendor-id 0x199b  # MicroStrain IMUs on this machine's USB
fi

step "done: outputs in $cache (room-demo-eval.png, room-demo-eval.json, *-vio.txt, map-then-localize/, map-then-localize/console/: map.png, map.html, exports)"
