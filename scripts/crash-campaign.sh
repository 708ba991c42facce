#!/bin/bash
# Crash campaign (issue 18, docs/reliability.md): power loss and kill -9 at random points of
# the mission stream and of a map save, and the checks that nothing acknowledged is lost.
#
# Stream runs: vilma-mission-sender (the mission-stream client of vilma-estimatord, the same
# MissionStreamSender code) streams a synthetic mission to vilma-mapstored over LCM loopback
# (ttl=0, a port per run). Odd runs SIGKILL vilma-mapstored at a uniformly random time and
# restart it (the sender retransmits): the finished map must hold every vertex of the mission.
# Even runs SIGKILL the sender: mapstored finalizes an incomplete mission, which must hold every
# vertex the sender saw acknowledged ("acked N" = chunks 0..N durable). Every map must load and
# pass check_map_consistency.
# Daemon runs: the real vilma-estimatord maps a simulated room session (12 s, replayed live by
# vilma-replay) and streams the mission to vilma-mapstored; at a uniformly random time of the
# replay, odd runs SIGKILL mapstored and even runs SIGKILL the daemon, which is restarted after
# 0-0.5 s and goes on with the rest of the replay (a new mission). lcm-logger records the
# stream; vilma-mission-audit then checks that every vertex of every chunk mapstored
# acknowledged is in the finalized maps, and every map folder must load and pass
# check_map_consistency.
# Save runs: `vilma console` loads a map, changes it (keyframing) and saves it over itself; it
# is SIGKILLed at a uniformly random time over the save (from the console's `> save` line, over
# the duration of a dry save measured on the same map; scripts/lib/save_kill.py). Whether the
# manifest's rename (the commit point) happened before the process died is seen by inotify:
# the folder must then load as the new generation, and as the previous one otherwise, never
# broken. The table counts the kills before and after the commit point.
#
# Usage: scripts/crash-campaign.sh [--runs N] [--daemon-runs N] [--save-runs N] [--save-vertices N] [--seed S]
#   --runs N       stream runs (default 100), alternating mapstored / sender kills
#   --daemon-runs N  runs with vilma-estimatord (default 100; about 20 s each), alternating
#                  mapstored / daemon kills
#   --save-runs N  save runs (default 100)
#   --save-vertices N  vertices of the saved map (default 400; a bigger map takes longer to
#                  save, so that fewer kills land after it on a loaded machine)
#   --seed S       of the kill times (default 1; the same seed gives the same kill times)
#   VILMA_BUILD_DIR  build folder (default <repo>/build); work in ~/.cache/vilma/crash-campaign
set -euo pipefail

repo_dir=$(cd "$(dirname "$0")/.." && pwd)
bin=${VILMA_BUILD_DIR:-$repo_dir/build}/bin
work=${VILMA_CRASH_DIR:-$HOME/.cache/vilma/crash-campaign}
runs=100
save_runs=100
save_vertices=400
daemon_runs=100
seed=1
while [ $# -gt 0 ]; do
  case "$1" in
    --runs) runs=$2; shift 2 ;;
    --save-runs) save_runs=$2; shift 2 ;;
    --save-vertices) save_vertices=$2; shift 2 ;;
    --daemon-runs) daemon_runs=$2; shift 2 ;;
    --seed) seed=$2; shift 2 ;;
    -h|--help) sed -n '2,/^set -euo/p' "$0" | sed '$d'  | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "crash-campaign.sh: unknown argument $1 (see --help)" >&2; exit 2 ;;
  esac
done
for n in "$runs" "$save_runs" "$daemon_runs" "$seed" "$save_vertices"; do
  [[ "$n" =~ ^[0-9]+$ ]] || { echo "crash-campaign.sh: expected a non-negative integer, got '$n'" >&2; exit 2; }
done
for p in vilma-mapstored vilma-mission-sender vilma vilma-estimatord vilma-replay vilma-sim \
         vilma-mission-audit; do
  [ -x "$bin/$p" ] || { echo "crash-campaign.sh: $bin/$p not built" >&2; exit 1; }
