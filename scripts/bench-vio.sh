#!/usr/bin/env bash
# VIO benchmark: runs `vilma vio` and `vilma eval --align posyaw` over the synthetic benchmark
# sets of scripts/make-datasets.sh and the real EuRoC slices (static start; moving start from
# the sensors, and from the ground-truth state with --initial-state: the row "+given"), and
# prints one table (docs/benchmarks.md, "VIO"). Sets that do not exist are listed as missing.
#
# Usage: scripts/bench-vio.sh [--config FILE] [--keep DIR] [--stereo] [--imu-draws K] [--sets LIST]
#   --stereo  also the rows "+stereo": vilma vio --stereo (cam0 + cam1) on every set
#   --imu-draws K  (implies --stereo) also mono and stereo on K IMU draws of each simulated set
#             (draw 0 = the set, draws 1..K-1 by vilma-sim --imu-draw N --images-from SET into
#             $VILMA_CACHE/imu-draws, docs/simulator.md "IMU draws"), and a second table per set:
#             each draw's mono / stereo ATE RMSE and roll/pitch max, the medians, the ratio of
#             the medians and the median of the per-draw ratios (stereo / mono), and the
#             paired bootstrap's 90 % interval of the ratio of the medians (20000 resamples,
#             seeded) with the share of resamples <= 0.80
#   --sets LIST  simulated sets to run (comma-separated; default room-easy,room-fast,hall,street)
#   VILMA_BUILD_DIR  build folder with bin/vilma (default <repo>/build)
#   VILMA_CACHE      cache folder; the sets are in $VILMA_CACHE/datasets (default ~/.cache/vilma)
#   VILMA_SHARED_DATA_DIR  real data (default <repo>/../shared/data)
# Columns: duration [s], ground-truth path length [m], ATE RMSE [m] and in % of the path,
# ATE max [m], worst roll/pitch error [deg] (gravity direction in the body frame, independent of
# the yaw alignment; `vilma eval`'s roll/pitch), per-frame filter time p50/p99 [ms] (one core,
# images loaded outside the timing), real-time factor of the whole run (wall time including PNG
# decoding), resets, how the filter started, the first pose's delay after the first frame and the
# filter options (`vilma vio`'s built-in profile: auto picks euroc for the real EuRoC slices,
# default for the simulated sets; or the --config file).
set -euo pipefail

repo_dir="$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)"
build_dir="${VILMA_BUILD_DIR:-$repo_dir/build}"
datasets_dir="${VILMA_CACHE:-$HOME/.cache/vilma}/datasets"
shared_dir="${VILMA_SHARED_DATA_DIR:-$repo_dir/../shared/data}"
vilma="$build_dir/bin/vilma"
config_args=()
keep=""
stereo=0
imu_draws=0
sim_sets=(room-easy room-fast hall street)
while [[ $# -gt 0 ]]; do
  case "$1" in
    --config) config_args=(--config "$2"); shift 2 ;;
    --keep) keep="$2"; shift 2 ;;
    --stereo) stereo=1; shift ;;
    --imu-draws)
      [[ "${2:-}" =~ ^[1-9][0-9]*$ ]] ||
        { echo "bench-vio.sh: --imu-draws: expected K >= 1" >&2; exit 2; }
      imu_draws="$2"; stereo=1; shift 2 ;;
    --sets) IFS=, read -r -a sim_sets <<< "${2:-}"; shift 2 ;;
    -h|--help) sed -n '2,24p' "${BASH_SOURCE[0]}" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "bench-vio.sh: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done
[[ -x "$vilma" ]] || { echo "bench-vio.sh: $vilma not built (set VILMA_BUILD_DIR)" >&2; exit 1; }

work="${keep:-$(mktemp -d /tmp/vilma-bench-vio.XXXXXX)}"
mkdir -p "$work"
[[ -n "$keep" ]] || trap 'rm -rf "$work"' EXIT

real_names=(euroc_V1_01_micro euroc_V1_01_moving euroc_V1_01_moving+given)
names=("${sim_sets[@]}" "${real_names[@]}")
# "+stereo": the same set with `vilma vio --stereo` (cam0 + cam1; docs/estimator.md "Stereo").
if [[ "$stereo" == 1 ]]; then
  for n in "${names[@]}"; do names+=("$n+stereo"); done
fi

