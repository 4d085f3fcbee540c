#!/usr/bin/env python3
"""Sequence peer benchmark: a whole camera path, dofcache against Blender Cycles at equal error.

A user renders a camera path as an animation. Here both renderers render every frame of the
path (the gallery walk and its rack focus by default), each as a user would:

  * Cycles (bench/peer/cycles_render.py --frames-json) in one Blender process, camera and focus
    distance keyed on every frame from the path, persistent data on; a ladder of sample counts in
    each of its configurations (peer_bench.CYCLES_CONFIGS: every pixel alike, and Blender's
    defaults with adaptive sampling and the light threshold);
  * dofcache `sequence --persistent`, the radiance cache carried from frame to frame, over a
    ladder of sample counts.

The cameras come from dofcache itself (`sequence --stats-json` gives each frame's camera and
lens), so both render the same views. A reference set of frames (every --reference-every-th,
plus the next frame of every other one, so that frame-to-frame changes can be measured) is
rendered converged by each renderer (cached under --cache-dir). For every ladder point:

  * the summed in-render time (Cycles: each frame's render, from its render handlers; dofcache:
    each frame's render and cache upkeep) and the whole process's wall time;
  * the mean per-frame relMSE over the reference frames against the renderer's own reference
    (`dofcache compare`, as the single-frame benchmark);
  * the temporal error of the clean-frames benchmark (bench/temporal_stability.py) over the
    reference pairs: mean of ((x[t+1] - x[t]) - (r[t+1] - r[t]))^2 / (((r[t] + r[t+1]) / 2)^2
    + 0.01), and the per-frame error with the same normalisation beside it.

The time each renderer needs to reach Cycles' per-frame error at its ladder points is
interpolated in log-log (peer_bench.time_to_error); ratios are dofcache / Cycles (best
configuration at each error). Ladder points are timed again in --repeat interleaved passes.
Writes bench/results/<results>.{json,csv} with the machine description.

    python3 bench/peer/peer_sequence.py                    # 640x360, the whole gallery walk
    python3 bench/peer/peer_sequence.py --quick            # 160x90, frames 0-7: a smoke test
    python3 bench/peer/peer_sequence.py --width 1280 --height 720
"""

import argparse
import json
import os
import re
import shutil
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
sys.path.insert(0, HERE)
import peer_bench as pb  # noqa: E402

REPO = pb.REPO

FULL = {"size": (640, 360), "frames": None, "cycles_ladder": [4, 16, 64], "targets": [16, 64],
        "reference_spp": 512, "dofcache_start": 1, "spp_cap": 256, "max_ratio": 2.0,
        "repeat": 1}
QUICK = {"size": (160, 90), "frames": (0, 7), "cycles_ladder": [2, 8], "targets": [2, 8],
         "reference_spp": 64, "dofcache_start": 1, "spp_cap": 32, "max_ratio": 4.0,
         "repeat": 1}
# The reference frames' shading budget in dofcache (uncached; a sequence samples every pixel
# alike): the one that converges fastest in the denoising benchmarks.
DOFCACHE_REFERENCE = ["--cache", "none", "--gather-rays", "4", "--light-samples", "2"]


def reference_frames(first, last, every):
    """The frames measured: every `every`-th from `first`, and after every other one of those its
    next frame too (the pairs the temporal error is measured on). Returns (frames, pairs)."""
    base = list(range(first, last + 1, every))
    pairs = [(f, f + 1) for i, f in enumerate(base) if i % 2 == 0 and f + 1 <= last]
    frames = sorted(set(base) | {b for _, b in pairs})
    return frames, pairs


def oiio_mean(args, what):
    """The mean over pixels and channels of the image oiiotool computes from `args` (scaled by 1e6
    before --printstats, whose six decimals would round small errors away)."""
    _, out = pb.run(["oiiotool"] + args + ["--mulc", "1e6", "--printstats"], what)
    m = re.search(r"Stats Avg:\s*([^\(\n]+)", out)
    if not m:
        raise pb.BenchError("%s: no statistics in oiiotool's output" % what)
    vals = [float(v) for v in m.group(1).split()]
    return sum(vals) / len(vals) / 1e6


def rgb(path):
    return [path, "--ch", "R,G,B"]


