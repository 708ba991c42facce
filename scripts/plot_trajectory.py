#!/usr/bin/env python3
"""Plot an evaluated trajectory: top-down (x-y) view of the aligned estimate over the ground
truth, and the translation / rotation error over time.

Input: the CSV that `vilma eval --plot` writes (aligned, matched poses):
    t_s,gt_x,gt_y,gt_z,est_x,est_y,est_z,translation_error_m,rotation_error_deg
Usage: plot_trajectory.py --input CSV --output OUT.png [--title TEXT]
Exit codes: 0 ok, 1 bad input, 2 usage, 3 matplotlib missing (vilma eval tries another python).
"""
import argparse
import csv
import sys

NO_MATPLOTLIB = 3


def read_csv(path):
    columns = ["t_s", "gt_x", "gt_y", "gt_z", "est_x", "est_y", "est_z",
               "translation_error_m", "rotation_error_deg"]
    data = {c: [] for c in columns}
    with open(path, newline="") as f:
        reader = csv.DictReader(f)
        missing = [c for c in columns if c not in (reader.fieldnames or [])]
        if missing:
            raise ValueError(f"{path}: header: expected columns {', '.join(missing)}")
        for line_number, row in enumerate(reader, start=2):
            try:
                for c in columns:
                    data[c].append(float(row[c]))
            except (TypeError, ValueError):
                raise ValueError(f"{path}: line {line_number}: expected {len(columns)} numbers")
    if not data["t_s"]:
        raise ValueError(f"{path}: expected at least one pose")
    return data


def main():
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--input", required=True, help="CSV written by vilma eval")
    parser.add_argument("--output", required=True, help="PNG to write")
    parser.add_argument("--title", default="", help="figure title")
    args = parser.parse_args()

    try:
        import matplotlib
        matplotlib.use("Agg")  # no display needed
        import matplotlib.pyplot as plt
    except ImportError as e:
        print(f"plot_trajectory.py: matplotlib not available ({e}); "
              "install python3-matplotlib", file=sys.stderr)
        return NO_MATPLOTLIB

    try:
        d = read_csv(args.input)
    except (OSError, ValueError) as e:
        print(f"plot_trajectory.py: error: {e}", file=sys.stderr)
        return 1

    fig, (ax_xy, ax_err) = plt.subplots(
        1, 2, figsize=(14, 6), gridspec_kw={"width_ratios": [1, 1.3]})
    # Top-down view, equal axes so that shapes and drift are not distorted.
    ax_xy.plot(d["gt_x"], d["gt_y"], color="0.2", linewidth=2.0, label="ground truth")
    ax_xy.plot(d["est_x"], d["est_y"], color="tab:red", linewidth=1.2, label="estimate (aligned)")
    ax_xy.plot(d["gt_x"][0], d["gt_y"][0], "o", color="tab:green", markersize=8, label="start")
    ax_xy.plot(d["gt_x"][-1], d["gt_y"][-1], "s", color="0.2", markersize=7, label="end")
    ax_xy.set_aspect("equal", adjustable="datalim")
    ax_xy.set_xlabel("x [m]")
    ax_xy.set_ylabel("y [m]")
    ax_xy.set_title("top-down view (x-y)")
    ax_xy.grid(True, alpha=0.3)
    ax_xy.legend(loc="best")

    ax_err.plot(d["t_s"], d["translation_error_m"], color="tab:blue", linewidth=1.2)
    ax_err.set_xlabel("time since first matched pose [s]")
    ax_err.set_ylabel("translation error [m]", color="tab:blue")
    ax_err.tick_params(axis="y", labelcolor="tab:blue")
    # Head room above the largest value, so that a constant error is not hidden by the frame.
    ax_err.set_ylim(0.0, 1.15 * max(max(d["translation_error_m"]), 1e-9))
    ax_err.grid(True, alpha=0.3)
    ax_rot = ax_err.twinx()
    ax_rot.plot(d["t_s"], d["rotation_error_deg"], color="tab:orange", linewidth=1.0, alpha=0.7)
    ax_rot.set_ylabel("rotation error [deg]", color="tab:orange")
    ax_rot.tick_params(axis="y", labelcolor="tab:orange")
    ax_rot.set_ylim(0.0, 1.15 * max(max(d["rotation_error_deg"]), 1e-9))
    # The translation error (the headline number) is drawn above the rotation error.
    ax_err.set_zorder(ax_rot.get_zorder() + 1)
    ax_err.patch.set_visible(False)
    ax_err.set_title("absolute error of the aligned estimate")

    if args.title:
        fig.suptitle(args.title)
    fig.tight_layout()
    try:
        fig.savefig(args.output, dpi=110)
    except OSError as e:
        print(f"plot_trajectory.py: error: {args.output}: {e}", file=sys.stderr)
        return 1
    return 0


if __name__ == "__main__":
    sys.exit(main())