done
rm -rf "$work"
mkdir -p "$work/bin"
# Private copies: a rebuild during the campaign must not be taken for a broken map.
cp "$bin/vilma-mapstored" "$bin/vilma-mission-sender" "$bin/vilma" "$bin/vilma-estimatord" \
   "$bin/vilma-replay" "$bin/vilma-sim" "$bin/vilma-mission-audit" "$work/bin/"
bin=$work/bin
RANDOM=$seed

# Uniform random milliseconds in [lo, hi].
random_ms() { echo $(( $1 + (RANDOM * 32768 + RANDOM) % ($2 - $1 + 1) )); }
sleep_ms() { sleep "$(awk "BEGIN { print $1 / 1000 }")"; }
last_ack() { { grep -o 'acked [0-9]*' "$1" || true; } | awk '{ if ($2 > m) m = $2 } END { print (m == "" ? -1 : m) }'; }
# "vertices consistent" of a map folder, or "unloadable".
check_map() {
  local out
  if out=$("$bin/vilma" console "$1" -c "map_stats; cmc" 2>&1) && grep -q "map is consistent" <<< "$out"; then
    awk '$1 == "total" { print $4 }' <<< "$out"
  else
    echo unloadable
  fi
}

vertices=60
declare -A lost=([mapstored]=0 [sender]=0) unloadable=([mapstored]=0 [sender]=0)
stream_failed=0
mapstored_kills=0; sender_kills=0
for run in $(seq 1 "$runs"); do
  dir=$work/stream-$run
  mkdir -p "$dir"
  port=$(( 20000 + (run * 7 + seed) % 40000 ))
  url="udpm://239.255.76.67:$port?ttl=0"
  printf 'incomplete_timeout_s: 3.0\n' > "$dir/mapstored.yaml"
  "$bin/vilma-mapstored" --root "$dir/maps" --lcm-url "$url" --config "$dir/mapstored.yaml" \
    > "$dir/mapstored1.log" 2>&1 &
  store=$!
  for _ in $(seq 50); do grep -qs ready "$dir/mapstored1.log" && break; sleep 0.1; done
  kill_at=$(random_ms 50 1400)  # the mission takes about 1.5 s at 40 vertices/s
  if [ $((run % 2)) -eq 1 ]; then
    mapstored_kills=$((mapstored_kills + 1))
    "$bin/vilma-mission-sender" --lcm-url "$url" --name crash --seed "$run" --vertices $vertices \
      --keypoints 40 --rate 40 --max-retransmit-timeout 0.3 --end-timeout 30 > "$dir/sender.log" 2>&1 &
    sender=$!
    sleep_ms "$kill_at"
    kill -9 $store 2> /dev/null || true
    wait $store 2> /dev/null || true
    sleep_ms "$(random_ms 0 500)"
    "$bin/vilma-mapstored" --root "$dir/maps" --lcm-url "$url" --config "$dir/mapstored.yaml" \
      > "$dir/mapstored2.log" 2>&1 &
    store=$!
    if ! wait $sender; then stream_failed=$((stream_failed + 1)); fi
    expected=$vertices
  else
    sender_kills=$((sender_kills + 1))
    "$bin/vilma-mission-sender" --lcm-url "$url" --name crash --seed "$run" --vertices $vertices \
      --keypoints 40 --rate 40 --no-end > "$dir/sender.log" 2>&1 &
    sender=$!
    sleep_ms "$kill_at"
    kill -9 $sender 2> /dev/null || true
    wait $sender 2> /dev/null || true
    # One vertex per chunk after the BEGIN chunk 0 (which holds the first vertex as well).
    expected=$(( $(last_ack "$dir/sender.log") + 1 ))
    for _ in $(seq 100); do grep -q "finalized" "$dir"/mapstored*.log && break; sleep 0.1; done
  fi
  kill -TERM $store 2> /dev/null || true
  wait $store 2> /dev/null || true
  got=0
  [ -d "$dir/maps/crash" ] && got=$(check_map "$dir/maps/crash")
  if [ "$expected" -le 0 ] && [ ! -d "$dir/maps/crash" ]; then
    got=0  # killed before the first acknowledgement: nothing was promised
  fi
  killed=$([ $((run % 2)) -eq 1 ] && echo mapstored || echo sender)
  if [ "$got" = unloadable ]; then
    unloadable[$killed]=$((${unloadable[$killed]} + 1)); status="UNLOADABLE"
  elif [ "$got" -lt "$expected" ]; then
    lost[$killed]=$((${lost[$killed]} + expected - got)); status="LOST $((expected - got))"
  else
    status=ok
  fi
  echo "stream run $run: kill $killed at ${kill_at} ms, acknowledged $expected, stored $got: $status" >> "$work/runs.log"
  [ "$status" = ok ] && rm -rf "$dir"