# Runs vilma vio (mono, or stereo for a NAME ending in +stereo; +given: from the ground truth)
# and vilma eval on DIR into $work/NAME.*; exits on a failed run.
run_vio() {
  local name=$1 dir=$2
  local gt="$dir/mav0/state_groundtruth_estimate0/data.csv"
  local start_args=()
  [[ "$name" == *+given* ]] && start_args=(--initial-state "$gt")
  [[ "$name" == *+stereo ]] && start_args+=(--stereo)
  "$vilma" vio "$dir" "${config_args[@]}" "${start_args[@]}" --out "$work/$name.txt" \
      --log-timing "$work/$name.timing.csv" > "$work/$name.vio.out" 2> "$work/$name.vio.err" || {
    echo "bench-vio.sh: vilma vio failed on $name:" >&2; cat "$work/$name.vio.err" >&2; exit 1; }
  "$vilma" eval --gt "$gt" --est "$work/$name.txt" --align posyaw --segments 1 \
      --json "$work/$name.json" > "$work/$name.eval.out"
}

rows=()
missing=()
for name in "${names[@]}"; do
  set_name="${name%+stereo}"; set_name="${set_name%+given}"
  if [[ "$name" == euroc_* ]]; then dir="$shared_dir/$set_name"; else dir="$datasets_dir/$set_name"; fi
  if [[ ! -d "$dir/mav0" ]]; then missing+=("$name ($dir)"); continue; fi
  if [[ "$name" == *+stereo && ! -d "$dir/mav0/cam1" ]]; then missing+=("$name (no cam1)"); continue; fi
  gt="$dir/mav0/state_groundtruth_estimate0/data.csv"
  run_vio "$name" "$dir"
  rows+=("$(python3 - "$name" "$work/$name.vio.out" "$work/$name.json" "$work/$name.timing.csv" \
                      "$gt" "$work/$name.txt" <<'PY'
import json, math, re, sys
name, vio_out, json_path, timing_path, gt_path, est_path = sys.argv[1:]
text = open(vio_out).read()
duration = float(re.search(r"duration\s+([0-9.]+) s", text).group(1))
rtf = float(re.search(r"real-time factor\s+([0-9.]+)x", text).group(1))
resets = int(re.search(r"resets\s+(\d+)", text).group(1))
m = re.search(r"initializations\s+(\d+) static, (\d+) moving \((\d+) by alignment, (\d+) mean-acc\S* "
              r"fallback\), (\d+) given", text)
start = ("given" if int(m.group(5)) else "static" if int(m.group(1)) else
         "aligned" if int(m.group(3)) else "fallback" if int(m.group(4)) else "?")
om = re.search(r"options\s+(?:built-in profile (\S+)|(\S+))", text)
options = (om.group(1) or om.group(2).split("/")[-1]) if om else "?"
ms = sorted(float(l.split(",")[1]) for l in open(timing_path).readlines()[1:])
pct = lambda q: ms[min(len(ms) - 1, int(q * (len(ms) - 1) + 0.5))]
j = json.load(open(json_path))
path = j["gt_path_length_m"]; rmse = j["ate"]["translation_rmse_m"]
amax = j["ate"]["translation_max_m"]
tilt = j["ate"]["roll_pitch_max_deg"]
import os
cam_csv = os.path.join(os.path.dirname(gt_path), "..", "cam0", "data.csv")
first_frame = int(next(l for l in open(cam_csv) if l[0].isdigit()).split(",")[0])
est_t0 = None
for l in open(est_path):
    if l.startswith("#") or not l.strip(): continue
    s_, frac = l.split()[0].split("."); est_t0 = int(s_) * 10**9 + int(frac.ljust(9, "0")[:9]); break
pct_path = 100.0 * rmse / path if path > 0 else float("nan")
print(f"| {name} | {duration:.1f} | {path:.2f} | {rmse:.4f} | {pct_path:.2f} | {amax:.4f} | "
      f"{tilt:.2f} | {pct(0.5):.2f} / {pct(0.99):.2f} | {rtf:.1f} | {resets} | {start} | "
      f"{(est_t0 - first_frame) * 1e-9:.2f} | {options} |")
PY
)")
done

