#!/usr/bin/env python3
"""The render with and without denoising, at equal error against a converged reference.

For each shipped scene at the peer benchmark's wide aperture (peer_bench.WIDE_FSTOP), one bounce,
320x240 and 2 threads: ladders of `render` with its defaults (the vdb cache, adaptive sampling)
at 1, 2, 4, ... spp, `--denoise off` (raw) and `--denoise on` (the EXR's denoised.RGB layer),
each compared with the converged reference REFS/ref_<scene>_f<fstop>_b1_<width>.exr (uncached
DRT, 1024 spp; --make-refs renders missing ones, a few minutes each):

  * relMSE (dofcache compare) and SSIM over the image;
  * relMSE over the edge band: pixels within 3 px of a depth discontinuity of the reference or of
    a strong luminance edge of it (a bokeh disc's rim, a shadow's edge);
  * the time each ladder needs to reach Cycles' relMSE at 16, 64 and 128 spp, as recorded by the
    peer benchmark (bench/results/peer_cycles_320_<scene>.json; Cycles against its own converged
    reference, raw: Debian's Blender has no denoiser), log-log interpolated along the ladder
    (peer_bench.time_to_error); the denoised ladder's time includes the filter;
  * at each denoised point, the raw ladder's edge-band relMSE at the same time (interpolated);
  * fireflies: pixels whose luminance exceeds 4x the 3x3 median of the reference's luminance
    plus 0.05, and the image's mean luminance over the reference's (energy kept).

Writes bench/results/NAME.json and .csv (machine description + rows).

    python3 bench/denoise_render.py --dofcache build/dofcache --refs DIR [--make-refs]
"""

import argparse
import json
import math
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)
sys.path.insert(0, os.path.join(HERE, "peer"))
sys.path.insert(0, HERE)
import peer_bench as pb  # noqa: E402
from denoise_quicklook import dump, edge_band, rel_mse, render_reference, run  # noqa: E402

# name, file, the peer benchmark's results name (None: no Cycles targets), f-number.
SCENES = [("cornell_box", "cornell_box.gltf", "cornell", pb.WIDE_FSTOP["cornell_box"]),
          ("color_bars", "color_bars.gltf", "bars", pb.WIDE_FSTOP["color_bars"]),
          ("color_spheres", "color_spheres.gltf", "spheres", pb.WIDE_FSTOP["color_spheres"]),
          ("glossy_closeup", "glossy_closeup.glb", "glossy", pb.WIDE_FSTOP["glossy_closeup"]),
          ("hanging_light_box", "hanging_light_box.gltf", "hanging",
           pb.WIDE_FSTOP["hanging_light_box"]),
          # A small bright lamp beside a wall over a glossy floor: the firefly count's scene.
          ("lamp_corner", "lamp_corner.gltf", None, 1.0)]


def luminance_band(rgb, width, height, step=0.3, floor=0.05, radius=3):
    """Pixels within `radius` of a 4-neighbour luminance step above `step` of the brighter."""
    lum = {p: 0.2126 * v[0] + 0.7152 * v[1] + 0.0722 * v[2] for p, v in rgb.items()}
    band = set()
    for y in range(height):
        for x in range(width):
            a = lum[(x, y)]
            for dx, dy in ((1, 0), (0, 1)):
                if x + dx >= width or y + dy >= height:
                    continue
                b = lum[(x + dx, y + dy)]
                hi = max(a, b)
                if hi < floor or abs(a - b) <= step * hi:
                    continue
                for cx, cy in ((x, y), (x + dx, y + dy)):
                    for by in range(max(0, cy - radius), min(height, cy + radius + 1)):
                        for bx in range(max(0, cx - radius), min(width, cx + radius + 1)):
                            band.add((bx, by))
    return band


def luminance_of(rgb):
    return {p: 0.2126 * v[0] + 0.7152 * v[1] + 0.0722 * v[2] for p, v in rgb.items()}


