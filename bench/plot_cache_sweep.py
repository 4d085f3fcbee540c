#!/usr/bin/python3
"""Plots bench/results/cache_sweep.json (written by cache_sweep_bench): lookups per CPU-second and
bytes per sample against the number of samples, one line per backend and trace.

    /usr/bin/python3 bench/plot_cache_sweep.py [RESULTS.json] [OUT.png]

Needs Debian's python3-matplotlib (apt-get install python3-matplotlib).
"""
import json
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def main():
    src = sys.argv[1] if len(sys.argv) > 1 else os.path.join(ROOT, "bench/results/cache_sweep.json")
    out = sys.argv[2] if len(sys.argv) > 2 else os.path.join(ROOT, "docs/images/cache_sweep.png")
    with open(src) as f:
        results = json.load(f)
    machine = results.get("machine", {})
    body = results.get("results", results)
    series = {}
    for row in body["rows"]:
        series.setdefault((row["trace"], row["backend"]), []).append(row)
    traces = sorted({t for t, _ in series})
    colours = dict(zip(traces, plt.rcParams["axes.prop_cycle"].by_key()["color"]))
    styles = {"octree": "--o", "vdb": "-s"}

    fig, (left, right) = plt.subplots(1, 2, figsize=(11, 4.2))
    for (trace, backend), rows in sorted(series.items()):
        rows.sort(key=lambda r: r["samples"])
        n = [r["samples"] for r in rows]
        style = styles.get(backend, "-")
        label = f"{backend}, {trace}"
        left.plot(n, [r["lookups/cpu-s"] / 1e6 for r in rows], style, color=colours[trace],
                  label=label, markersize=4)
        right.plot(n, [r["bytes/sample"] for r in rows], style, color=colours[trace],
                   label=label, markersize=4)
    for ax in (left, right):
        ax.set_xscale("log")
        ax.set_xlabel("samples in the cache")
        ax.grid(True, which="both", alpha=0.3)
    left.set_ylabel("lookups per CPU-second (millions, one thread)")
    left.set_ylim(bottom=0)
    right.set_ylabel("bytes per sample")
    right.set_ylim(bottom=0)
    right.legend(fontsize=7, loc="upper right")
    commit = machine.get("git", {}).get("commit", "")[:7]
    fig.suptitle("Radiance-cache backends on recorded render traces (dashed: octree, solid: vdb)"
                 f", commit {commit}")
    fig.tight_layout()
    fig.savefig(out, dpi=110)
    print("wrote", out)


if __name__ == "__main__":
    main()