done

# Daemon runs (see the header).
declare -A d_runs=([mapstored]=0 [daemon]=0) d_lost=([mapstored]=0 [daemon]=0) \
  d_acked=([mapstored]=0 [daemon]=0) d_unloadable=([mapstored]=0 [daemon]=0) \
  d_audit_failed=([mapstored]=0 [daemon]=0) d_unseen=([mapstored]=0 [daemon]=0) \
  d_missions=([mapstored]=0 [daemon]=0)
if [ "$daemon_runs" -gt 0 ]; then
  command -v lcm-logger > /dev/null ||
    { echo "crash-campaign.sh: lcm-logger not found (Debian liblcm-bin)" >&2; exit 1; }
  data=$work/daemon-data
  mkdir -p "$data"
  "$bin/vilma-sim" room --session 0 --seed 3 --seconds 12 --out "$data/room" > "$data/sim.log"
  # config/daemon.yaml with map building and the stream on (as scripts/soak.sh).
  sed -e 's/^  enabled: false          # run the map-builder/  enabled: true           # run the map-builder/' \
      -e '/^  stream:/,/^    enabled:/ s/^    enabled: false/    enabled: true/' \
      -e 's/^  mission_name: ""/  mission_name: "crash"/' \
      -e 's/^    end_timeout_s: 5.0/    end_timeout_s: 15.0/' "$repo_dir/config/daemon.yaml" > "$data/daemon.yaml"
  grep -q '^    end_timeout_s: 15.0' "$data/daemon.yaml" ||
    { echo "crash-campaign.sh: config/daemon.yaml changed: cannot turn streaming on" >&2; exit 1; }
  printf 'incomplete_timeout_s: 3.0\n' > "$data/mapstored.yaml"
