#!/usr/bin/env python3
"""The soak's table, CSV and plot (scripts/soak.sh, docs/reliability.md "Soak").

Inputs: the 10-s process samples of soak.sh (proc.csv: t_s, wall_us, load1, <p>_rss_mb,
<p>_cpu_pct for p in sim, daemon, mapstored) and the VILMA_STATUS reports as JSON lines
(vilma-lcm-json). Each sample gets the reports of its 10-s interval: the maximum queue depths
and latency p99s of the daemon's 1-s reports, its drop counters, and mapstored's counters.

Verdict (issue 18): RSS growth of every process <= 5 % from the baseline (5 min, or half the
run for runs shorter than 10 min) to the end; no drop (the daemon's "drops" counter, which sums
every drop counter, stays 0); latency p99 stable: the median of the 1-s latency_total p99 in
every 10-min window <= 1.5 x the first window's + 2 ms.
Usage: soak_report.py --proc CSV --status JSONL --csv OUT.csv --plot OUT.png --minutes N
Exit status: 0 PASS, 1 FAIL or bad input, 2 usage.
"""
import argparse
import csv
import json
import statistics
import sys

PROCS = ["sim", "daemon", "mapstored"]
DAEMON_MAX = ["queue_input_depth_max", "queue_filter_depth_max", "queue_output_depth_max"]
DAEMON_LAST = ["drops", "frames_dropped_busy", "images_dropped_pool", "images_dropped_input_queue",
               "map_frames_dropped", "sync_frames_dropped_overflow", "filter_state",
               "filter_resets", "map_vertices", "stream_acked", "stream_retransmitted",
               "loc_attempts", "loc_ok"]
METRICS_MAX = ["latency_total_p99_ms", "latency_filter_p99_ms", "latency_receive_p99_ms"]
STORE_LAST = ["chunks_journaled", "bytes_journaled", "chunks_undecodable"]
# The heap over the malloc arenas (mallinfo2): mapstored's status since 2026-11-27 (session 32),
# the daemon's since session 34.
HEAP_METRICS_LAST = ["heap_in_use_mb", "heap_free_mb"]


def read_proc(path):
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        need = ["t_s", "wall_us", "load1"] + [f"{p}_{k}" for p in PROCS for k in ("rss_mb", "cpu_pct")]
        missing = [c for c in need if c not in (reader.fieldnames or [])]
        if missing:
            raise ValueError(f"{path}: header: expected columns {', '.join(missing)}")
        # RssAnon columns (soak.sh since 2026-11-27 session 32): optional, older CSVs lack them.
        optional = [f"{p}_anon_mb" for p in PROCS if f"{p}_anon_mb" in (reader.fieldnames or [])]
        rows = []
        for n, row in enumerate(reader, start=2):
            try:
                rows.append({c: float(row[c]) for c in need + optional})
            except (TypeError, ValueError):
                raise ValueError(f"{path}:{n}: expected numbers in every column")
    if not rows:
        raise ValueError(f"{path}: no samples")
    return rows


def read_status(path):
    reports = []
    with open(path) as f:
        for n, line in enumerate(f, start=1):
            try:
                r = json.loads(line)
            except json.JSONDecodeError as e:
                raise ValueError(f"{path}:{n}: not JSON ({e})")
            if r.get("type") == "status":
                reports.append(r)
    reports.sort(key=lambda r: r["log_us"])
    return reports