def firefly_limits(ref_rgb, width, height):
    """Per pixel, 4x the 3x3 median of the reference's luminance plus 0.05 (issue 37's rule)."""
    lum = luminance_of(ref_rgb)
    limits = {}
    for y in range(height):
        for x in range(width):
            window = sorted(lum[(qx, qy)] for qy in range(max(0, y - 1), min(height, y + 2))
                            for qx in range(max(0, x - 1), min(width, x + 2)))
            limits[(x, y)] = 4.0 * window[len(window) // 2] + 0.05
    return limits


def fireflies(rgb, limits):
    return sum(1 for p, l in luminance_of(rgb).items() if l > limits[p])


def mean_luminance(rgb):
    lum = luminance_of(rgb)
    return sum(lum.values()) / len(lum)


def interpolate_loglog(points, x_key, y_key, x):
    """y at x along points sorted by x, log-log; None outside their range."""
    pts = sorted((p[x_key], p[y_key]) for p in points if p[x_key] > 0 and p[y_key] > 0)
    for (x0, y0), (x1, y1) in zip(pts, pts[1:]):
        if x0 <= x <= x1:
            if x1 == x0:
                return y0
            f = (math.log(x) - math.log(x0)) / (math.log(x1) - math.log(x0))
            return math.exp(math.log(y0) + f * (math.log(y1) - math.log(y0)))
    return None


def cycles_targets(short):
    if short is None:
        return {}, None
    path = os.path.join(REPO, "bench", "results", "peer_cycles_320_%s.json" % short)
    with open(path) as f:
        rows = json.load(f)["results"]["rows"]
    return {r["target"]: r["target_rel_mse"] for r in rows}, os.path.relpath(path, REPO)


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--dofcache", default=os.path.join(REPO, "build", "dofcache"))
    p.add_argument("--refs", required=True)
    p.add_argument("--make-refs", action="store_true")
    p.add_argument("--ref-spp", type=int, default=1024)
    p.add_argument("--width", type=int, default=320)
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--ladder", type=int, nargs="+", default=[1, 2, 4, 8, 16, 32, 64])
    p.add_argument("--scenes", nargs="+", default=None)
    p.add_argument("--work", default="/tmp/dofcache-denoise-render")
    p.add_argument("--results", default="denoise_render")
    a = p.parse_args()
    os.makedirs(a.work, exist_ok=True)
    rows, ladders = [], {}
    for name, file, short, fstop in SCENES:
        if a.scenes and name not in a.scenes:
            continue
        scene = os.path.join(REPO, "scenes", file)
        lens = ["--fstop", repr(fstop), "--bounces", "1", "--width", str(a.width),
                "--threads", str(a.threads)]
        ref = os.path.join(a.refs, "ref_%s_f%s_b1_%d.exr" % (name, fstop, a.width))
        if not os.path.isfile(ref):
            if not a.make_refs:
                raise SystemExit("no reference %s (--make-refs renders it)" % ref)
            render_reference(a.dofcache, scene, ref, a.ref_spp, lens)
        ref_rgb, ref_z = dump(ref, "R,G,B"), dump(ref, "Z")
        height = 1 + max(y for _, y in ref_z)
        band = edge_band(ref_z, a.width, height) | luminance_band(ref_rgb, a.width, height)
        limits = firefly_limits(ref_rgb, a.width, height)
        ref_mean = mean_luminance(ref_rgb)
        targets, source = cycles_targets(short)
        points = {"raw": [], "denoised": []}
        for spp in a.ladder:
            for mode in ("off", "on"):
                out = os.path.join(a.work, "%s_%d_%s.exr" % (name, spp, mode))
                stats = out + ".json"
                run([a.dofcache, "render", scene, "--spp", str(spp), "--denoise", mode, "-q",
                     "-o", out, "--stats-json", stats] + lens)
                with open(stats) as f:
                    st = json.load(f)
                test = out
                seconds = st["seconds"]
                if mode == "on":
                    test = out + ".denoised.exr"
                    run(["oiiotool", out, "--ch", "denoised.R,denoised.G,denoised.B",
                         "--chnames", "R,G,B", "-o", test])
                    seconds += st["denoise"]["seconds"]
                _, cmp = run([a.dofcache, "compare", test, ref, "--json"])
                m = json.loads(cmp[cmp.index("{"):])
                rgb = dump(test, "R,G,B")
                pt = {"spp": spp, "seconds": seconds, "rel_mse": m["rel_mse"],
                      "ssim": m.get("ssim"), "edge_rel_mse": rel_mse(rgb, ref_rgb, band),
                      "fireflies": fireflies(rgb, limits),
                      "mean_ratio": mean_luminance(rgb) / ref_mean}
                if mode == "on":
                    pt["denoise_seconds"] = st["denoise"]["seconds"]
                points["raw" if mode == "off" else "denoised"].append(pt)
                print("%-18s %3d spp %-8s %6.2f s  relMSE %.5f  SSIM %.4f  edge %.5f  "
                      "fireflies %d  mean x%.4f" % (
                          name, spp, "raw" if mode == "off" else "denoised", seconds,
                          pt["rel_mse"], pt["ssim"] or 0, pt["edge_rel_mse"], pt["fireflies"],
                          pt["mean_ratio"]), flush=True)
        for pt in points["denoised"]:
            pt["raw_edge_rel_mse_at_equal_time"] = interpolate_loglog(
                points["raw"], "seconds", "edge_rel_mse", pt["seconds"])
        ladders[name] = points
        for target, err in sorted(targets.items(), key=lambda kv: -kv[1]):
            t_raw, x_raw = pb.time_to_error(points["raw"], err)
            t_dn, x_dn = pb.time_to_error(points["denoised"], err)
            row = {"scene": name, "fstop": fstop, "width": a.width, "height": height,
                   "target": target, "target_rel_mse": err, "raw_s": t_raw, "denoised_s": t_dn,
                   "speedup": t_raw / t_dn if t_raw and t_dn else None,
                   "extrapolated": ",".join(k for k, x in (("raw", x_raw), ("denoised", x_dn))
                                            if x) or None,
                   "edge_band_fraction": len(band) / float(a.width * height),
                   "targets_from": source}
            rows.append(row)
            print("%-18s to %-14s (relMSE %.5f): raw %s s, denoised %s s, x%s%s" % (
                name, target, err, pb.fmt(t_raw), pb.fmt(t_dn), pb.fmt(row["speedup"]),
                " (extrapolated: %s)" % row["extrapolated"] if row["extrapolated"] else ""),
                flush=True)
    path = pb.write_results(a.results, {
        "description": "time to Cycles' relMSE, dofcache raw vs denoised (--denoise on), each "
                       "against the converged uncached DRT; Cycles' numbers are raw (Debian's "
                       "Blender has no denoiser)",
        "settings": {"width": a.width, "ref_spp": a.ref_spp, "threads": a.threads,
                     "ladder": a.ladder},
        "columns": list(rows[0].keys()) if rows else [], "rows": rows, "ladders": ladders},
        None)
    print("wrote %s" % path)


if __name__ == "__main__":
    main()
