#!/usr/bin/env python3
"""Flicker: how a sequence's frames differ from one another beyond how the converged frames do.

For a camera path, renders frames FIRST-LAST with `sequence` (defaults: 320x240, 16 spp, the
persistent vdb cache) raw and denoised (`--denoise on`, each frame filtered on its own), then
filtered over time with `--temporal K --temporal-only` for each K of --temporal, and the same
frames converged (uncached, --ref-spp, cached under --refs). Reports

  * the per-frame error: relMSE, mean over pixels and frames of (x - r)^2 / (r^2 + 0.01);
  * the temporal error: mean over pixels and frame pairs of
    ((x[t+1] - x[t]) - (r[t+1] - r[t]))^2 / (((r[t] + r[t+1]) / 2)^2 + 0.01)
    (issue 37). Independent noise in every frame makes it twice the per-frame error; a filter
    that carries samples from frame to frame brings it under;
  * the per-frame relMSE within 3 px of the reference's depth steps (ghosts would show there).

Writes bench/results/NAME.json and .csv (machine description + rows). Needs numpy (Debian's
python3-numpy; the benchmark runs it with /usr/bin/python3 if the default python lacks it).

    python3 bench/temporal_stability.py --dofcache build/dofcache --refs DIR
"""

import argparse
import json
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)
sys.path.insert(0, os.path.join(HERE, "peer"))
sys.path.insert(0, HERE)
import peer_bench as pb  # noqa: E402
from denoise_quicklook import dump, run  # noqa: E402

try:
    import numpy as np
except ImportError:  # a Python without Debian's numpy: run again with the system one
    if sys.executable != "/usr/bin/python3" and os.path.exists("/usr/bin/python3"):
        os.execv("/usr/bin/python3", ["/usr/bin/python3"] + sys.argv)
    raise SystemExit("temporal_stability.py needs numpy (apt-get install python3-numpy)")

PATHS = {"dolly": ("cornell_box_dolly.gltf", None),
         "focus_pull": ("cornell_box.gltf", "paths/cornell_focus_pull.json"),
         "gallery_walk": ("gallery.glb", "paths/gallery_walk.json")}


def load(path, channels="R,G,B"):
    """The named channels of an image as a float array (height, width, channels)."""
    pixels = dump(path, channels)
    w = 1 + max(x for x, _ in pixels)
    h = 1 + max(y for _, y in pixels)
    a = np.zeros((h, w, len(next(iter(pixels.values())))))
    for (x, y), v in pixels.items():
        a[y, x] = v
    return a


def edge_bands(depths, jump=0.05, radius=3):
    """Per frame, the pixels within `radius` of a depth discontinuity of the reference (a step
    over `jump` relative, or between surface and background): where a temporal filter that
    reprojects wrongly leaves ghosts."""
    bands = []
    for z in depths:
        z = z[..., 0]
        finite = z < 1e30
        edge = np.zeros(z.shape, bool)
        for axis in (0, 1):
            a = z.take(range(z.shape[axis] - 1), axis)
            b = z.take(range(1, z.shape[axis]), axis)
            fa = finite.take(range(z.shape[axis] - 1), axis)
            fb = finite.take(range(1, z.shape[axis]), axis)
            with np.errstate(invalid="ignore"):
                step = (fa != fb) | (fa & fb & (np.abs(a - b) > jump * np.minimum(a, b)))
            lo = [slice(None)] * 2
            hi = [slice(None)] * 2
            lo[axis] = slice(0, z.shape[axis] - 1)
            hi[axis] = slice(1, None)
            edge[tuple(lo)] |= step
            edge[tuple(hi)] |= step
        band = edge.copy()
        for _ in range(radius):  # dilate by one pixel (4-neighbours) at a time
            grown = band.copy()
            grown[1:] |= band[:-1]
            grown[:-1] |= band[1:]
            grown[:, 1:] |= band[:, :-1]
            grown[:, :-1] |= band[:, 1:]
            band = grown
        bands.append(band)
    return bands