def merge(rows, reports):
    out = []
    j = 0
    last = {"daemon": None, "mapstored": None}
    prev_us = rows[0]["wall_us"] - 10e6
    for row in rows:
        window = []
        while j < len(reports) and reports[j]["log_us"] <= row["wall_us"]:
            r = reports[j]
            if r["node"] == "vilma-estimatord":
                last["daemon"] = r
                if r["log_us"] > prev_us:
                    window.append(r)
            elif r["node"] == "vilma-mapstored":
                last["mapstored"] = r
            j += 1
        prev_us = row["wall_us"]
        m = dict(row)
        for k in DAEMON_MAX:
            m[k] = max((r["counters"].get(k, 0) for r in window), default=None)
        for k in METRICS_MAX:
            values = [r["metrics"].get(k) for r in window if r["metrics"].get(k) is not None]
            m[k] = max(values, default=None)
        d = last["daemon"]
        for k in DAEMON_LAST:
            m[k] = d["counters"].get(k) if d else None
        m["daemon_state"] = d["state"] if d else None
        for k in HEAP_METRICS_LAST:
            m["daemon_" + k] = d["metrics"].get(k) if d and "metrics" in d else None
        s = last["mapstored"]
        for k in STORE_LAST:
            m["mapstored_" + k] = s["counters"].get(k) if s else None
        for k in HEAP_METRICS_LAST:
            m["mapstored_" + k] = s["metrics"].get(k) if s and "metrics" in s else None
        m["p99_values"] = [r["metrics"]["latency_total_p99_ms"] for r in window
                           if r["metrics"].get("latency_total_p99_ms") is not None
                           and r["metrics"]["latency_total_p99_ms"] > 0]
        out.append(m)
    return out


def fmt(x, digits=1):
    return "-" if x is None else f"{x:.{digits}f}"


def write_csv(path, merged):
    columns = [c for c in merged[0].keys() if c != "p99_values"]
    with open(path, "w", newline="") as f:
        w = csv.writer(f)
        w.writerow(columns)
        for m in merged:
            w.writerow(["" if m[c] is None else m[c] for c in columns])


