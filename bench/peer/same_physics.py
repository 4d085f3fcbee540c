#!/usr/bin/env python3
"""Same physics, checked: dofcache and Blender Cycles converge to the same image.

Each renderer is measured against its own converged reference in the peer benchmark, which would
hide a bias that both its ladder and its reference share. Here both render every scene as pure
Lambertian reflectors (dofcache `--material-override lambert`, cycles_render.py `--lambert`),
through a pinhole (dofcache `--mode pinhole`; Cycles with an aperture of 1e-9 of the focal length),
uncached, with 0 and with 1 bounce, each as K independent batches of S samples per pixel. Then:

  * per tile of a 4x4 grid, the difference of the two tile means (of the pixels' luminance) must
    lie within three standard errors of that difference. A tile mean's standard error comes from
    the pixels' spread across the batches: the variance of pixel p's K-batch mean is
    var_k(x_pk) / K, pixels are independent, so var(tile mean) = sum_p var_p / n^2;
  * the image means must agree within 1 %.

A failure is a bug to find, in dofcache or in the mapping of the scene to Cycles. Results go to
bench/results/NAME.json and .csv with the machine; exit status 1 if any check fails.

    python3 bench/peer/same_physics.py --dofcache build/dofcache [--width 160 --height 120
        --batches 4 --batch-spp 256 --scenes cornell_box ...]
"""

import argparse
import json
import math
import os
import subprocess
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
import peer_bench as pb  # noqa: E402  (shared process, results and machine helpers)

LUMA = (0.2126, 0.7152, 0.0722)


# ---------------------------------------------------------------------------------------------
# the arithmetic (tests/bench/same_physics_test.py)


def pixel_moments(batches):
    """Per pixel, the mean of K batch values and the variance of that mean (var_k / K, ddof 1).

    `batches`: K lists of the same length (one value per pixel)."""
    k = len(batches)
    if k < 2:
        raise ValueError("the standard errors need at least two batches")
    n = len(batches[0])
    means, variances = [0.0] * n, [0.0] * n
    for p in range(n):
        xs = [b[p] for b in batches]
        m = sum(xs) / k
        means[p] = m
        variances[p] = sum((x - m) ** 2 for x in xs) / (k - 1) / k
    return means, variances


def tile_stats(means, variances, width, height, grid=4):
    """Per tile of a grid x grid split (row-major, tiles as equal as integer bounds allow): the mean
    of the pixel means and its standard error sqrt(sum var_p) / n."""
    tiles = []
    for ty in range(grid):
        y0, y1 = ty * height // grid, (ty + 1) * height // grid
        for tx in range(grid):
            x0, x1 = tx * width // grid, (tx + 1) * width // grid
            s, v, n = 0.0, 0.0, 0
            for y in range(y0, y1):
                for x in range(x0, x1):
                    p = y * width + x
                    s += means[p]
                    v += variances[p]
                    n += 1
            tiles.append({"mean": s / n, "se": math.sqrt(v) / n, "pixels": n})
    return tiles


def compare_tiles(a, b, sigmas=3.0):
    """Each tile's difference a - b, its standard error and z; `ok` when |z| <= sigmas."""
    out = []
    for ta, tb in zip(a, b):
        diff = ta["mean"] - tb["mean"]
        se = math.sqrt(ta["se"] ** 2 + tb["se"] ** 2)
        z = diff / se if se > 0 else (0.0 if diff == 0 else math.inf)
        out.append({"a": ta["mean"], "b": tb["mean"], "diff": diff, "se": se, "z": z,
                    "ok": abs(z) <= sigmas})
    return out


def relative_difference(a, b):
    return (a - b) / b if b != 0 else (0.0 if a == 0 else math.inf)


# ---------------------------------------------------------------------------------------------
# images


def read_luminance(path, width, height):
    """Per-pixel luminance (Rec. 709) of an EXR's R, G, B, through oiiotool --dumpdata."""
    rgb = path + ".rgb.exr"
    pb.run(["oiiotool", path, "-ch", "R,G,B", "-o", rgb], "oiiotool -ch")
    _, text = pb.run(["oiiotool", "--dumpdata", rgb], "oiiotool --dumpdata")
    values = [0.0] * (width * height)
    seen = 0
    for line in text.splitlines():
        line = line.strip()
        if not line.startswith("Pixel ("):
            continue
        head, _, data = line.partition("):")
        x, y = (int(v) for v in head[len("Pixel ("):].split(","))
        r, g, b = (float(v) for v in data.split()[:3])
        values[y * width + x] = LUMA[0] * r + LUMA[1] * g + LUMA[2] * b
        seen += 1
    if seen != width * height:
        raise pb.BenchError("%s: %d pixels read, expected %dx%d" % (path, seen, width, height))
    return values


def resolved_lens(dofcache, scene, width, height):
    """The lens dofcache resolves for the scene (autofocus included), from --print-request."""
    _, out = pb.run([dofcache, "render", scene, "--width", str(width), "--height", str(height),
                     "--print-request"], "dofcache --print-request")
    return json.loads(out)["lens"]


