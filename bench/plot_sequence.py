#!/usr/bin/python3
"""Plots the per-frame results of sequence_persistent_bench: CPU time and error (relMSE against
each frame's converged reference) along each camera path, for no cache, a fresh cache per frame
and the persistent cache, and the persistent cache's memory.

    /usr/bin/python3 bench/plot_sequence.py [RESULTS.json] [OUT_DIR] [SUFFIX]

Writes OUT_DIR/sequence_<path>[SUFFIX].png (default docs/images/). Needs Debian's
python3-matplotlib.
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
    suffix = sys.argv[3] if len(sys.argv) > 3 else ""
    os.makedirs(out_dir, exist_ok=True)
    with open(src) as f:
        results = json.load(f)
    machine = results.get("machine", {})
    body = results.get("results", results)
    for path, frames in body["per_frame"].items():
        fig, (top, bottom, memory) = plt.subplots(3, 1, figsize=(8, 8), sharex=True,
                                                  gridspec_kw={"height_ratios": [3, 3, 2]})
        for key, label, style in METHODS:
            # A method may skip frames (the benchmark's --ref-every renders "none" and measures
            # the error only on frames with a reference): plot what each frame has.
            timed = [f for f in frames if key in f]
            if not timed:
                continue
            # Sparse series as points: a line across skipped frames would invent values.
            sparse = dict(linestyle="none", marker="o", markersize=4)
            top.plot([f["frame"] for f in timed], [f[key]["cpu_seconds"] for f in timed],
                     **(dict(linestyle=style) if len(timed) == len(frames) else sparse),
                     label=label)
            scored = [f for f in timed if "rel_mse" in f[key]]
            bottom.plot([f["frame"] for f in scored], [f[key]["rel_mse"] for f in scored],
                        **(dict(linestyle=style) if len(scored) == len(frames) else
                           dict(sparse, marker={"none": "s", "fresh": "x"}.get(key, "o"))),
                        label=label)
        top.set_yscale("log")
        top.set_ylabel("CPU seconds per frame")
        top.grid(True, which="both", alpha=0.3)
        top.legend(fontsize=8)
        bottom.set_ylabel("relMSE against the frame's reference")
        bottom.legend(fontsize=8)
        bottom.set_ylim(bottom=0)
        bottom.grid(True, alpha=0.3)
        # The persistent cache's size after each frame (eviction keeps it to what the camera sees).
        kept = [f for f in frames if "persistent" in f and "memory_bytes" in f["persistent"]]
        memory.plot([f["frame"] for f in kept],
                    [f["persistent"]["memory_bytes"] / 2**20 for f in kept], "-", color="C2",
                    label="persistent cache")
        memory.set_ylabel("cache MiB")
        memory.set_ylim(bottom=0)
        memory.set_xlabel("frame")
        memory.grid(True, alpha=0.3)
        memory.legend(fontsize=8)
        commit = machine.get("git", {}).get("commit", "")[:7]
        settings = body.get("settings", {})
        size = f", {settings['width']} px wide, {settings['spp']} spp" if "width" in settings else ""
        fig.suptitle(f"{path}: per frame{size} (commit {commit})")
        fig.tight_layout()
        out = os.path.join(out_dir, f"sequence_{path}{suffix}.png")
        fig.savefig(out, dpi=110)
        plt.close(fig)
        print("wrote", out)


if __name__ == "__main__":
    main()