echo "| dataset | duration [s] | path [m] | ATE RMSE [m] | ATE [% path] | ATE max [m] | roll/pitch err max [deg] | ms/frame p50 / p99 | real-time factor | resets | start | first pose after [s] | options |"
echo "|---|---|---|---|---|---|---|---|---|---|---|---|---|"
printf '%s\n' "${rows[@]}"
if [[ ${#missing[@]} -gt 0 ]]; then
  echo
  echo "missing (make them with scripts/make-datasets.sh): ${missing[*]}"
fi
[[ "$imu_draws" -gt 0 ]] || exit 0

# IMU draws of each simulated set: draw 0 is the set itself (its runs above), draw N >= 1 the
# same images with the IMU of vilma-sim --imu-draw N (remade when the set or vilma-sim is newer).
sim_bin="$build_dir/bin/vilma-sim"
[[ -x "$sim_bin" ]] ||
  { echo "bench-vio.sh: $sim_bin not built (set VILMA_BUILD_DIR)" >&2; exit 1; }
draws_dir="${VILMA_CACHE:-$HOME/.cache/vilma}/imu-draws"
sim_key() { sed -n "s/^$2: //p" "$1/sim.yaml"; }
draw_sets=()
for set_name in "${sim_sets[@]}"; do
  dir="$datasets_dir/$set_name"
  [[ -d "$dir/mav0/cam1" && -f "$dir/sim.yaml" ]] || continue
  draw_sets+=("$set_name")
  for ((n = 1; n < imu_draws; n++)); do
    out="$draws_dir/$set_name-imu$n"
    if [[ ! -f "$out/sim.yaml" || "$dir/sim.yaml" -nt "$out/sim.yaml" ||
          "$sim_bin" -nt "$out/sim.yaml" ]]; then
      stereo_flag=(); [[ "$(sim_key "$dir" stereo)" == true ]] && stereo_flag=(--stereo)
      revisit=()
      [[ "$(sim_key "$dir" revisit_seconds)" != 0 ]] &&
        revisit=(--revisit "$(sim_key "$dir" revisit_seconds)")
      "$sim_bin" "$(sim_key "$dir" world)" "${stereo_flag[@]}" "${revisit[@]}" \
          --seconds "$(sim_key "$dir" seconds)" --seed "$(sim_key "$dir" seed)" \
          --session "$(sim_key "$dir" session)" \
          --time-offset-ns "$(sim_key "$dir" camera_time_offset_ns)" \
          --motion-blur "$(sim_key "$dir" motion_blur_samples)" \
          --pixel-noise "$(sim_key "$dir" noise_sigma)" \
          --imu-draw "$n" --images-from "$dir" --out "$out" 2> "$work/$set_name-imu$n.sim.err" || {
        echo "bench-vio.sh: vilma-sim --imu-draw $n failed on $set_name:" >&2
        cat "$work/$set_name-imu$n.sim.err" >&2; exit 1; }
    fi
    run_vio "$set_name-imu$n" "$out"
    run_vio "$set_name-imu$n+stereo" "$out"
  done
done
echo
python3 - "$work" "$imu_draws" "${draw_sets[@]}" <<'PY'
import json, os, random, statistics, sys
work, k, sets = sys.argv[1], int(sys.argv[2]), sys.argv[3:]
def bootstrap(mono, stereo, resamples=20000):
    """Paired bootstrap of the ratio of the medians (draws resampled with replacement, a fixed
    seed so that the table repeats): the 5-95 % interval and the share of resamples <= 0.80."""
    rng = random.Random(1)
    n, ratios = len(mono), []
    for _ in range(resamples):
        pick = [rng.randrange(n) for _ in range(n)]
        ratios.append(statistics.median(stereo[i] for i in pick) /
                      statistics.median(mono[i] for i in pick))
    ratios.sort()
    return (ratios[int(0.05 * resamples)], ratios[int(0.95 * resamples) - 1],
            sum(r <= 0.8 for r in ratios) / resamples)
def ate(name):
    j = json.load(open(os.path.join(work, name + ".json")))
    return j["ate"]["translation_rmse_m"], j["ate"]["roll_pitch_max_deg"]
print(f"IMU draws 0..{k - 1} (ATE RMSE [m] posyaw, roll/pitch max [deg]; ratio = stereo / mono)")
print()
print("| set | draw | mono ATE | stereo ATE | stereo / mono | mono roll/pitch max "
      "| stereo roll/pitch max |")
print("|---|---|---|---|---|---|---|")
summary = []
for s in sets:
    mono, stereo, ratios = [], [], []
    for n in range(k):
        name = s if n == 0 else f"{s}-imu{n}"
        (m, mrp), (st, srp) = ate(name), ate(name + "+stereo")
        mono.append(m); stereo.append(st); ratios.append(st / m)
        print(f"| {s} | {n} | {m:.4f} | {st:.4f} | {st / m:.2f} | {mrp:.2f} | {srp:.2f} |")
    mm, ms = statistics.median(mono), statistics.median(stereo)
    low, high, share = bootstrap(mono, stereo) if k > 1 else (ms / mm, ms / mm, float("nan"))
    summary.append(f"| {s} | {k} | {mm:.4f} | {ms:.4f} | {ms / mm:.2f} | "
                   f"{statistics.median(ratios):.2f} | {sum(r <= 0.8 for r in ratios)} of {k} | "
                   f"{low:.2f}-{high:.2f} | {share:.2f} |")
print()
print("| set | draws | mono median | stereo median | ratio of the medians | median of the ratios "
      "| draws with ratio <= 0.80 | bootstrap 90 % of the ratio of the medians "
      "| share of resamples <= 0.80 |")
print("|---|---|---|---|---|---|---|---|---|")
print("\n".join(summary))
PY