def per_frame_error(x, r):
    """mean (x - r)^2 / (r^2 + 0.01), bench/temporal_stability.py's per-frame error."""
    return oiio_mean(rgb(x) + rgb(r) + ["--sub", "--dup", "--mul"] + rgb(r) +
                     ["--dup", "--mul", "--addc", "0.01", "--div"], "oiiotool (per-frame error)")


def temporal_error(x0, x1, r0, r1):
    """mean ((x1 - x0) - (r1 - r0))^2 / (((r0 + r1) / 2)^2 + 0.01) over one pair of frames."""
    return oiio_mean(rgb(x1) + rgb(x0) + ["--sub"] + rgb(r1) + rgb(r0) +
                     ["--sub", "--sub", "--dup", "--mul"] + rgb(r0) + rgb(r1) +
                     ["--add", "--mulc", "0.5", "--dup", "--mul", "--addc", "0.01", "--div"],
                     "oiiotool (temporal error)")


class SequenceBench:
    def __init__(self, a, plan, dof_path, blender, width, height):
        self.a, self.plan = a, plan
        self.dof, self.blender = dof_path, blender
        self.width, self.height = width, height
        self.work = os.path.join(a.out_dir, "sequence_%dx%d" % (width, height))
        os.makedirs(self.work, exist_ok=True)
        self.cache_dir = a.cache_dir or os.path.join(a.out_dir, "references")
        os.makedirs(self.cache_dir, exist_ok=True)

    # -- the frames' cameras, as dofcache resolves them
    def lens_args(self):
        args = []
        if self.a.fstop:
            args += ["--fstop", repr(self.a.fstop)]
        return args

    def common(self, spp, seed, out, stats):
        return [self.dof, "sequence", self.a.scene, "--path", self.a.path,
                "--frames", "%d-%d" % (self.first, self.last), "--width", str(self.width),
                "--height", str(self.height), "--spp", str(spp), "--seed", str(seed),
                "--threads", str(self.a.threads), "--bounces", str(self.a.bounces),
                "-o", out, "--stats-json", stats, "-q", "--restart"] + self.lens_args()

    def cameras(self):
        """Every frame's camera and lens (a 1-spp render at 16x9: the cameras do not depend on
        the image size; the focus is keyed by the path)."""
        out = os.path.join(self.work, "cameras", "####.exr")
        stats = os.path.join(self.work, "cameras.json")
        first, last = self.a.frames if self.a.frames else (0, 10 ** 6)
        cmd = [self.dof, "sequence", self.a.scene, "--path", self.a.path, "--width", "16",
               "--height", "9", "--spp", "1", "--cache", "none", "-o", out, "--stats-json", stats,
               "-q", "--restart", "--threads", str(self.a.threads)] + self.lens_args()
        if self.a.frames:
            cmd += ["--frames", "%d-%d" % (first, last)]
        pb.run(cmd, "dofcache sequence (the cameras)")
        with open(stats) as f:
            doc = json.load(f)
        rows = sorted(doc["per_frame"], key=lambda r: r["frame"])
        self.first, self.last = rows[0]["frame"], rows[-1]["frame"]
        self.camera_rows = rows
        self.cameras_json = stats
        return rows

    def subset_json(self, frames, name):
        path = os.path.join(self.work, name)
        rows = [r for r in self.camera_rows if r["frame"] in set(frames)]
        pb.write_atomically(path, json.dumps({"per_frame": rows}) + "\n")
        return path

    # -- references (cached by everything that makes them)
    def key(self, renderer, extra):
        return pb.key_of({"renderer": renderer, "scene": pb.sha256_file(self.a.scene),
                          "path": pb.sha256_file(self.a.path), "cameras": self.camera_rows,
                          "size": [self.width, self.height], "bounces": self.a.bounces,
                          "spp": self.plan["reference_spp"], **extra})

    def references(self, frames):
        spp = self.plan["reference_spp"]
        refs = {}
        # Cycles: every pixel alike, every light sampled, another seed.
        ckey = self.key("cycles", {"blender": self.cycles_version,
                                   "script": pb.sha256_file(pb.CYCLES_SCRIPT)})
        cdir = os.path.join(self.cache_dir, "sequence_cycles_" + ckey)
        if not all(os.path.isfile(pb.frame_path(os.path.join(cdir, "####.exr"), f)) for f in frames):
            pb.log("  Cycles references: %d frames at %d spp ..." % (len(frames), spp))
            tmp = cdir + ".tmp"
            shutil.rmtree(tmp, ignore_errors=True)
            self.cycles(spp, 7919 + self.a.seed, os.path.join(tmp, "####.exr"),
                        self.subset_json(frames, "reference_cameras.json"), {})
            shutil.rmtree(cdir, ignore_errors=True)
            os.replace(tmp, cdir)
        refs["cycles"] = os.path.join(cdir, "####.exr")
        # dofcache: uncached, every pixel alike, another seed. Frame by frame (they are independent
        # without a cache), so only the reference frames are rendered.
        dkey = self.key("dofcache", {"binary": pb.sha256_file(self.dof),
                                     "config": DOFCACHE_REFERENCE})
        ddir = os.path.join(self.cache_dir, "sequence_dofcache_" + dkey)
        if not all(os.path.isfile(pb.frame_path(os.path.join(ddir, "####.exr"), f)) for f in frames):
            pb.log("  dofcache references: %d frames at %d spp ..." % (len(frames), spp))
            tmp = ddir + ".tmp"
            shutil.rmtree(tmp, ignore_errors=True)
            for f in frames:
                cmd = self.common(spp, 7919 + self.a.seed, os.path.join(tmp, "####.exr"),
                                  os.path.join(tmp, "stats.json"))
                cmd[cmd.index("--frames") + 1] = "%d-%d" % (f, f)
                pb.run(cmd + DOFCACHE_REFERENCE, "dofcache reference frame %d" % f)
            shutil.rmtree(ddir, ignore_errors=True)
            os.replace(tmp, ddir)
        refs["dofcache"] = os.path.join(ddir, "####.exr")
        return refs

    # -- the renderers over the whole path
    def cycles(self, spp, seed, out, frames_json, config):
        j = os.path.join(os.path.dirname(out), "cycles.json")
        os.makedirs(os.path.dirname(out), exist_ok=True)
        cmd = [self.blender, "-b", "--factory-startup", "--python", pb.CYCLES_SCRIPT, "--",
               self.a.scene, "--out", out, "--json-out", j, "--frames-json", frames_json,
               "--spp", str(spp), "--seed", str(seed), "--width", str(self.width),
               "--height", str(self.height), "--bounces", str(self.a.bounces),
               "--threads", str(self.a.threads)] + pb.cycles_config_args(config)
        wall, _ = pb.run(cmd, "Cycles animation (%d spp)" % spp)
        with open(j) as f:
            st = json.load(f)
        return {"seconds": float(st["render_seconds_sum"]), "process_seconds": wall,
                "animation_seconds": float(st["render_seconds"])}

    def dofcache(self, spp, out):
        stats = os.path.join(os.path.dirname(out), "stats.json")
        wall, _ = pb.run(self.common(spp, self.a.seed, out, stats) + ["--persistent"],
                         "dofcache sequence --persistent (%d spp)" % spp)
        with open(stats) as f:
            st = json.load(f)
        rows = [r for r in st["per_frame"] if not r.get("skipped")]
        return {"seconds": sum(r["render_seconds"] + r["cache_seconds"] for r in rows),
                "process_seconds": wall,
                "frame_seconds": sum(r["seconds"] for r in rows)}

    def measure(self, pattern, ref_pattern, frames, pairs):
        e = {}
        rel = []
        for f in frames:
            _, out = pb.run([self.dof, "compare", pb.frame_path(pattern, f),
                             pb.frame_path(ref_pattern, f), "--json"], "dofcache compare")
            rel.append(float(json.loads(out[out.index("{"):])["rel_mse"]))
        e["rel_mse"] = sum(rel) / len(rel)
        e["rel_mse_frames"] = rel
        if pairs:
            e["per_frame_error"] = sum(per_frame_error(pb.frame_path(pattern, f),
                                                       pb.frame_path(ref_pattern, f))
                                       for f in frames) / len(frames)
            e["temporal_error"] = sum(
                temporal_error(pb.frame_path(pattern, a), pb.frame_path(pattern, b),
                               pb.frame_path(ref_pattern, a), pb.frame_path(ref_pattern, b))
                for a, b in pairs) / len(pairs)
        return e

    def run(self):
        a, plan = self.a, self.plan
        rows = self.cameras()
        n = len(rows)
        pb.log("sequence benchmark: %s along %s, frames %d-%d (%d), %dx%d" % (
            os.path.relpath(a.scene, REPO), os.path.relpath(a.path, REPO), self.first, self.last,
            n, self.width, self.height))
        frames, pairs = reference_frames(self.first, self.last, a.reference_every)
        refs = self.references(frames)

        cyc_ladders = {}
        for name, cfg in pb.CYCLES_CONFIGS:
            pts = []
            for spp in plan["cycles_ladder"]:
                out = os.path.join(self.work, "cycles_%s_%d" % (name, spp), "####.exr")
                r = self.cycles(spp, a.seed, out, self.cameras_json, cfg)
                p = dict(r, spp=spp, renderer="cycles", config=cfg, out=out,
                         **self.measure(out, refs["cycles"], frames, pairs))
                pb.log("    Cycles %-9s %4d spp: per-frame relMSE %.5g  %.1f s (%.2f s a frame; "
                       "process %.1f s)" % (name, spp, p["rel_mse"], p["seconds"],
                                            p["seconds"] / n, p["process_seconds"]))
                pts.append(p)
            cyc_ladders[name] = {"config": cfg, "points": pts}
        targets = [{"label": "Cycles %d spp" % spp, "spp": spp,
                    "rel_mse": next(p["rel_mse"] for p in cyc_ladders["fixed"]["points"]
                                    if p["spp"] == spp)} for spp in plan["targets"]]
        min_target = min(t["rel_mse"] for t in targets)
        slowest = max(p["seconds"] for L in cyc_ladders.values() for p in L["points"])

        dof_pts, spp = [], plan["dofcache_start"]
        while True:
            out = os.path.join(self.work, "dofcache_%d" % spp, "####.exr")
            r = self.dofcache(spp, out)
            p = dict(r, spp=spp, renderer="dofcache", config={"persistent": True}, out=out,
                     **self.measure(out, refs["dofcache"], frames, pairs))
            pb.log("    dofcache persistent %4d spp: per-frame relMSE %.5g  %.1f s (%.2f s a "
                   "frame; process %.1f s)" % (spp, p["rel_mse"], p["seconds"], p["seconds"] / n,
                                               p["process_seconds"]))
            dof_pts.append(p)
            if len(dof_pts) >= 2 and p["rel_mse"] <= min_target / 1.1:
                break
            if p["seconds"] > plan["max_ratio"] * slowest or spp * 2 > plan["spp_cap"]:
                break
            spp *= 2

        if a.repeat > 0:
            queues = [[p for L in cyc_ladders.values() for p in L["points"]], dof_pts]
            pb.log("  timing: %d interleaved pass(es) over %d Cycles and %d dofcache paths ..." % (
                a.repeat, len(queues[0]), len(queues[1])))
            scratch = os.path.join(self.work, "timing", "####.exr")

            def again(p):
                shutil.rmtree(os.path.dirname(scratch), ignore_errors=True)
                if p["renderer"] == "cycles":
                    return self.cycles(p["spp"], a.seed, scratch, self.cameras_json, p["config"])
                return self.dofcache(p["spp"], scratch)
            pb.timing_passes(queues, a.repeat, again)

        out_rows = []
        for t in targets:
            row = {"scene": os.path.basename(a.scene), "path": os.path.basename(a.path),
                   "width": self.width, "height": self.height, "frames": n,
                   "reference_frames": len(frames), "target": t["label"],
                   "target_rel_mse": t["rel_mse"]}
            extrap = []
            for key, col in (("seconds", ""), ("process_seconds", "_process")):
                best, label = None, None
                for name, L in cyc_ladders.items():
                    v, x = pb.time_to_error(L["points"], t["rel_mse"], key)
                    row["cycles_%s%s_s" % (name, col)] = v
                    if x:
                        extrap.append("cycles_" + name)
                    if v is not None and (best is None or v < best):
                        best, label = v, name
                row["cycles%s_s" % col], row["cycles_best_config%s" % col] = best, label
                d, x = pb.time_to_error(dof_pts, t["rel_mse"], key)
                if x:
                    extrap.append("dofcache")
                row["dofcache%s_s" % col] = d
                row["ratio%s" % col] = d / best if d and best else None
                if key == "seconds":
                    row["cycles_s_per_frame"] = best / n if best else None
                    row["dofcache_s_per_frame"] = d / n if d else None
            # The temporal error at the target (interpolated along each ladder as time is).
            fixed = cyc_ladders["fixed"]["points"]
            if "temporal_error" in fixed[0]:
                for who, pts in (("cycles_fixed", fixed),
                                 ("cycles_defaults", cyc_ladders["defaults"]["points"]),
                                 ("dofcache", dof_pts)):
                    row["%s_temporal_error" % who] = pb.time_to_error(
                        pts, t["rel_mse"], "temporal_error")[0]
                    row["%s_per_frame_error" % who] = pb.time_to_error(
                        pts, t["rel_mse"], "per_frame_error")[0]
            row["extrapolated"] = " ".join(sorted(set(extrap))) or None
            out_rows.append(row)
        return {"rows": out_rows, "detail": {
            "frames": [self.first, self.last], "reference_frames": frames, "pairs": pairs,
            "references": refs, "cycles": cyc_ladders, "dofcache": dof_pts,
            "dofcache_reference_config": DOFCACHE_REFERENCE}}


