#!/usr/bin/env python3
"""The preview of a lens that is not plain, against converged distributed ray tracing.

For each lens of LENSES on scenes/bokeh_lights.gltf (lamps and highlights far from the focus):
`render --mode preview` with its defaults, which draws a shaped lens with the shaped scatter,
the same with the occlusion fix (`--mode preview-occlusion`: the shaped scatter splats the
surfaces the fix reveals behind blurred foreground rims), and the same preview through the plain
round lens (what the preview drew before it knew the lens), each compared with the converged DRT
reference through that lens (REFS/shaped_<lens>.exr,
uncached, e.g. 512 spp; --make-refs renders them): relMSE and PSNR (dofcache compare). Also the
post-process's time (the fastest of three runs). Writes bench/results/NAME.json and .csv.

With --real-lens NAME (a shipped prescription, e.g. double_gauss_50mm), also the preview through
that traced lens, whose rims cut cat's eyes towards the corners (docs/lens.md), against its
uncached DRT reference; "drawn round" is then the same saved preview inputs with the rims taken
out of the file (oiiotool), which is what the preview drew before it fitted them.

    python3 bench/shaped_preview.py --dofcache build/dofcache --refs DIR [--make-refs]
        [--real-lens double_gauss_50mm] [--lenses round,blades6,...]
"""

import argparse
import json
import os
import sys

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(HERE, "peer"))
import denoise_quicklook as dq  # noqa: E402  (run, the converged reference)
import peer_bench as pb  # noqa: E402  (results files with the machine description)

SCENE = os.path.join(REPO, "scenes", "bokeh_lights.gltf")
# The scene's lens is 85 mm at f/1.4 (a 30 mm aperture radius). The stop passes the whole
# bundle on the axis and cuts a cat's eye towards the corners.
LENSES = [
    ("round", []),
    ("blades6", ["--aperture-blades", "6", "--aperture-rotation", "15"]),
    ("anamorphic", ["--anamorphic-ratio", "1.8"]),
    ("catseye", ["--vignetting-stop", "0.032,0.1"]),
    ("chromatic", ["--axial-ca", "0.08", "--lateral-ca", "0.01"]),
    ("tilt", ["--lens-tilt", "4,0"]),
]


def compare(dofcache, test, ref):
    _, out = dq.run([dofcache, "compare", test, ref, "--json"])
    m = json.loads(out[out.index("{"):])
    return m["rel_mse"], m["psnr"]


def postprocess_ms(dofcache, argv):
    """The fastest of three runs' post-process time (ms) of a preview command."""
    best = None
    for _ in range(3):
        _, out = dq.run([dofcache] + argv)
        ms = float(out.split("post-process ")[1].split(" ms")[0])
        best = ms if best is None else min(best, ms)
    return best


def real_lens_row(a, size):
    name = "real_" + a.real_lens
    flags = ["--lens-file", a.real_lens]
    ref = os.path.join(a.refs, "shaped_%s_%d.exr" % (name, a.width))
    if not os.path.isfile(ref):
        if not a.make_refs:
            raise SystemExit("no reference %s (--make-refs renders it)" % ref)
        dq.render_reference(a.dofcache, SCENE, ref, a.ref_spp, size + flags)
    inputs = os.path.join(a.work, name + "_inputs.exr")
    shaped = os.path.join(a.work, name + "_shaped.exr")
    dq.run([a.dofcache, "render", SCENE, "--mode", "preview", "-q", "-o", shaped,
            "--save-preview-inputs", inputs] + size + flags)
    plain = os.path.join(a.work, name + "_inputs_round.exr")
    dq.run(["oiiotool", inputs, "-a", "--eraseattrib", "dofcache:lens_rims.*", "-o", plain])
    round_out = os.path.join(a.work, name + "_round.exr")
    row = {"lens": name, "flags": " ".join(flags), "width": a.width}
    for label, src, out in (("shaped", inputs, shaped), ("round", plain, round_out)):
        row["postprocess_ms_" + label] = postprocess_ms(
            a.dofcache, ["refocus", src, "-o", out])
        row["rel_mse_" + label], row["psnr_" + label] = compare(a.dofcache, out, ref)
    print("%-11s relMSE %.4f (PSNR %.1f dB), without its rims %.4f (%.1f dB); post-process "
          "%.0f ms (without %.0f ms)" % (name, row["rel_mse_shaped"], row["psnr_shaped"],
                                         row["rel_mse_round"], row["psnr_round"],
                                         row["postprocess_ms_shaped"],
                                         row["postprocess_ms_round"]), flush=True)
    return row


def main():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--dofcache", default=os.path.join(REPO, "build", "dofcache"))
    p.add_argument("--refs", required=True)
    p.add_argument("--make-refs", action="store_true")
    p.add_argument("--ref-spp", type=int, default=512)
    p.add_argument("--width", type=int, default=320)
    p.add_argument("--work", default="/tmp/dofcache-shaped-preview")
    p.add_argument("--results", default="shaped_preview")
    p.add_argument("--real-lens", help="also a shipped lens prescription's preview")
    p.add_argument("--lenses", default=",".join(n for n, _ in LENSES),
                   help="which of the thin lenses to run (comma-separated; empty: none)")
    a = p.parse_args()
    os.makedirs(a.work, exist_ok=True)
    size = ["--width", str(a.width)]
    rows = []
    chosen = set(a.lenses.split(",")) if a.lenses else set()
    for name, flags in LENSES:
        if name not in chosen:
            continue
        ref = os.path.join(a.refs, "shaped_%s_%d.exr" % (name, a.width))
        if not os.path.isfile(ref):
            if not a.make_refs:
                raise SystemExit("no reference %s (--make-refs renders it)" % ref)
            dq.render_reference(a.dofcache, SCENE, ref, a.ref_spp, size + flags)
        row = {"lens": name, "flags": " ".join(flags), "width": a.width}
        for label, extra, mode in (("shaped", flags, "preview"),
                                   ("shaped_fix", flags, "preview-occlusion"),
                                   ("round", [], "preview")):
            out = os.path.join(a.work, "%s_%s.exr" % (name, label))
            stats = os.path.join(a.work, "%s_%s.json" % (name, label))
            best = None
            for _ in range(3):
                dq.run([a.dofcache, "render", SCENE, "--mode", mode, "-q", "-o", out,
                        "--stats-json", stats] + size + extra)
                with open(stats) as f:
                    ms = json.load(f)["preview"]["postprocess_ms"]
                best = ms if best is None else min(best, ms)
            row["rel_mse_" + label], row["psnr_" + label] = compare(a.dofcache, out, ref)
            row["postprocess_ms_" + label] = best
        rows.append(row)
        print("%-11s relMSE %.4f (PSNR %.1f dB), with the occlusion fix %.4f (%.1f dB), drawn "
              "round %.4f (%.1f dB); post-process %.0f ms (fix %.0f ms, round %.0f ms)"
              % (name, row["rel_mse_shaped"], row["psnr_shaped"], row["rel_mse_shaped_fix"],
                 row["psnr_shaped_fix"], row["rel_mse_round"], row["psnr_round"],
                 row["postprocess_ms_shaped"], row["postprocess_ms_shaped_fix"],
                 row["postprocess_ms_round"]), flush=True)
    if a.real_lens:
        rows.append(real_lens_row(a, size))
    path = pb.write_results(a.results, {"settings": {"width": a.width, "ref_spp": a.ref_spp,
                                                     "scene": "bokeh_lights.gltf"},
                                        "columns": list(rows[0].keys()), "rows": rows}, None)
    print("wrote %s" % path)


if __name__ == "__main__":
    main()
