#!/usr/bin/env python3
"""The quick look with and without denoising, against converged distributed ray tracing.

For each shipped scene: `render --mode preview-occlusion` with its defaults (one pinhole sample,
quick shading) at --width (320), `--denoise off` and `--denoise on`, each compared with the
converged reference REFS/ref_<scene>.exr (uncached DRT, e.g. 1024 spp; make them with --make-refs):
relMSE over the image (dofcache compare) and over the edge band, the pixels within 3 px of a depth
discontinuity of the reference (4-neighbours whose depths differ by more than 5 %). Also the
quick look's time at 640x480 with and without denoising. Writes bench/results/NAME.json and .csv.

    python3 bench/denoise_quicklook.py --dofcache build/dofcache --refs DIR [--make-refs]
"""

import argparse
import json
import os
import subprocess
import sys
import time

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)
sys.path.insert(0, os.path.join(HERE, "peer"))
import peer_bench as pb  # noqa: E402  (results files with the machine description)

SCENES = ["cornell_box.gltf", "color_bars.gltf", "color_spheres.gltf", "glossy_closeup.glb",
          "hanging_light_box.gltf"]


def run(cmd):
    t0 = time.perf_counter()
    p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if p.returncode != 0:
        raise SystemExit("failed: %s\n%s" % (" ".join(cmd), p.stderr.strip()))
    return time.perf_counter() - t0, p.stdout


def dump(path, channels):
    """{(x, y): [values]} of the named channels, through oiiotool."""
    tmp = path + ".sel.exr"
    run(["oiiotool", path, "-ch", channels, "-o", tmp])
    _, text = run(["oiiotool", "--dumpdata", tmp])
    out = {}
    for line in text.splitlines():
        line = line.strip()
        if line.startswith("Pixel ("):
            head, _, data = line.partition("):")
            x, y = (int(v) for v in head[len("Pixel ("):].split(","))
            out[(x, y)] = [float(v) for v in data.split()]
    os.remove(tmp)
    return out


def render_reference(dofcache, scene, out, spp, extra=()):
    """The converged reference both denoising benchmarks compare with: uncached DRT, uniform
    sampling, the shading budget that converges fastest (4 gather rays, 2 light samples), its own
    seed."""
    run([dofcache, "render", scene, "--spp", str(spp), "--cache", "none", "--adaptive", "off",
         "--gather-rays", "4", "--light-samples", "2", "--seed", "1000003", "-q", "-o", out] +
        list(extra))


def edge_band(depth, width, height, jump=0.05, radius=3):
    band = set()
    for y in range(height):
        for x in range(width):
            z = depth[(x, y)][0]
            for dx, dy in ((1, 0), (0, 1)):
                if x + dx >= width or y + dy >= height:
                    continue
                w = depth[(x + dx, y + dy)][0]
                finite = z < 1e30 and w < 1e30
                if finite and abs(z - w) <= jump * min(z, w):
                    continue
                if not finite and (z >= 1e30) == (w >= 1e30):
                    continue
                for cx, cy in ((x, y), (x + dx, y + dy)):
                    for by in range(max(0, cy - radius), min(height, cy + radius + 1)):
                        for bx in range(max(0, cx - radius), min(width, cx + radius + 1)):
                            band.add((bx, by))
    return band


def rel_mse(test, ref, pixels):
    s = 0.0
    for p in pixels:
        for a, b in zip(test[p], ref[p]):
            s += (a - b) ** 2 / (b * b + 1e-2)  # image::compare's form
    return s / (3 * len(pixels))


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--dofcache", default=os.path.join(REPO, "build", "dofcache"))
    p.add_argument("--refs", required=True)
    p.add_argument("--make-refs", action="store_true")
    p.add_argument("--ref-spp", type=int, default=1024)
    p.add_argument("--width", type=int, default=320)
    p.add_argument("--work", default="/tmp/dofcache-denoise-quicklook")
    p.add_argument("--results", default="denoise_quicklook")
    a = p.parse_args()
    os.makedirs(a.work, exist_ok=True)
    rows = []
    for s in SCENES:
        name = os.path.splitext(s)[0]
        scene = os.path.join(REPO, "scenes", s)
        ref = os.path.join(a.refs, "ref_%s.exr" % name)
        if not os.path.isfile(ref):
            if not a.make_refs:
                raise SystemExit("no reference %s (--make-refs renders it)" % ref)
            render_reference(a.dofcache, scene, ref, a.ref_spp, ["--width", str(a.width)])
        ref_rgb, ref_z = dump(ref, "R,G,B"), dump(ref, "Z")
        height = 1 + max(y for _, y in ref_z)
        band = edge_band(ref_z, a.width, height)
        row = {"scene": name, "width": a.width, "height": height,
               "edge_band_fraction": len(band) / float(a.width * height)}
        for mode in ("off", "on"):
            out = os.path.join(a.work, "%s_%s.exr" % (name, mode))
            run([a.dofcache, "render", scene, "--mode", "preview-occlusion", "--width",
                 str(a.width), "--denoise", mode, "-q", "-o", out])
            _, cmp = run([a.dofcache, "compare", out, ref, "--json"])
            m = json.loads(cmp[cmp.index("{"):])
            test = dump(out, "R,G,B")
            row["rel_mse_" + mode] = m["rel_mse"]
            row["ssim_" + mode] = m.get("ssim")
            row["edge_rel_mse_" + mode] = rel_mse(test, ref_rgb, band)
            stats = os.path.join(a.work, "%s_%s_640.json" % (name, mode))
            best = None
            for _ in range(3):  # the fastest of three runs at 640x480
                run([a.dofcache, "render", scene, "--mode", "preview-occlusion", "--width", "640",
                     "--denoise", mode, "-q", "-o", os.path.join(a.work, "t.png"),
                     "--stats-json", stats])
                with open(stats) as f:
                    secs = json.load(f)["seconds"]
                best = secs if best is None else min(best, secs)
            row["seconds_640_" + mode] = best
        row["rel_mse_ratio"] = row["rel_mse_on"] / row["rel_mse_off"]
        row["edge_rel_mse_ratio"] = row["edge_rel_mse_on"] / row["edge_rel_mse_off"]
        rows.append(row)
        print("%-18s relMSE %.5f -> %.5f (x%.2f)  edge band %.5f -> %.5f (x%.2f)  "
              "640x480 %.2f -> %.2f s" % (name, row["rel_mse_off"], row["rel_mse_on"],
                                          row["rel_mse_ratio"], row["edge_rel_mse_off"],
                                          row["edge_rel_mse_on"], row["edge_rel_mse_ratio"],
                                          row["seconds_640_off"], row["seconds_640_on"]),
              flush=True)
    path = pb.write_results(a.results, {"settings": {"width": a.width, "ref_spp": a.ref_spp},
                                        "columns": list(rows[0].keys()), "rows": rows}, None)
    print("wrote %s" % path)


if __name__ == "__main__":
    main()