def render_batches(a, scene, name, bounces, lens, work):
    """K batches of each renderer (kept in `work`: a rerun reuses what exists)."""
    out = {"dofcache": [], "cycles": []}
    for k in range(a.batches):
        seed = 1 + k
        d = os.path.join(work, "%s_b%d_dofcache_%d.exr" % (name, bounces, k))
        if not os.path.isfile(d):
            pb.run([a.dofcache, "render", scene, "--mode", "pinhole", "--material-override",
                    "lambert", "--cache", "none", "--bounces", str(bounces), "--light-samples",
                    "1", "--gather-rays", "1", "--spp", str(a.batch_spp), "--seed", str(seed),
                    "--width", str(a.width), "--height", str(a.height), "--threads",
                    str(a.threads), "--out", d, "-q"], "dofcache %s batch %d" % (name, k))
        c = os.path.join(work, "%s_b%d_cycles_%d.exr" % (name, bounces, k))
        if not os.path.isfile(c):
            pb.run([a.blender, "-b", "--factory-startup", "--python", pb.CYCLES_SCRIPT, "--",
                    scene, "--out", c, "--spp", str(a.batch_spp), "--seed", str(seed),
                    "--width", str(a.width), "--height", str(a.height), "--bounces",
                    str(bounces), "--threads", str(a.threads), "--lambert",
                    "--focal-length", repr(lens["focal_length"]), "--fstop", "1e9",
                    "--focus-distance", repr(lens["focus_distance"])],
                   "Cycles %s batch %d" % (name, k))
        out["dofcache"].append(read_luminance(d, a.width, a.height))
        out["cycles"].append(read_luminance(c, a.width, a.height))
    return out


def check(a, name, scene, bounces, work):
    lens = resolved_lens(a.dofcache, scene, a.width, a.height)
    b = render_batches(a, scene, name, bounces, lens, work)
    stats = {}
    for r in ("dofcache", "cycles"):
        means, variances = pixel_moments(b[r])
        stats[r] = (means, tile_stats(means, variances, a.width, a.height))
    tiles = compare_tiles(stats["dofcache"][1], stats["cycles"][1])
    mean_d = sum(stats["dofcache"][0]) / len(stats["dofcache"][0])
    mean_c = sum(stats["cycles"][0]) / len(stats["cycles"][0])
    rel = relative_difference(mean_d, mean_c)
    worst = max(tiles, key=lambda t: abs(t["z"]))
    return {"scene": name, "bounces": bounces, "mean_dofcache": mean_d, "mean_cycles": mean_c,
            "mean_rel_diff": rel, "mean_ok": abs(rel) <= 0.01,
            "tiles_ok": sum(t["ok"] for t in tiles), "tiles": len(tiles),
            "worst_tile_z": worst["z"], "worst_tile_rel_diff": relative_difference(
                worst["a"], worst["b"]),
            "ok": abs(rel) <= 0.01 and all(t["ok"] for t in tiles), "tile_detail": tiles}


def main(argv=None):
    p = argparse.ArgumentParser(prog="same_physics.py", description=__doc__.split("\n")[0])
    p.add_argument("--dofcache", default=os.path.join(pb.REPO, "build", "dofcache"))
    p.add_argument("--blender", default=None)
    p.add_argument("--scenes", nargs="+", default=[n for n, _ in pb.DEFAULT_SCENES])
    p.add_argument("--bounces", nargs="+", type=int, default=[0, 1])
    p.add_argument("--width", type=int, default=160)
    p.add_argument("--height", type=int, default=120)
    p.add_argument("--batches", type=int, default=4)
    p.add_argument("--batch-spp", type=int, default=256)
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--work", default=os.path.join(pb.REPO, "bench", "peer", "work_same_physics"))
    p.add_argument("--results", default="same_physics")
    a = p.parse_args(argv)
    a.blender = pb.find_exe(a.blender, "blender")
    if not a.blender:
        pb.log("same_physics: Blender not found (apt-get install blender python3-numpy)")
        return 2
    os.makedirs(a.work, exist_ok=True)
    known = dict(pb.DEFAULT_SCENES)
    rows = []
    try:
        _, version = pb.run([a.blender, "--version"], "blender --version")
        version = version.split()[1] if version.split() else None
        for name in a.scenes:
            scene = os.path.join(pb.REPO, known[name]) if name in known else os.path.abspath(name)
            for bounces in a.bounces:
                r = check(a, os.path.splitext(os.path.basename(name))[0], scene, bounces, a.work)
                rows.append(r)
                print("%-18s %d bounce(s): means %.5f / %.5f (%+.2f%%), tiles within 3 se "
                      "%d/%d, worst z %+.2f (%+.2f%%)  %s" % (
                          r["scene"], bounces, r["mean_dofcache"], r["mean_cycles"],
                          100 * r["mean_rel_diff"], r["tiles_ok"], r["tiles"],
                          r["worst_tile_z"], 100 * r["worst_tile_rel_diff"],
                          "ok" if r["ok"] else "FAILED"), flush=True)
    except pb.BenchError as e:
        pb.log("same_physics: %s" % e)
        return 2
    settings = {"width": a.width, "height": a.height, "batches": a.batches,
                "batch_spp": a.batch_spp, "threads": a.threads, "dofcache":
                "--mode pinhole --material-override lambert --cache none --light-samples 1 "
                "--gather-rays 1", "cycles": "--lambert, f/1e9"}
    path = pb.write_results(a.results, {"settings": settings, "columns": [
        "scene", "bounces", "mean_dofcache", "mean_cycles", "mean_rel_diff", "mean_ok",
        "tiles_ok", "tiles", "worst_tile_z", "worst_tile_rel_diff", "ok"], "rows": rows},
        version)
    print("wrote %s" % path)
    return 0 if all(r["ok"] for r in rows) else 1


if __name__ == "__main__":
    sys.exit(main())