def plot(path, merged, title):
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    t = [m["t_s"] / 60 for m in merged]
    fig, ax = plt.subplots(4, 1, figsize=(10, 12), sharex=True)
    for p in PROCS:
        ax[0].plot(t, [m[f"{p}_rss_mb"] for m in merged], label=p)
    ax[0].set_ylabel("RSS [MB]")
    ax[0].legend()
    for p in PROCS:
        ax[1].plot(t, [m[f"{p}_cpu_pct"] for m in merged], label=f"{p} CPU %")
    ax[1].set_ylabel("CPU [% of a core]")
    load = ax[1].twinx()
    load.plot(t, [m["load1"] for m in merged], "k:", label="load average (1 min)")
    load.set_ylabel("load")
    ax[1].legend(loc="upper left")
    load.legend(loc="upper right")
    for k in METRICS_MAX[:2]:
        ax[2].plot(t, [m[k] if m[k] is not None else float("nan") for m in merged], label=k)
    ax[2].set_ylabel("latency p99 [ms]")
    q = ax[2].twinx()
    q.plot(t, [m["queue_input_depth_max"] if m["queue_input_depth_max"] is not None
               else float("nan") for m in merged], "g:", label="input queue depth max")
    q.set_ylabel("queue depth")
    ax[2].legend(loc="upper left")
    q.legend(loc="upper right")
    ax[3].plot(t, [m["drops"] if m["drops"] is not None else float("nan") for m in merged],
               label="drops (all drop counters)")
    ax[3].plot(t, [m["frames_dropped_busy"] if m["frames_dropped_busy"] is not None
                   else float("nan") for m in merged], label="frames_dropped_busy")
    ax[3].set_ylabel("drops (cumulative)")
    v = ax[3].twinx()
    v.plot(t, [m["map_vertices"] if m["map_vertices"] is not None else float("nan")
               for m in merged], "k:", label="map vertices")
    v.set_ylabel("vertices")
    ax[3].legend(loc="upper left")
    v.legend(loc="upper right")
    ax[3].set_xlabel("time [min]")
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(path, dpi=90)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--proc", required=True)
    ap.add_argument("--status", required=True)
    ap.add_argument("--csv", required=True)
    ap.add_argument("--plot", required=True)
    ap.add_argument("--minutes", type=int, required=True)
    ap.add_argument("--title", default="sim -> estimatord (LOC + mapping) -> mapstored")
    args = ap.parse_args()
    try:
        rows = read_proc(args.proc)
        reports = read_status(args.status)
    except (OSError, ValueError) as e:
        print(f"soak_report.py: {e}", file=sys.stderr)
        return 1
    merged = merge(rows, reports)
    write_csv(args.csv, merged)
    end_s = merged[-1]["t_s"]
    base_s = 300 if args.minutes >= 10 else end_s / 2
    base = min(merged, key=lambda m: abs(m["t_s"] - base_s))
    last = merged[-1]
    loads = [m["load1"] for m in merged]
    print(f"soak: {end_s / 60:.1f} min, {len(merged)} samples every 10 s; load average "
          f"median {statistics.median(loads):.2f} (min {min(loads):.2f}, max {max(loads):.2f}) "
          f"on {2} cores shared with other work")
    print()
    print(f"| process | RSS at {base['t_s'] / 60:.1f} min [MB] | RSS at end [MB] | growth | "
          f"RSS max [MB] | CPU median [% core] | CPU p90 |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    ok = True
    verdicts = []
    for p in PROCS:
        r0, r1 = base[f"{p}_rss_mb"], last[f"{p}_rss_mb"]
        growth = 100.0 * (r1 - r0) / r0 if r0 > 0 else float("inf")
        cpus = sorted(m[f"{p}_cpu_pct"] for m in merged)
        p90 = cpus[min(len(cpus) - 1, int(0.9 * len(cpus)))]
        print(f"| {p} | {r0:.1f} | {r1:.1f} | {growth:+.1f} % | "
              f"{max(m[f'{p}_rss_mb'] for m in merged):.1f} | {statistics.median(cpus):.1f} | {p90:.1f} |")
        if p != "sim":  # the simulator is the test bench, not the system under test
            passed = growth <= 5.0
            ok &= passed
            verdicts.append(f"RSS growth {p} {growth:+.1f} % (<= 5 %): {'PASS' if passed else 'FAIL'}")
    if all(f"{p}_anon_mb" in base for p in PROCS):
        # The anonymous part of RSS (heap, stacks) without the resident pages of mapped files
        # (shared libraries, which the kernel may fault in and out): where a leak would show.
        print()
        print(f"| process | RssAnon at {base['t_s'] / 60:.1f} min [MB] | RssAnon at end [MB] | "
              f"growth | RssAnon max [MB] |")
        print("|---|---:|---:|---:|---:|")
        for p in PROCS:
            a0, a1 = base[f"{p}_anon_mb"], last[f"{p}_anon_mb"]
            growth = 100.0 * (a1 - a0) / a0 if a0 > 0 else float("inf")
            print(f"| {p} | {a0:.1f} | {a1:.1f} | {growth:+.1f} % | "
                  f"{max(m[f'{p}_anon_mb'] for m in merged):.1f} |")
    for p in ("daemon", "mapstored"):
        if base.get(f"{p}_heap_in_use_mb") is None or last.get(f"{p}_heap_in_use_mb") is None:
            continue
        h0, h1 = base[f"{p}_heap_in_use_mb"], last[f"{p}_heap_in_use_mb"]
        in_use = [m[f"{p}_heap_in_use_mb"] for m in merged
                  if m.get(f"{p}_heap_in_use_mb") is not None]
        free = [m[f"{p}_heap_free_mb"] for m in merged if m.get(f"{p}_heap_free_mb") is not None]
        print(f"\n{p} heap (mallinfo2), in use: {h0:.2f} MB at {base['t_s'] / 60:.1f} min, "
              f"{h1:.2f} MB at the end, max {max(in_use):.2f} MB; free in malloc: "
              f"{base[f'{p}_heap_free_mb']:.2f} -> {last[f'{p}_heap_free_mb']:.2f} MB, "
              f"max {max(free):.2f} MB")
    if base["map_vertices"] is not None and last["map_vertices"] is not None and \
            last["map_vertices"] > base["map_vertices"]:
        per_vertex_kb = 1024.0 * (last["daemon_rss_mb"] - base["daemon_rss_mb"]) / \
            (last["map_vertices"] - base["map_vertices"])
        print(f"\ndaemon RSS growth per map vertex built after {base['t_s'] / 60:.1f} min: "
              f"{per_vertex_kb:.1f} kB ({last['map_vertices'] - base['map_vertices']:.0f} vertices)")
    print()
    drops = last["drops"]
    print(f"drops: {fmt(drops, 0)} (frames_dropped_busy {fmt(last['frames_dropped_busy'], 0)}, "
          f"images_dropped_pool {fmt(last['images_dropped_pool'], 0)}, images_dropped_input_queue "
          f"{fmt(last['images_dropped_input_queue'], 0)}, map_frames_dropped "
          f"{fmt(last['map_frames_dropped'], 0)}, sync_frames_dropped_overflow "
          f"{fmt(last['sync_frames_dropped_overflow'], 0)}); filter resets "
          f"{fmt(last['filter_resets'], 0)}; map vertices {fmt(last['map_vertices'], 0)}, "
          f"stream acked {fmt(last['stream_acked'], 0)}, retransmitted "
          f"{fmt(last['stream_retransmitted'], 0)}; localization attempts "
          f"{fmt(last['loc_attempts'], 0)}, ok {fmt(last['loc_ok'], 0)}; mapstored journaled "
          f"{fmt(last['mapstored_chunks_journaled'], 0)} chunks")
    passed = drops == 0
    ok &= passed
    verdicts.append(f"no drop ({fmt(drops, 0)}): {'PASS' if passed else 'FAIL'}")
    # Drops against the machine's load: did frames drop only when the machine was busy?
    print()
    print("| load average (1 min) | samples | samples with new drops | new drops |")
    print("|---|---:|---:|---:|")
    bins = [(0, 2), (2, 3), (3, 4), (4, 6), (6, 1e9)]
    prev = 0
    per_bin = {b: [0, 0, 0] for b in bins}
    for m in merged:
        d = m["drops"] if m["drops"] is not None else prev
        new = d - prev
        prev = d
        for b in bins:
            if b[0] <= m["load1"] < b[1]:
                per_bin[b][0] += 1
                per_bin[b][1] += 1 if new > 0 else 0
                per_bin[b][2] += new
    for b in bins:
        if per_bin[b][0]:
            label = f"{b[0]}-{b[1]}" if b[1] < 1e9 else f">= {b[0]}"
            print(f"| {label} | {per_bin[b][0]} | {per_bin[b][1]} | {per_bin[b][2]:.0f} |")
    print()
    print("| window [min] | latency_total p99 [ms]: median of 1-s p99 | max | "
          "queue input depth max | load median |")
    print("|---|---:|---:|---:|---:|")
    first = None
    stable = True
    for w0 in range(0, int(end_s) + 1, 600):
        ms = [m for m in merged if w0 < m["t_s"] <= w0 + 600]
        if not ms:
            continue
        p99s = [x for m in ms for x in m["p99_values"]]
        med = statistics.median(p99s) if p99s else None
        qd = max((m["queue_input_depth_max"] or 0) for m in ms)
        print(f"| {w0 // 60}-{min(w0 + 600, int(end_s)) // 60} | {fmt(med, 2)} | "
              f"{fmt(max(p99s) if p99s else None, 2)} | {qd} | "
              f"{statistics.median(m['load1'] for m in ms):.2f} |")
        if med is None:
            stable = False
        elif first is None:
            first = med
        elif med > 1.5 * first + 2.0:
            stable = False
    ok &= stable
    verdicts.append(f"latency p99 stable (each window's median <= 1.5 x first + 2 ms): "
                    f"{'PASS' if stable else 'FAIL'}")
    print()
    for v in verdicts:
        print(v)
    print("soak:", "PASS" if ok else "FAIL")
    try:
        plot(args.plot, merged, f"vilma soak: {end_s / 60:.0f} min, {args.title}")
    except ImportError:
        print("soak_report.py: python3-matplotlib missing: no plot", file=sys.stderr)
        return 1
    return 0 if ok else 1


if __name__ == "__main__":
    sys.exit(main())
