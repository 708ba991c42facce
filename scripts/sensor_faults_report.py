#!/usr/bin/env python3
"""The table of scripts/sensor-faults.sh (docs/reliability.md "Sensor faults").

Per run (runs.txt: name|fault|fault end [s after the dataset's first stamp]|run folder, the first
run clean) it reads bus.jsonl (VILMA_ODOM poses and VILMA_STATUS reports as vilma-lcm-json
writes them, log_us = lcm-logger's receive time) and imu_wall.txt (IMU seq and receive time).
The fault's end on the wall clock is the receive time of the first IMU sample at or after it
(IMU seq numbers are those of the dataset: time jumps do not change them). Recovery = the
receive time of the first valid pose (status TRACKING or LOCALIZED, finite) at or after that
instant, minus that instant. Position difference to the clean run: poses matched by stamp
(within 1 ms; runs with shifted stamps have none during the shift; after a restart of the
filter the poses are in a new frame M and not compared).
Usage: sensor_faults_report.py --runs runs.txt --dataset DIR --start S
Exit status: 0 when every fault recovered within 1 s, 1 otherwise or on bad input.
"""
import argparse
import json
import math
import sys

VALID = (2, 3)  # pose_t TRACKING, LOCALIZED
POSE_STATUS = {0: "INVALID", 1: "INITIALIZING", 2: "TRACKING", 3: "LOCALIZED", 4: "LOST"}
NODE_STATE = {0: "STARTING", 1: "OK", 2: "DEGRADED", 3: "ERROR", 4: "STOPPING"}
COUNTERS = ["camera_silences", "time_jump_restarts", "time_jump_resumes",
            "time_jump_imu_restamped", "filter_resets", "sync_imu_gaps",
            "sync_imu_duplicates", "sync_imu_out_of_order", "sync_imu_time_jumps",
            "sync_imu_stale", "sync_images_duplicate", "sync_images_out_of_order",
            "sync_images_late", "sync_image_time_jumps", "sync_images_stale",
            "sync_frames_dropped_no_imu", "sync_frames_dropped_time_jump",
            "sync_frames_incomplete", "frames_dropped_busy", "drops"]


def read_imu_stamps(dataset):
    stamps = []
    with open(f"{dataset}/mav0/imu0/data.csv") as f:
        for line in f:
            if line.startswith("#") or not line.strip():
                continue
            stamps.append(int(line.split(",")[0]))
    return stamps


def read_run(folder):
    poses, status = [], []
    with open(f"{folder}/bus.jsonl") as f:
        for line in f:
            r = json.loads(line)
            if r["type"] == "pose" and r["channel"] == "VILMA_ODOM":
                poses.append(r)
            elif r["type"] == "status" and r["node"] == "vilma-estimatord":
                status.append(r)
    imu = []
    with open(f"{folder}/imu_wall.txt") as f:
        for line in f:
            seq, us = line.split()
            imu.append((int(seq), int(us)))
    return poses, status, imu


def valid(p):
    return p["status"] in VALID and all(x is not None and math.isfinite(x) for x in p["position"])