def print_table(rows):
    head = ["target", "relMSE", "Cycles s/frame", "which", "dof s/frame", "dof/C", "dof/C process",
            "temporal C", "temporal dof", "extrapolated"]
    body = [[r["target"], pb.fmt(r["target_rel_mse"]), pb.fmt(r["cycles_s_per_frame"]),
             pb.fmt(r["cycles_best_config"]), pb.fmt(r["dofcache_s_per_frame"]),
             pb.fmt(r["ratio"]), pb.fmt(r["ratio_process"]),
             pb.fmt(r.get("cycles_%s_temporal_error" % r["cycles_best_config"])),
             pb.fmt(r.get("dofcache_temporal_error")), pb.fmt(r["extrapolated"])] for r in rows]
    widths = [max(len(x[i]) for x in [head] + body) for i in range(len(head))]
    for cells in [head] + body:
        print("  ".join(c.rjust(w) if i else c.ljust(w)
                        for i, (c, w) in enumerate(zip(cells, widths))))


def main(argv=None):
    p = argparse.ArgumentParser(prog="peer_sequence.py",
                                description="A camera path, dofcache against Blender Cycles at "
                                            "equal per-frame error (bench/README.md).")
    p.add_argument("--scene", default=os.path.join(REPO, "scenes", "gallery.glb"))
    p.add_argument("--path", default=os.path.join(REPO, "scenes", "paths", "gallery_walk.json"),
                   help="keyframe file (default: the gallery walk, with its rack focus)")
    p.add_argument("--frames", default=None, help="A-B (default: the whole path; 0-7 with --quick)")
    p.add_argument("--width", type=int, default=None, help="default 640 (160 with --quick)")
    p.add_argument("--height", type=int, default=None, help="default 360 (90 with --quick)")
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--bounces", type=int, default=1)
    p.add_argument("--fstop", type=float, default=None, help="default: the scene's")
    p.add_argument("--reference-every", type=int, default=4,
                   help="measure every Nth frame (and pairs for the temporal error; default 4)")
    p.add_argument("--reference-spp", type=int, default=None,
                   help="samples of the converged frames (default 512; 64 with --quick)")
    p.add_argument("--cycles-ladder", type=int, nargs="+", default=None,
                   help="Cycles' samples per pixel along its ladder (default 4 16 64)")
    p.add_argument("--targets", type=int, nargs="+", default=None,
                   help="the Cycles ladder points whose per-frame error is matched (default 16 64)")
    p.add_argument("--repeat", type=int, default=None,
                   help="interleaved timing passes over the whole paths (default 1; 0: none)")
    p.add_argument("--quick", action="store_true", help="160x90, frames 0-7 (a smoke test)")
    p.add_argument("--blender", default=None)
    p.add_argument("--dofcache", default=None)
    p.add_argument("--out-dir", default=None, help="default $TMPDIR/dofcache_peer")
    p.add_argument("--cache-dir", default=None, help="references (default OUT_DIR/references)")
    p.add_argument("--results", default=None,
                   help="results name (default peer_sequence; peer_sequence_quick with --quick)")
    a = p.parse_args(argv)

    plan = dict(QUICK if a.quick else FULL)
    width = a.width or plan["size"][0]
    height = a.height or plan["size"][1]
    if a.reference_spp:
        plan["reference_spp"] = a.reference_spp
    if a.cycles_ladder:
        plan["cycles_ladder"] = sorted(set(a.cycles_ladder))
    if a.targets:
        plan["targets"] = sorted(set(a.targets))
    if not set(plan["targets"]) <= set(plan["cycles_ladder"]) or min(plan["cycles_ladder"]) < 1:
        p.error("--targets must be points of --cycles-ladder (positive sample counts)")
    a.repeat = plan["repeat"] if a.repeat is None else a.repeat
    if a.frames:
        m = re.fullmatch(r"(\d+)-(\d+)", a.frames)
        if not m or int(m.group(1)) > int(m.group(2)):
            p.error("--frames takes A-B with A <= B")
        a.frames = (int(m.group(1)), int(m.group(2)))
    else:
        a.frames = plan["frames"]
    for name, v in (("--width", width), ("--height", height), ("--threads", a.threads),
                    ("--reference-every", a.reference_every), ("--reference-spp",
                                                               plan["reference_spp"])):
        if v < 1:
            p.error("%s must be at least 1" % name)
    if a.repeat < 0 or a.bounces < 0 or (a.fstop is not None and a.fstop <= 0):
        p.error("--repeat and --bounces must be >= 0, --fstop > 0")
    results = a.results or ("peer_sequence_quick" if a.quick else "peer_sequence")
    if not re.fullmatch(r"[A-Za-z0-9_][A-Za-z0-9_.-]*", results):
        p.error("the results name may hold only letters, digits, '_', '.', '-'")
    for f in (a.scene, a.path):
        if not os.path.isfile(f):
            raise pb.BenchError("not found: %s" % f)
    a.scene, a.path = os.path.abspath(a.scene), os.path.abspath(a.path)

    blender = pb.find_exe(a.blender, "blender")
    if not blender:
        raise pb.BenchError("blender not found (apt-get install blender python3-numpy)")
    dof = pb.find_exe(a.dofcache or os.path.join(REPO, "build", "dofcache"), "dofcache")
    if not dof:
        raise pb.BenchError("dofcache not found (build it, or pass --dofcache PATH)")
    if not shutil.which("oiiotool", path=pb.CHILD_ENV.get("PATH")):
        raise pb.BenchError("oiiotool not found (apt-get install openimageio-tools)")
    a.out_dir = os.path.abspath(a.out_dir or os.path.join(tempfile.gettempdir(), "dofcache_peer"))
    os.makedirs(a.out_dir, exist_ok=True)
    copy = os.path.join(a.out_dir, "dofcache_sequence.bin")  # the build may change meanwhile
    shutil.copy2(dof, copy + ".tmp")
    os.replace(copy + ".tmp", copy)

    cyc = pb.Cycles(blender, a.threads, width, height, a.bounces, False)
    bench = SequenceBench(a, plan, copy, blender, width, height)
    bench.cycles_version = cyc.version
    t0 = time.perf_counter()
    load_before = os.getloadavg()
    r = bench.run()
    print("\n%s along %s, %dx%d, %d frames" % (os.path.basename(a.scene), os.path.basename(a.path),
                                              width, height, r["rows"][0]["frames"]))
    print_table(r["rows"])
    doc = {
        "description": "A whole camera path rendered by each renderer as a user renders an "
                       "animation: time to equal mean per-frame relMSE (each renderer against its "
                       "own converged frames), dofcache sequence --persistent vs Blender Cycles; "
                       "ratios are dofcache / Cycles",
        "rows": r["rows"],
        "settings": {"width": width, "height": height, "threads": a.threads, "seed": a.seed,
                     "bounces": a.bounces, "fstop": a.fstop, "repeat": a.repeat,
                     "reference_every": a.reference_every, "plan": plan,
                     "scene": os.path.relpath(a.scene, REPO), "path": os.path.relpath(a.path, REPO),
                     "blender": cyc.version, "dofcache_sha256": pb.sha256_file(copy), "nice": 10,
                     "timing": "seconds: summed in-render time of the frames (Cycles: its render "
                               "handlers around each frame; dofcache: each frame's render and "
                               "cache upkeep); process_seconds: the whole process (Blender "
                               "start-up, import, every frame and its file; dofcache: scene "
                               "load, frames, files and the cache checkpoint)"},
        "run": {"wall_seconds": time.perf_counter() - t0, "load_average_before": list(load_before),
                "load_average_after": list(os.getloadavg())},
        "detail": r["detail"],
    }
    path = pb.write_results(results, doc, cyc.version)
    print("\nwrote %s (and .csv)" % path)
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except pb.BenchError as e:
        sys.stderr.write("peer_sequence: error: %s\n" % e)
        sys.exit(1)
    except KeyboardInterrupt:
        sys.stderr.write("peer_sequence: interrupted\n")
        sys.exit(130)
