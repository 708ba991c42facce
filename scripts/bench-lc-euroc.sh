#!/usr/bin/env bash
# Loop closure on real images (docs/loop-closure.md "Real images"): the 100 stereo keyframes of
# EuRoC V1_01 (../shared/data/euroc_V1_01_keyframes; the room is revisited) as a one-mission
# map (`vilma map-from-poses`, poses = ground truth, or moved 0.2 m / 3 deg and optimized as in
# scripts/bench-optvi.sh), then `lc` within the mission. Every accepted loop edge (its measured T_A_B) is checked against the ground
# truth's relative pose; the revisits that were possible are the keyframe pairs the ground
# truth puts within 1 m and 30 deg of viewing direction, at least --lc_min_time_gap_s apart.
# Prints a markdown table: keyframes with a possible revisit, found (with >= 1 accepted loop),
# loops accepted, wrong ones (> 0.3 m or > 5 deg), median and max errors.
#
# Usage: scripts/bench-lc-euroc.sh   (VILMA_BUILD_DIR; work: ~/.cache/vilma/lc-euroc)
set -euo pipefail

repo_dir=$(cd "$(dirname "$0")/.." && pwd)
build_dir=${VILMA_BUILD_DIR:-$repo_dir/build}
cache=${VILMA_CACHE:-$HOME/.cache/vilma}
work=${BENCH_WORK:-$cache/lc-euroc}
bin=$build_dir/bin
kf=${VILMA_SHARED_DATA_DIR:-$repo_dir/../shared/data}/euroc_V1_01_keyframes
gap_s=10
[ -d "$kf" ] || { echo "bench-lc-euroc.sh: $kf missing" >&2; exit 1; }
mkdir -p "$work"
py=/usr/bin/python3
[ -x "$py" ] || py=python3

echo "| map poses | keyframes with a possible revisit | found | loops accepted | wrong (> 0.3 m or > 5 deg) | translation error median / max [m] | rotation error median / max [deg] | lc [s] |"
echo "|---|---:|---:|---:|---:|---|---|---:|"
for start in gt perturbed; do
  map=$work/map-$start
  rm -rf "$map" "$work/csv-$start"
  args=()
  [ "$start" = perturbed ] && args=(--perturb 0.2,3 --seed 1)
  "$bin/vilma" map-from-poses "$kf" --out "$map" "${args[@]}" > "$map.out" 2>&1 ||
    { cat "$map.out" >&2; exit 1; }
  recipe=""
  # The perturbed map as a robot would have it before loop closure: optimized (bench-optvi.sh's
  # recipe; elq with 2 observers: stereo keyframes).
  [ "$start" = perturbed ] && recipe="set elq_min_observers 2; optvi --evaluate_quality=false; \
    rtl; optvi --evaluate_quality=false; rtl; optvi;"
  "$bin/vilma" console -c "load $map; $recipe lc --lc_min_time_gap_s=$gap_s; \
    csv_export --out=$work/csv-$start --export_keypoints=false" > "$work/lc-$start.out" 2>&1 ||
    { cat "$work/lc-$start.out" >&2; exit 1; }
  lc_s=$(awk '/^lc: / { for (i = 1; i <= NF; ++i) if ($(i+1) == "s") { print $i; exit } }' \
    "$work/lc-$start.out" | tail -1)
  "$py" - "$work/csv-$start" "$kf/mav0/state_groundtruth_estimate0/data.csv" "$gap_s" \
    "$start" "$lc_s" <<'PY'
import csv, math, sys

folder, gt_path, gap_s, label, lc_s = sys.argv[1], sys.argv[2], float(sys.argv[3]), sys.argv[4], sys.argv[5]

def qmul(a, b):
    aw, ax, ay, az = a; bw, bx, by, bz = b
    return (aw*bw - ax*bx - ay*by - az*bz, aw*bx + ax*bw + ay*bz - az*by,
            aw*by - ax*bz + ay*bw + az*bx, aw*bz + ax*by - ay*bx + az*bw)
def qconj(q): return (q[0], -q[1], -q[2], -q[3])
def qrot(q, v):
    w = qmul(qmul(q, (0.0,) + tuple(v)), qconj(q))
    return w[1:]
def relative(pa, qa, pb, qb):  # T_A_B = T_W_A^-1 T_W_B
    d = tuple(b - a for a, b in zip(pa, pb))
    return qrot(qconj(qa), d), qmul(qconj(qa), qb)
def angle_deg(q):
    return math.degrees(2.0 * math.acos(min(1.0, abs(q[0]) / math.sqrt(sum(c * c for c in q)))))

gt = []
with open(gt_path) as f:
    for row in csv.reader(f):
        if not row or row[0].startswith('#'): continue
        gt.append((int(row[0]), tuple(map(float, row[1:4])), tuple(map(float, row[4:8]))))
gt.sort()
def gt_at(t):
    import bisect
    i = bisect.bisect_left(gt, (t,))
    best = min((abs(gt[j][0] - t), j) for j in (i - 1, i) if 0 <= j < len(gt))
    if best[0] > 5_000_000: raise SystemExit("no ground truth within 5 ms of %d" % t)
    return gt[best[1]]

vertices = {}
with open(folder + '/vertices.csv') as f:
    for row in csv.DictReader(f):
        vertices[row['vertex_id']] = int(row['t_ns'])
states = {v: gt_at(t) for v, t in vertices.items()}
ids = sorted(vertices, key=lambda v: vertices[v])

# Possible revisits: pairs >= gap apart in time, within 1 m, viewing directions within 30 deg
# (the IMU's x axis, which the EuRoC cameras look along, as the heading proxy: the angle of the
# relative rotation).
possible = set()
for i, a in enumerate(ids):
    for b in ids[i + 1:]:
        if abs(vertices[a] - vertices[b]) < gap_s * 1e9: continue
        pa, qa = states[a][1], states[a][2]
        pb, qb = states[b][1], states[b][2]
        if math.dist(pa, pb) <= 1.0 and angle_deg(qmul(qconj(qa), qb)) <= 30.0:
            possible.add(a); possible.add(b)

found, accepted, wrong, et, er = set(), 0, 0, [], []
with open(folder + '/edges.csv') as f:
    for row in csv.DictReader(f):
        if row['type'] != 'loop_closure': continue
        accepted += 1
        a, b = row['from_vertex_id'], row['to_vertex_id']
        found.add(a); found.add(b)
        p_meas = tuple(float(row['p_A_B_' + c]) for c in 'xyz')
        q_meas = tuple(float(row['q_A_B_' + c]) for c in 'wxyz')
        p_true, q_true = relative(states[a][1], states[a][2], states[b][1], states[b][2])
        e_t = math.dist(p_meas, p_true)
        e_r = angle_deg(qmul(qconj(q_true), q_meas))
        et.append(e_t); er.append(e_r)
        wrong += 1 if (e_t > 0.3 or e_r > 5.0) else 0
def med(v): return sorted(v)[len(v) // 2] if v else float('nan')
found_possible = len(found & possible)
print("| %s | %d | %d (%.0f %%) | %d | %d | %.3f / %.3f | %.2f / %.2f | %s |" % (
    'ground truth' if label == 'gt' else '0.2 m / 3 deg off, optvi; rtl x2; optvi', len(possible),
    found_possible,
    100.0 * found_possible / max(1, len(possible)), accepted, wrong, med(et), max(et or [0]),
    med(er), max(er or [0]), lc_s))
PY
done