def errors(frames, refs, bands=None):
    per_frame = np.mean([np.mean((x - r) ** 2 / (r * r + 1e-2)) for x, r in zip(frames, refs)])
    temporal = np.mean([np.mean(((frames[t + 1] - frames[t]) - (refs[t + 1] - refs[t])) ** 2 /
                                (((refs[t] + refs[t + 1]) / 2) ** 2 + 1e-2))
                        for t in range(len(frames) - 1)])
    if bands is None:
        return float(per_frame), float(temporal)
    edge = np.mean([np.mean(((x - r) ** 2 / (r * r + 1e-2))[b]) for x, r, b in
                    zip(frames, refs, bands)])
    return float(per_frame), float(temporal), float(edge)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--dofcache", default=os.path.join(REPO, "build", "dofcache"))
    p.add_argument("--refs", required=True, help="directory of the converged frames (made here)")
    p.add_argument("--paths", nargs="+", default=["dolly"], choices=sorted(PATHS))
    p.add_argument("--frames", default="0-5")
    p.add_argument("--width", type=int, default=320)
    p.add_argument("--spp", type=int, default=16)
    p.add_argument("--ref-spp", type=int, default=256)
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--temporal", type=int, nargs="*", default=[1, 2, 3],
                   help="windows (frames on each side) of the temporal filter to measure")
    p.add_argument("--work", default="/tmp/dofcache-temporal")
    p.add_argument("--results", default="temporal_stability")
    a = p.parse_args()
    first, last = (int(v) for v in a.frames.split("-"))
    numbers = range(first, last + 1)
    rows = []
    for name in a.paths:
        scene_file, path_file = PATHS[name]
        base = [a.dofcache, "sequence", os.path.join(REPO, "scenes", scene_file), "--frames",
                a.frames, "--width", str(a.width), "--threads", str(a.threads), "-q"]
        if path_file:
            base += ["--path", os.path.join(REPO, "scenes", path_file)]
        ref_dir = os.path.join(a.refs, "%s_%d_%d" % (name, a.width, a.ref_spp))
        if not all(os.path.isfile(os.path.join(ref_dir, "%04d.exr" % n)) for n in numbers):
            os.makedirs(ref_dir, exist_ok=True)
            # Frames already there are kept (the sequence resumes past them).
            run(base + ["--spp", str(a.ref_spp), "--cache", "none", "--seed", "1000003",
                        "-o", os.path.join(ref_dir, "####.exr")])
        refs = [load(os.path.join(ref_dir, "%04d.exr" % n)) for n in numbers]
        bands = edge_bands([load(os.path.join(ref_dir, "%04d.exr" % n), "Z") for n in numbers])
        work = os.path.join(a.work, name)
        os.makedirs(work, exist_ok=True)
        out = os.path.join(work, "####.exr")
        stats = os.path.join(work, "stats.json")
        run(base + ["--spp", str(a.spp), "--persistent", "--denoise", "on", "--restart", "-o",
                    out, "--stats-json", stats])
        with open(stats) as f:
            frame_stats = json.load(f)["per_frame"]
        seconds = sum(f["seconds"] for f in frame_stats)
        denoise_seconds = sum(f.get("denoise_seconds", 0.0) for f in frame_stats)
        raw = [load(os.path.join(work, "%04d.exr" % n)) for n in numbers]
        denoised = [load(os.path.join(work, "%04d.exr" % n), "denoised.R,denoised.G,denoised.B")
                    for n in numbers]
        kinds = [("raw", raw, seconds - denoise_seconds), ("denoised", denoised, seconds)]
        for k in a.temporal:
            # The temporal filter over the frames just written, as the farm's last job runs it.
            t_stats = os.path.join(work, "temporal%d.json" % k)
            run(base + ["--spp", str(a.spp), "--persistent", "--denoise", "on", "-o", out,
                        "--temporal", str(k), "--temporal-only", "--temporal-output",
                        os.path.join(work, "t%d_####.exr" % k), "--stats-json", t_stats])
            with open(t_stats) as f:
                t_seconds = sum(r["seconds"] for r in json.load(f)["temporal"]["per_frame"])
            kinds.append(("temporal-%d" % k,
                          [load(os.path.join(work, "t%d_%04d.exr" % (k, n))) for n in numbers],
                          seconds + t_seconds))
        for kind, frames, kind_seconds in kinds:
            per_frame, temporal, edge = errors(frames, refs, bands)
            row = {"path": name, "frames": a.frames, "width": a.width, "spp": a.spp,
                   "ref_spp": a.ref_spp, "kind": kind, "per_frame_rel_mse": per_frame,
                   "temporal_error": temporal, "ratio": temporal / per_frame,
                   "edge_band_rel_mse": edge, "seconds": kind_seconds}
            rows.append(row)
            print("%-12s %-11s per-frame %.5f  temporal %.5f  (x%.2f)  edge band %.5f  %.1f s" % (
                name, kind, per_frame, temporal, row["ratio"], edge, row["seconds"]), flush=True)
    path = pb.write_results(a.results, {
        "description": "per-frame and temporal error of sequences against converged frames, "
                       "raw, denoised frame by frame, and temporally filtered over K frames on "
                       "each side (issue 37's temporal measure; edge band: within 3 px of the "
                       "reference's depth steps, where ghosts would show)",
        "columns": list(rows[0].keys()), "rows": rows}, None)
    print("wrote %s" % path)


if __name__ == "__main__":
    main()