def distance(a, b):
    return math.sqrt(sum((x - y) ** 2 for x, y in zip(a, b)))


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--runs", required=True)
    ap.add_argument("--dataset", required=True)
    ap.add_argument("--start", type=float, required=True)
    args = ap.parse_args()
    try:
        imu_stamps = read_imu_stamps(args.dataset)
        runs = [line.rstrip("\n").split("|") for line in open(args.runs) if line.strip()]
        data = {r[3]: read_run(r[3]) for r in runs}
    except (OSError, ValueError, KeyError, IndexError) as e:
        print(f"sensor_faults_report.py: {e}", file=sys.stderr)
        return 1
    t_first = imu_stamps[0]
    clean_poses = {p["utime"]: p for p in data[runs[0][3]][0] if valid(p)}

    def seq_at(t_s):
        t_ns = t_first + round(t_s * 1e9)
        return next((i for i, t in enumerate(imu_stamps) if t >= t_ns), len(imu_stamps))

    def wall_of_seq(imu, seq):
        return next((us for s, us in imu if s >= seq), None)

    print("| fault | recovery [ms] | pose status during the fault | daemon state / message "
          "during the fault | counters that moved | position vs clean run: after / end [m] |")
    print("|---|---:|---|---|---|---|")
    all_ok = True
    for name, fault, fault_end, folder in runs:
        poses, status, imu = data[folder]
        if not fault:
            n_valid = sum(1 for p in poses if valid(p))
            print(f"| {name} | - | {n_valid} valid poses of {len(poses)} | "
                  f"{', '.join(sorted({NODE_STATE.get(s['state'], '?') for s in status}))} | "
                  f"drops {status[-1]['counters'].get('drops') if status else '-'} | - |")
            continue
        start_wall = wall_of_seq(imu, seq_at(args.start))
        end_wall = wall_of_seq(imu, seq_at(float(fault_end)))
        if start_wall is None or end_wall is None:
            print(f"| {name} | no IMU in the log | | | | |")
            all_ok = False
            continue
        after = [p for p in poses if p["log_us"] >= end_wall and valid(p)]
        recovery_ms = (after[0]["log_us"] - end_wall) / 1e3 if after else None
        ok = recovery_ms is not None and recovery_ms < 1000.0
        all_ok &= ok
        until = after[0]["log_us"] if after else float("inf")
        during = [p for p in poses if start_wall <= p["log_us"] <= until]
        seen = sorted({POSE_STATUS.get(p["status"], "?") for p in during})
        statuses_during = [s for s in status if start_wall <= s["log_us"] <= max(until, end_wall) + 1e6]
        states = sorted({NODE_STATE.get(s["state"], "?") for s in statuses_during})
        messages = sorted({s["message"] for s in statuses_during})
        before = [s for s in status if s["log_us"] < start_wall]
        later = [s for s in status if s["log_us"] >= max(until, end_wall) + 1.5e6] or status[-1:]
        moved = []
        if before and later:
            for c in COUNTERS:
                d = later[0]["counters"].get(c, 0) - before[-1]["counters"].get(c, 0)
                if d:
                    moved.append(f"{c} +{d}")
        # Position against the clean run (same stamps: unshifted runs only).
        first_diff = end_diff = None
        matched = [p for p in after if p["utime"] in clean_poses]
        if matched:
            first_diff = distance(matched[0]["position"], clean_poses[matched[0]["utime"]]["position"])
            end_diff = distance(matched[-1]["position"], clean_poses[matched[-1]["utime"]]["position"])
        diff = "-" if first_diff is None else f"{first_diff:.3f} / {end_diff:.3f}"
        # Positions after the fault are in the clean run's frame M unless the filter reset or a
        # jump restarted it without a later resume of the pre-jump filter.
        def moved_by(c):
            return sum(int(m.split(" +")[1]) for m in moved if m.startswith(c + " "))
        if (moved_by("filter_resets") > 0 or
                moved_by("time_jump_restarts") > moved_by("time_jump_resumes")):
            diff = "restarted: a new frame M"  # positions of another odometry frame
        msg = "; ".join(messages[:3]) + (" ..." if len(messages) > 3 else "")
        print(f"| {name} (`{fault}`) | {'never' if recovery_ms is None else f'{recovery_ms:.0f}'} "
              f"{'' if ok else '(FAIL)'} | {', '.join(seen) or 'no pose'} | "
              f"{'/'.join(states) or '-'}: {msg or '-'} | {', '.join(moved) or 'none'} | {diff} |")
    print()
    print("sensor faults:", "PASS (every recovery < 1 s)" if all_ok else "FAIL")
    return 0 if all_ok else 1


if __name__ == "__main__":
    sys.exit(main())
