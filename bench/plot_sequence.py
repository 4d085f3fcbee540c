#!/usr/bin/python3
"""Plots the per-frame results of sequence_persistent_bench: CPU time and error (relMSE against
each frame's converged reference) along each camera path, for no cache, a fresh cache per frame
and the persistent cache.

    /usr/bin/python3 bench/plot_sequence.py [RESULTS.json] [OUT_DIR]

Writes OUT_DIR/sequence_<path>.png (default docs/images/). Needs Debian's python3-matplotlib.
"""
import json
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
METHODS = [("none", "no cache", ":"), ("fresh", "fresh cache per frame", "--"),
           ("persistent", "persistent cache", "-")]


def main():
    src = sys.argv[1] if len(sys.argv) > 1 else os.path.join(
        ROOT, "bench/results/sequence_persistent.json")
    out_dir = sys.argv[2] if len(sys.argv) > 2 else os.path.join(ROOT, "docs/images")
    with open(src) as f:
        results = json.load(f)
    machine = results.get("machine", {})
    body = results.get("results", results)
    for path, frames in body["per_frame"].items():
        fig, (top, bottom) = plt.subplots(2, 1, figsize=(8, 6), sharex=True)
        for key, label, style in METHODS:
            # A method may skip frames (the benchmark's --ref-every renders "none" and measures
            # the error only on frames with a reference): plot what each frame has.
            timed = [f for f in frames if key in f]
            if not timed:
                continue
            top.plot([f["frame"] for f in timed], [f[key]["cpu_seconds"] for f in timed], style,
                     marker="." if len(timed) < len(frames) else None, label=label)
            scored = [f for f in timed if "rel_mse" in f[key]]
            bottom.plot([f["frame"] for f in scored], [f[key]["rel_mse"] for f in scored], style,
                        marker="o" if len(scored) < len(frames) else None, markersize=3,
                        label=label)
        top.set_yscale("log")
        top.set_ylabel("CPU seconds per frame")
        top.grid(True, which="both", alpha=0.3)
        top.legend(fontsize=8)
        bottom.set_ylabel("relMSE against the frame's reference")
        bottom.legend(fontsize=8)
        bottom.set_ylim(bottom=0)
        bottom.set_xlabel("frame")
        bottom.grid(True, alpha=0.3)
        commit = machine.get("git", {}).get("commit", "")[:7]
        fig.suptitle(f"{path}: per-frame time and error (commit {commit})")
        fig.tight_layout()
        out = os.path.join(out_dir, f"sequence_{path}.png")
        fig.savefig(out, dpi=110)
        plt.close(fig)
        print("wrote", out)


if __name__ == "__main__":
    main()
