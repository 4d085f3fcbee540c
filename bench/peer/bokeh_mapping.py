#!/usr/bin/env python3
"""How Cycles' aperture blades, rotation and ratio map onto dofcache's (docs/lens.md).

Renders one small lamp far behind the focus (an emissive quad 3 m away, the focus at 1 m, a black
world) through both renderers with the same blades, rotation and anamorphic ratio, and measures
each bokeh from its area moments, as tests/render/bokeh_test.cpp does: the circumradius from the
polar moment of a regular N-gon, R^2 (1 + 2 cos^2(pi / N)) / 6; the angle of a corner from the
phase of the order-N angular moment; the height over the width from the second moments. Prints
both and the rotation offset that makes Cycles' corners land where dofcache's do, which the peer
benchmark applies (peer_bench.cycles_rotation).

    /usr/bin/python3 bench/peer/bokeh_mapping.py [--blades 6] [--rotation 20] [--ratio 1]
"""

import argparse
import json
import math
import os
import sys
import tempfile

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
sys.path.insert(0, os.path.join(os.path.dirname(os.path.dirname(HERE)), "scenes"))
import peer_bench as pb  # noqa: E402
import generate_scenes as gs  # noqa: E402
sys.path.insert(0, os.path.dirname(HERE))
from denoise_quicklook import dump  # noqa: E402

try:
    import numpy as np
except ImportError:
    if sys.executable != "/usr/bin/python3" and os.path.exists("/usr/bin/python3"):
        os.execv("/usr/bin/python3", ["/usr/bin/python3"] + sys.argv)
    raise SystemExit("bokeh_mapping.py needs numpy (apt-get install python3-numpy)")

SIZE = 64


def lamp_scene(path):
    """A 1.5 cm lamp 3 m in front of a camera at the origin (looking down -z), focus 1 m, f/2."""
    g = gs.Gltf("bokeh_mapping")
    lamp = g.material("lamp", (0.8, 0.8, 0.8), emissive=(1.0, 1.0, 1.0), strength=1.0)
    target = g.material("target", (0.0, 0.0, 0.0))
    g.add("lamp", gs.quad(), lamp, (0.0, 0.0, -3.0), gs.rot_x(math.pi / 2), (0.015, 1.0, 0.015))
    g.add("target", gs.quad(), target, (0.0, 0.0, -1.0), gs.rot_x(math.pi / 2), (0.0001, 1.0, 0.0001))
    # A field of view that makes the bokeh about 28 px across on a 64 px image.
    g.add_camera(eye=(0.0, 0.0, 0.0), target=(0.0, 0.0, -1.0), yfov=0.0572, focal_length=0.05,
                 fstop=2.0, focus_object="target")
    g.doc["cameras"][0]["perspective"]["aspectRatio"] = 1.0
    g.finish()
    g.write_gltf_embedded(path)


def load(path):
    """The green channel as an array (rows top to bottom)."""
    a = np.zeros((SIZE, SIZE))
    for (x, y), v in dump(path, "R,G,B").items():
        a[y, x] = v[1]
    return a


def measure(img, blades):
    h, w = img.shape
    ys, xs = np.mgrid[0:h, 0:w]
    x, y = xs + 0.5, h - (ys + 0.5)  # y up
    total = img.sum()
    cx, cy = (img * x).sum() / total, (img * y).sum() / total
    dx, dy = x - cx, y - cy
    r2 = dx * dx + dy * dy
    polar = (img * r2).sum() / total - (1.5 ** 2 + 1.0) / 6.0  # the lamp's square, the pixel
    out = {"height_over_width": math.sqrt((img * dy * dy).sum() / (img * dx * dx).sum())}
    if blades:
        c = math.cos(math.pi / blades)
        out["circumradius_px"] = math.sqrt(polar * 6.0 / (1.0 + 2.0 * c * c))
        m = (img * r2 * np.exp(1j * blades * np.arctan2(dy, dx))).sum()
        out["corner_deg"] = math.degrees(np.angle(m)) / blades
    else:
        out["radius_px"] = math.sqrt(2.0 * polar)
    return out


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--blades", type=int, default=6)
    p.add_argument("--rotation", type=float, default=20.0, help="dofcache's rotation, degrees")
    p.add_argument("--ratio", type=float, default=1.0)
    p.add_argument("--spp", type=int, default=1024)
    a = p.parse_args()
    work = tempfile.mkdtemp(prefix="bokeh_mapping_")
    scene = os.path.join(work, "lamp.gltf")
    lamp_scene(scene)
    dof = os.path.join(pb.REPO, "build", "dofcache")
    shape = {"blades": a.blades, "rotation": a.rotation, "ratio": a.ratio}
    pb.run([dof, "render", scene, "-o", os.path.join(work, "d.exr"), "--width", str(SIZE),
            "--height", str(SIZE), "--spp", str(a.spp), "--cache", "none", "-q",
            "--aperture-blades", str(a.blades), "--aperture-rotation", repr(a.rotation),
            "--anamorphic-ratio", repr(a.ratio), "--bounces", "0"], "dofcache render")
    lens = {"focal_length": 0.05, "fstop": 2.0, "focus_distance": 1.0}
    cyc = pb.Cycles(pb.find_exe(None, "blender"), 2, SIZE, SIZE, 0, False)
    cyc.render(scene, lens, a.spp, 1, os.path.join(work, "c.exr"),
               {"aperture": pb.cycles_aperture(shape)})
    d, c = measure(load(os.path.join(work, "d.exr")), a.blades), \
        measure(load(os.path.join(work, "c.exr")), a.blades)
    print(json.dumps({"shape": shape, "cycles_settings": pb.cycles_aperture(shape),
                      "dofcache": d, "cycles": c}, indent=2))
    if a.blades:
        off = (c["corner_deg"] - d["corner_deg"] + 180.0 / a.blades) % (360.0 / a.blades) \
            - 180.0 / a.blades
        print("Cycles' corners lie %.2f deg from dofcache's (0: the mapping holds)" % off)


if __name__ == "__main__":
    try:
        main()
    except pb.BenchError as e:
        sys.stderr.write("bokeh_mapping: error: %s\n" % e)
        sys.exit(1)