fi
for run in $(seq 1 "$daemon_runs"); do
  dir=$work/daemon-$run
  mkdir -p "$dir"
  port=$(( 20000 + (run * 13 + seed + 7) % 40000 ))
  url="udpm://239.255.76.67:$port?ttl=0&recv_buf_size=8388608"
  lcm-logger --lcm-url="$url" --channel='VILMA_MISSION.*' --quiet "$dir/stream.lcmlog" \
    > "$dir/logger.log" 2>&1 &
  logger=$!
  start_store() {
    "$bin/vilma-mapstored" --root "$dir/maps" --lcm-url "$url" --config "$data/mapstored.yaml" \
      >> "$dir/mapstored.log" 2>&1 &
    store=$!
  }
  start_daemon() {
    "$bin/vilma-estimatord" --config "$data/daemon.yaml" --rig "$data/room/rig.yaml" \
      --lcm-url "$url" >> "$dir/daemon.log" 2>&1 &
    daemon=$!
  }
  start_store
  for _ in $(seq 50); do grep -qs ready "$dir/mapstored.log" && break; sleep 0.1; done
  start_daemon
  sleep 1
  "$bin/vilma-replay" "$data/room" --lcm-url "$url" --quiet > "$dir/replay.log" 2>&1 &
  replay=$!
  kill_at=$(random_ms 2000 11500)  # the session is 12 s; tracking and deltas start after ~2 s
  sleep_ms "$kill_at"
  if [ $((run % 2)) -eq 1 ]; then
    killed=mapstored
    kill -9 $store 2> /dev/null || true; wait $store 2> /dev/null || true
    sleep_ms "$(random_ms 0 500)"
    echo "--- restart after kill -9 at $kill_at ms" >> "$dir/mapstored.log"
    start_store
  else
    killed=daemon
    kill -9 $daemon 2> /dev/null || true; wait $daemon 2> /dev/null || true
    sleep_ms "$(random_ms 0 500)"
    echo "--- restart after kill -9 at $kill_at ms" >> "$dir/daemon.log"
    start_daemon
  fi
  wait $replay || true
  sleep 1
  # SIGTERM: the daemon flushes, ends its mission and waits for mapstored's final ack.
  kill -TERM $daemon 2> /dev/null || true
  wait $daemon 2> /dev/null || true
  # The killed daemon's mission is finalized as incomplete after 3 s without chunks (the
  # living sender sends a keepalive every second while idle: a 1 s timeout raced it).
  if [ "$killed" = daemon ]; then
    for _ in $(seq 100); do grep -q "finalized as incomplete" "$dir/mapstored.log" && break; sleep 0.1; done
  fi
  sleep 0.5
  kill -TERM $store 2> /dev/null || true; wait $store 2> /dev/null || true
  kill -INT $logger 2> /dev/null || true; wait $logger 2> /dev/null || true
  "$bin/vilma-mission-audit" "$dir/stream.lcmlog" "$dir/maps" > "$dir/audit.txt" 2>&1 || true
  audit=$(tail -1 "$dir/audit.txt")
  lost=$(sed -n 's/.*, lost \([0-9]*\),.*/\1/p' <<< "$audit"); lost=${lost:-unknown}
  acked=$(sed -n 's/.*acknowledged vertices \([0-9]*\),.*/\1/p' <<< "$audit"); acked=${acked:-0}
  unseen=$(sed -n 's/.*unseen chunks \([0-9]*\),.*/\1/p' <<< "$audit"); unseen=${unseen:-0}
  missions=$(sed -n 's/^audit: missions \([0-9]*\),.*/\1/p' <<< "$audit"); missions=${missions:-0}
  status=ok; bad_maps=0; inconsistent=0
  for map in "$dir"/maps/*/; do
    [ -d "$map" ] || continue
    got=$(check_map "$map")
    if [ "$got" = unloadable ]; then bad_maps=$((bad_maps + 1)); fi
  done
  if [ "$lost" = unknown ]; then
    status="AUDIT FAILED"; inconsistent=1
  elif [ "$lost" -gt 0 ]; then
    status="LOST $lost"
  fi
  [ "$bad_maps" -gt 0 ] && status="$status, $bad_maps UNLOADABLE/INCONSISTENT"
  d_runs[$killed]=$((${d_runs[$killed]} + 1))
  d_lost[$killed]=$((${d_lost[$killed]} + ${lost/unknown/0}))
  d_unloadable[$killed]=$((${d_unloadable[$killed]} + bad_maps))
  d_audit_failed[$killed]=$((${d_audit_failed[$killed]} + inconsistent))
  d_acked[$killed]=$((${d_acked[$killed]} + acked))
  d_unseen[$killed]=$((${d_unseen[$killed]} + unseen))
  d_missions[$killed]=$((${d_missions[$killed]} + missions))
  echo "daemon run $run: kill $killed at ${kill_at} ms, missions $missions, acknowledged $acked vertices, unseen chunks $unseen: $status" >> "$work/runs.log"
  sed 's/^/    /' "$dir/audit.txt" >> "$work/runs.log"
  [ "$status" = ok ] && rm -rf "$dir"
done

# Save runs: a map to save over, made by one clean stream run.
save_unloadable=0; save_wrong=0; save_before=0; save_after=0; save_late=0; save_before_data=0
save_resaved=0; save_resave_failed=0; save_leftovers=0
save_windows=(); save_medians=()
if [ "$save_runs" -gt 0 ]; then
  dir=$work/save-source
  mkdir -p "$dir"
  url="udpm://239.255.76.67:$(( 61000 + seed % 1000 ))?ttl=0"
  "$bin/vilma-mapstored" --root "$dir/maps" --lcm-url "$url" > "$dir/mapstored.log" 2>&1 &
  store=$!
  for _ in $(seq 50); do grep -qs ready "$dir/mapstored.log" && break; sleep 0.1; done
  "$bin/vilma-mission-sender" --lcm-url "$url" --name source --seed 99 --vertices "$save_vertices" \
    --keypoints 200 --rate 2000 --end-timeout 60 > "$dir/sender.log" 2>&1
  kill -TERM $store; wait $store || true
  before=$(check_map "$dir/maps/source")
  # Every 4th vertex kept, so that the new generation differs from the previous one.
  save_commands="kfh --kf_distance_threshold_m 1000 --kf_rotation_threshold_deg 180 --kf_every_nth_vertex 4 --kf_min_shared_landmarks_obs 0; save --overwrite"
  # scripts/lib/save_kill.py watches the save from outside (the console's flushed `> save` and
  # `(save: X s)` lines through a pipe, inotify on the map folder for the new generation folder
  # and the manifest's rename, the commit point) and kills it DELAY ms after the `> save` line,
  # without forking in between (the grep/sleep polling before 2026-11-27 lagged by tens of ms
  # at load 7-11, so 150 of 160 kills landed after the commit). Its timer runs at SCHED_FIFO
  # where allowed (root; the console keeps the campaign's policy and nice value).
  killer=(python3 "$repo_dir/scripts/lib/save_kill.py")
  field() { sed -n "s/.*\\b$1=\\([^ ]*\\).*/\\1/p" <<< "$2"; }
  # A dry save (no kill) measures the save's duration from `> save` to `(save: ...)`; the kill
  # times are uniform over the median of the last 3 dry saves, measured again every 25 runs,
  # so that the window follows the machine's load.
  save_timing() {
    rm -rf "$work/timing-map"
    cp -r "$dir/maps/source" "$work/timing-map"
    local t
    t=$(SAVE_KILL_LOG="$work/timing.log" "${killer[@]}" timing "$work/timing-map" -- \
        "$bin/vilma" console "$work/timing-map" -c "$save_commands" 2> /dev/null)
    echo "save timing: $t" >> "$work/runs.log"
    after=$(check_map "$work/timing-map")
    local end
    end=$(field save_end_ms "$t")
    [ "$(field exit "$t")" = 0 ] && [ -n "$end" ] && [ "$end" != - ] ||
      { echo "crash-campaign.sh: the dry save failed: $work/timing.log" >&2; exit 1; }
    save_windows+=("${end%.*}")
    rm -rf "$work/timing-map"
  }
  save_timing; save_timing; save_timing
  for run in $(seq 1 "$save_runs"); do
    [ $((run % 25)) -eq 0 ] && save_timing
    kill_window_ms=$(printf '%s\n' "${save_windows[@]: -3}" | sort -n | sed -n 2p)
    save_medians+=("$kill_window_ms")
    map=$work/save-$run
    rm -rf "$map"
    cp -r "$dir/maps/source" "$map"
    delay=$(random_ms 0 "$kill_window_ms")
    r=$(SAVE_KILL_LOG="$work/save-$run.log" "${killer[@]}" kill "$map" "$delay" -- \
        "$bin/vilma" console "$map" -c "$save_commands" 2> /dev/null) || r="killer failed"
    committed=$(field committed "$r"); phase=$(field phase "$r")
    got=$(check_map "$map")
    # The manifest's rename seen before the process died decides which generation must load.
    if [ "$committed" = 1 ]; then expected=$after; else expected=$before; fi
    if [ "$got" = unloadable ]; then
      save_unloadable=$((save_unloadable + 1)); status=UNLOADABLE
    elif [ -z "$committed" ] || [ "$got" != "$expected" ]; then
      save_wrong=$((save_wrong + 1)); status="WRONG GENERATION ($got vertices, expected $expected)"
    elif [ "$phase" = after_save ]; then
      save_late=$((save_late + 1)); status="after the save's end: new generation"
    elif [ "$phase" = after_commit ]; then
      save_after=$((save_after + 1)); status="after the commit: new generation"
    else
      save_before=$((save_before + 1)); status="before the commit: previous generation"
      [ "$(field data_files "$r")" -gt 0 ] 2> /dev/null && save_before_data=$((save_before_data + 1))
    fi
    # Recovery: a save over the killed folder must succeed and load with the same vertices
    # (it reuses the generation folder a crashed save left unlisted and removes what the new
    # manifest does not list); temporary files still there afterwards are counted.
    if [ "$got" != unloadable ]; then
      resaved=unloadable
      if "$bin/vilma" console "$map" -c "save --overwrite" > "$work/resave-$run.log" 2>&1; then
        resaved=$(check_map "$map")
      fi
      if [ "$resaved" = "$got" ]; then
        save_resaved=$((save_resaved + 1))
      else
        save_resave_failed=$((save_resave_failed + 1)); status="$status; RE-SAVE FAILED ($resaved)"
      fi
      leftovers=$(find "$map" -name '.*' -type f | wc -l)
      save_leftovers=$((save_leftovers + leftovers))
      [ "$leftovers" -gt 0 ] && status="$status; $leftovers temporary files left: $(cd "$map" && find . -name '.*' -type f | tr '\n' ' ')"
      rm -f "$work/resave-$run.log"
    fi
    echo "save run $run: window $kill_window_ms ms, $r: $status" >> "$work/runs.log"
    case "$status" in UNLOADABLE*|WRONG*|*FAILED*) ;; *) rm -rf "$map" "$work/save-$run.log" ;; esac
  done
