#!/usr/bin/env python3
"""Recall vs pruning fraction of landmark summarization (scripts/bench-summarization.sh), as the
summarization figure of the maplab paper: one line per method (ilp, random, most_observed), solid
without keyframing, dashed with kfh. Usage: plot_summarization.py SUMMARIZATION.csv OUT.png"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main():
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    rows = list(csv.DictReader(open(sys.argv[1])))
    fig, ax = plt.subplots(figsize=(7, 4.5))
    colors = {"ilp": "tab:blue", "random": "tab:orange", "most_observed": "tab:green"}
    for database, style in (("full", "-"), ("kfh", "--")):
        full = [r for r in rows if r["database"] == database and float(r["pruning"]) == 0.0]
        for method, color in colors.items():
            points = full + [r for r in rows if r["database"] == database and
                             r["method"] == method and float(r["pruning"]) > 0.0]
            points.sort(key=lambda r: float(r["pruning"]))
            if len(points) < 2:
                continue
            ax.plot([float(r["pruning"]) for r in points],
                    [float(r["recall_percent"] or 0.0) for r in points], style, marker="o",
                    color=color, label=f"{method} ({'with kfh' if database == 'kfh' else 'all vertices'})")
    ax.set_xlabel("pruning fraction (landmarks removed)")
    ax.set_ylabel("recall within 0.5 m [%]")
    ax.set_ylim(0, 100)
    ax.grid(True, alpha=0.3)
    ax.legend(fontsize=8)
    ax.set_title("Localization recall vs landmark pruning (simulated room, 4 sessions -> 5th)")
    fig.tight_layout()
    fig.savefig(sys.argv[2], dpi=110)


if __name__ == "__main__":
    main()