fi

echo "| campaign | runs | acknowledged vertices lost | unloadable maps | other |"
echo "|---|---:|---:|---:|---|"
echo "| kill -9 of vilma-mapstored mid-stream, restart | $mapstored_kills | ${lost[mapstored]} | ${unloadable[mapstored]} | missions not finished after the restart: $stream_failed |"
echo "| kill -9 of the sender mid-stream | $sender_kills | ${lost[sender]} | ${unloadable[sender]} | |"
if [ "$daemon_runs" -gt 0 ]; then
  for k in mapstored daemon; do
    echo "| vilma-estimatord streaming, kill -9 of $([ $k = daemon ] && echo "the daemon" || echo vilma-mapstored), restart | ${d_runs[$k]} | ${d_lost[$k]} of ${d_acked[$k]} | ${d_unloadable[$k]} | missions ${d_missions[$k]}, acknowledged chunks the logger missed ${d_unseen[$k]}, audits failed ${d_audit_failed[$k]} |"
  done
fi
if [ "$save_runs" -gt 0 ]; then
  echo "| kill -9 during \`kfh; save --overwrite\` (kills uniform over the save: from \`> save\` over the median of the last 3 dry saves, $(printf '%s\n' "${save_medians[@]}" | sort -n | sed -n '1h; $!d; x; G; s/\n/-/; p') ms; $(printf '%s\n' "${save_windows[@]}" | sort -n | sed -n '1h; $!d; x; G; s/\n/-/; s/^/dry saves /; p') ms (${#save_windows[@]}); $before -> $after vertices) | $save_runs | - | $save_unloadable | before the commit $save_before (previous generation; $save_before_data of them with new data files written), after the commit $save_after (new generation), after the save's end $save_late, wrong generation $save_wrong; a save over the killed folder: loads $save_resaved, failed $save_resave_failed, temporary files left $save_leftovers |"
fi
echo "(details: $work/runs.log)"
[ $((${lost[mapstored]} + ${lost[sender]} + ${unloadable[mapstored]} + ${unloadable[sender]})) -eq 0 ] && \
  [ $stream_failed -eq 0 ] && \
  [ $((d_lost[mapstored] + d_lost[daemon] + d_unloadable[mapstored] + d_unloadable[daemon] + d_audit_failed[mapstored] + d_audit_failed[daemon])) -eq 0 ] && \
  [ $save_unloadable -eq 0 ] && [ $save_wrong -eq 0 ] && [ $save_resave_failed -eq 0 ]
