#!/usr/bin/env python3
"""Peer benchmark: dofcache against Blender Cycles at equal error (bench/README.md).

For each scene, with a wide aperture (the scene's f-number times --fstop-scale, 0.5 by default):

  * Cycles (bench/peer/cycles_render.py inside `blender -b`) renders a ladder of sample counts
    and its own converged reference (16x the largest ladder point, another seed);
  * dofcache renders ladders in three configurations: its defaults, the fastest uncached
    shading budget found by a small search over --gather-rays x --light-samples (one path per
    lens ray included), and the vdb radiance cache; plus its own converged reference (uncached,
    the search's most efficient budget, 16x the samples that budget needs for the smallest
    target, another seed);
  * every render's relMSE is taken against its own renderer's reference by `dofcache compare`
    (the same metric code for both renderers);
  * the time each configuration needs to reach Cycles' relMSE at given sample counts is
    interpolated in log-log along its ladder, for in-render and whole-process times.

Writes bench/results/<results>.{json,csv} (machine description + rows, written atomically) and
docs/images/peer_<scene>.png (Cycles | dofcache uncached | dofcache cached at about equal time,
error maps below). Converged references are cached under --cache-dir, keyed by scene, settings
and renderer version, so a rerun reuses them.

Python 3 standard library only; needs blender (with python3-numpy), the dofcache CLI and
oiiotool (openimageio-tools).
"""

import argparse
import datetime
import hashlib
import json
import math
import os
import platform
import re
import shutil
import socket
import statistics
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(os.path.dirname(HERE))
CYCLES_SCRIPT = os.path.join(HERE, "cycles_render.py")

# The wide aperture of each shipped scene: half its own f-number, except the hanging-light box,
# whose f/0.2 (50 mm: aperture radius 0.125 m) is already the wide aperture of issue 17. Other
# scenes: their f-number times --fstop-scale.
WIDE_FSTOP = {"cornell_box": 0.7, "color_bars": 1.0, "color_spheres": 0.9, "glossy_closeup": 2.0,
              "hanging_light_box": 0.2}

# name -> path relative to the repository. hanging_light_box is skipped (with a note) if absent.
DEFAULT_SCENES = [
    ("cornell_box", "scenes/cornell_box.gltf"),
    ("color_bars", "scenes/color_bars.gltf"),
    ("color_spheres", "scenes/color_spheres.gltf"),
    ("glossy_closeup", "scenes/glossy_closeup.glb"),
    ("hanging_light_box", "scenes/hanging_light_box.gltf"),
]
# More scenes by name: the gallery, and the atrium, generated (deterministically) on first use
# into the references' directory by scenes/generate_atrium.py.
NAMED_SCENES = dict(DEFAULT_SCENES, gallery="scenes/gallery.glb", atrium=None)

FULL = {
    "size": (320, 240),
    "cycles_ladder": [16, 32, 64, 128, 256],
    "targets": [16, 64, 256],          # targets: Cycles' relMSE at these ladder points
    "probe_spp": 8,
    "gather": [1, 2, 4, 8, 16, 32],
    "light": [1, 2, 4],
    "top_configs": 3,
    "max_ratio": 4.0,                  # ladders stop past this multiple of Cycles' slowest target
    "min_cap_seconds": 20.0,
    "spp_cap": 65536,
    "cached_start": 4,
    "reference_factor": 16,            # converged references: this many times the ladders' samples
    "repeat": 3,                       # interleaved timing passes
}
QUICK = {
    "size": (80, 60),
    "cycles_ladder": [4, 8, 16],
    "targets": [4, 16],
    "probe_spp": 2,
    "gather": [1, 4],
    "light": [1, 4],
    "top_configs": 2,
    "max_ratio": 6.0,
    "min_cap_seconds": 1.0,
    "spp_cap": 1024,
    "cached_start": 2,
    "reference_factor": 16,
    "repeat": 1,
}
# 160x120, as the measurements that opened issue 17: a whole run in well under an hour.
MEDIUM = dict(FULL, size=(160, 120), cycles_ladder=[16, 32, 64, 128], targets=[16, 64, 128],
              gather=[1, 2, 4, 8, 32], min_cap_seconds=10.0, repeat=1)
# Production size (issue 40): 1280x720 frames of the gallery and the 2.1 M-triangle atrium. Cycles
# takes about 2 s a sample there on two cores, so the ladders are shorter and the references 8x
# the ladders' samples (their noise then adds up to 1/8 to the smallest target's error).
PRODUCTION = dict(FULL, size=(1280, 720), cycles_ladder=[8, 16, 32, 64], targets=[16, 64],
                  probe_spp=2, gather=[1, 4, 16], light=[1, 4], top_configs=2, max_ratio=3.0,
                  min_cap_seconds=60.0, reference_factor=8, repeat=1,
                  scenes=["gallery", "atrium"])
COLUMNS = [
    "scene", "width", "height", "fstop", "scene_fstop", "aperture_radius_m", "target", "target_rel_mse",
    "cycles_s", "cycles_process_s", "cycles_best_config", "cycles_best_config_process",
    "cycles_fixed_s", "cycles_defaults_s", "cycles_fixed_process_s", "cycles_defaults_process_s",
    "dofcache_default_s", "dofcache_default_process_s",
    "dofcache_best_uncached_s", "dofcache_best_uncached_process_s", "dofcache_best_config",
    "dofcache_cached_s", "dofcache_cached_process_s",
    "dofcache_cached_uniform_s", "dofcache_cached_uniform_process_s",
    "ratio_default", "ratio_best_uncached", "ratio_cached", "ratio_cached_uniform",
    "ratio_default_process", "ratio_best_uncached_process", "ratio_cached_process",
    "ratio_cached_uniform_process",
    "cache_speedup_vs_best_uncached", "extrapolated",
]


class BenchError(Exception):
    pass


def log(msg):
    sys.stderr.write(msg + "\n")
    sys.stderr.flush()


# ---------------------------------------------------------------------------------------------
# processes


def child_env():
    """The environment for the renderers, without this interpreter's own prefix on PATH.

    Blender's embedded Python finds its standard library (and Debian's numpy) from the python3
    it meets on PATH; a pyenv or virtualenv interpreter running this script puts its own bin
    directory first, and the glTF importer then fails for want of numpy.
    """
    env = dict(os.environ)
    prefixes = {os.path.realpath(p) for p in (sys.prefix, sys.base_prefix)} - {"/usr", "/usr/local"}
    keep = []
    for d in env.get("PATH", "").split(os.pathsep):
        r = os.path.realpath(d) if d else d
        if any(r == p or r.startswith(p + os.sep) for p in prefixes) or "/.pyenv/" in d + "/":
            continue
        keep.append(d)
    env["PATH"] = os.pathsep.join(keep)
    for k in ("PYTHONHOME", "PYTHONPATH", "VIRTUAL_ENV"):
        env.pop(k, None)
    return env


CHILD_ENV = child_env()


def run(cmd, what, capture=True, timeout=None):
    """Runs cmd under `nice -n 10`; returns (wall seconds, stdout). One-line error on failure."""
    full = ["nice", "-n", "10"] + cmd
    t0 = time.perf_counter()
    try:
        p = subprocess.run(full, stdout=subprocess.PIPE if capture else None,
                           stderr=subprocess.PIPE, timeout=timeout, text=True, env=CHILD_ENV)
    except subprocess.TimeoutExpired:
        raise BenchError("%s timed out after %.0f s" % (what, timeout))
    seconds = time.perf_counter() - t0
    if p.returncode != 0:
        err = [l for l in ((p.stderr or "") + "\n" + (p.stdout or "")).splitlines() if l.strip()]
        keyed = [l for l in err if "rror" in l or l.startswith(("cycles_render:", "dofcache:"))]
        tail = (keyed or err or ["no message"])[-1].strip()
        with open(os.path.join(tempfile.gettempdir(), "peer_bench_failed.log"), "w") as f:
            f.write(" ".join(full) + "\n" + (p.stdout or "") + "\n" + (p.stderr or ""))
        raise BenchError("%s failed (exit %d): %s" % (what, p.returncode, tail))
    return seconds, p.stdout or ""


def sha256_file(path):
    h = hashlib.sha256()
    with open(path, "rb") as f:
        for block in iter(lambda: f.read(1 << 20), b""):
            h.update(block)
    return h.hexdigest()


def key_of(obj):
    return hashlib.sha256(json.dumps(obj, sort_keys=True).encode()).hexdigest()[:16]


def write_atomically(path, text):
    d = os.path.dirname(os.path.abspath(path))
    os.makedirs(d, exist_ok=True)
    fd, tmp = tempfile.mkstemp(prefix="." + os.path.basename(path) + ".", dir=d)
    try:
        with os.fdopen(fd, "w", newline="") as f:
            f.write(text)
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


# ---------------------------------------------------------------------------------------------
# machine description (as bench_common.cpp writes it)


def read_key(path, key, sep):
    try:
        with open(path) as f:
            for line in f:
                k, _, v = line.partition(sep)
                if k.strip() == key:
                    return v.strip().strip('"')
    except OSError:
        pass
    return None


def git_description():
    try:
        commit = subprocess.run(["git", "-C", REPO, "rev-parse", "HEAD"], capture_output=True,
                                text=True).stdout.strip()
        if not commit:
            return None
        status = subprocess.run(
            ["git", "-C", REPO, "status", "--porcelain", "--untracked-files=no", "--", ".",
             ":!bench/results", ":!docs/images"], capture_output=True, text=True).stdout
        return {"commit": commit, "dirty": bool(status.strip())}
    except OSError:
        return None


def machine_description(blender_version):
    mem = read_key("/proc/meminfo", "MemTotal", ":")
    mem_bytes = int(float(mem.split()[0]) * 1024) if mem else None
    u = platform.uname()
    try:
        threads_available = len(os.sched_getaffinity(0))
    except AttributeError:
        threads_available = os.cpu_count()
    try:
        load = list(os.getloadavg())
    except OSError:
        load = None
    return {
        "cpu": read_key("/proc/cpuinfo", "model name", ":"),
        "logical_cores": os.cpu_count(),
        "threads_available": threads_available,
        "memory_bytes": mem_bytes,
        "memory_gib": round(mem_bytes / (1 << 30), 1) if mem_bytes else None,
        "os": read_key("/etc/os-release", "PRETTY_NAME", "="),
        "kernel": "%s %s %s" % (u.system, u.release, u.machine),
        "hostname": socket.gethostname() or None,
        "date_utc": datetime.datetime.now(datetime.timezone.utc).strftime("%Y-%m-%dT%H:%M:%SZ"),
        "git": git_description(),
        "load_average": load,
        "blender": blender_version,
        "python": platform.python_version(),
    }


def csv_field(v):
    if v is None:
        return ""
    if isinstance(v, bool):
        text = "true" if v else "false"
    elif isinstance(v, (int, float)):
        text = json.dumps(v)
    else:
        text = str(v)
    if any(c in text for c in ',"\r\n') or text.strip() != text:
        return '"' + text.replace('"', '""') + '"'
    return text


def write_results(name, results, blender_version):
    env = os.environ.get("DOFCACHE_BENCH_RESULTS")
    d = env if env else os.path.join(REPO, "bench", "results")
    os.makedirs(d, exist_ok=True)
    doc = {"machine": machine_description(blender_version), "results": results}
    json_path = os.path.join(d, name + ".json")
    write_atomically(json_path, json.dumps(doc, indent=2) + "\n")
    cols = list(results.get("columns", []))
    for row in results["rows"]:
        for k in sorted(row):
            if k not in cols:
                cols.append(k)
    lines = [",".join(csv_field(c) for c in cols)]
    for row in results["rows"]:
        lines.append(",".join(csv_field(row.get(c)) for c in cols))
    write_atomically(os.path.join(d, name + ".csv"), "\n".join(lines) + "\n")
    return json_path


# ---------------------------------------------------------------------------------------------
# renderers


class Dofcache:
    def __init__(self, path, threads, width, height, bounces, extra):
        self.path, self.threads = path, threads
        self.width, self.height, self.bounces, self.extra = width, height, bounces, extra
        _, help_text = run([path, "render", "--help"], "dofcache render --help")
        self.flags = set(re.findall(r"(--[a-z][a-z0-9-]*)", help_text))
        try:
            _, v = run([path, "--version"], "dofcache --version")
            self.version_text = v.strip().splitlines()[0] if v.strip() else None
        except BenchError:
            self.version_text = None
        self.binary_sha = sha256_file(path)

    def render(self, scene, lens, spp, seed, out, config, workdir):
        stats = out + ".stats.json"
        cmd = [self.path, "render", scene, "--out", out, "--spp", str(spp),
               "--width", str(self.width), "--height", str(self.height),
               "--fstop", repr(lens["fstop"]), "--focal-length", repr(lens["focal_length"]),
               "--focus-distance", repr(lens["focus_distance"]),
               "--threads", str(self.threads), "--seed", str(seed), "--stats-json", stats, "-q"]
        if self.bounces is not None:
            cmd += ["--bounces", str(self.bounces)]
        cmd += list(self.extra) + config_args(config)
        wall, _ = run(cmd, "dofcache render %s (%s, %d spp)" % (
            os.path.basename(scene), config_label(config), spp))
        with open(stats) as f:
            st = json.load(f)
        return {"seconds": float(st["seconds"]), "process_seconds": wall, "stats": st}

    def compare(self, test, ref, error_map=None, error_map_max=None):
        cmd = [self.path, "compare", test, ref, "--json"]
        if error_map:
            cmd += ["--error-map", error_map]
            if error_map_max:
                cmd += ["--error-map-max", repr(error_map_max)]
        _, out = run(cmd, "dofcache compare")
        m = json.loads(out[out.index("{"):])
        return float(m["rel_mse"])


class Cycles:
    def __init__(self, blender, threads, width, height, bounces, lambert, aperture=None):
        self.aperture = aperture  # cycles_aperture(...) or None: round
        self.blender, self.threads = blender, threads
        self.width, self.height, self.bounces, self.lambert = width, height, bounces, lambert
        _, out = run([blender, "--version"], "blender --version")
        m = re.search(r"Blender\s+(\S+)", out)
        self.version = m.group(1) if m else out.strip().splitlines()[0]
        self.script_sha = sha256_file(CYCLES_SCRIPT)

    def render(self, scene, lens, spp, seed, out, config=None):
        j = out + ".json"
        cmd = [self.blender, "-b", "--factory-startup", "--python", CYCLES_SCRIPT, "--",
               scene, "--out", out, "--json-out", j, "--spp", str(spp), "--seed", str(seed),
               "--width", str(self.width), "--height", str(self.height),
               "--bounces", str(self.bounces), "--threads", str(self.threads),
               "--fstop", repr(lens["fstop"]), "--focal-length", repr(lens["focal_length"]),
               "--focus-distance", repr(lens["focus_distance"])]
        if self.lambert:
            cmd.append("--lambert")
        cmd += cycles_config_args(dict({"aperture": self.aperture}, **(config or {})))
        wall, _ = run(cmd, "Cycles render %s (%d spp)" % (os.path.basename(scene), spp))
        if not os.path.isfile(j):
            raise BenchError("Cycles render of %s wrote no JSON" % scene)
        with open(j) as f:
            st = json.load(f)
        return {"seconds": float(st["render_seconds"]), "process_seconds": wall, "stats": st}


# Cycles' configurations: the one that sets the targets (every pixel the same samples, every light
# sampled: the plain estimator dofcache's transport is checked against), and Cycles as a user runs
# it, with Blender's defaults on: adaptive sampling (noise threshold 0.01, the ladder's sample
# count the maximum) and the light threshold 0.01. Each error counts the faster of the two.
CYCLES_CONFIGS = [
    ("fixed", {}),
    ("defaults", {"adaptive_threshold": 0.01, "light_threshold": 0.01}),
]


def cycles_aperture(shape):
    """Cycles' blades, rotation and ratio for dofcache's shape {blades, rotation, ratio}.

    dofcache's rotation is a corner's angle from the image's +x, counter-clockwise; Cycles' puts
    a corner half a sector further (measured by bench/peer/bokeh_mapping.py: 6 blades at Cycles'
    0, 20 and 40 deg put corners at 30.3, 51.1 and 70.2 deg; 5 blades at 0 deg, 35.2), so Cycles
    is given dofcache's angle less 180 / N. The ratio is the same (height over width)."""
    blades = shape.get("blades", 0)
    rotation = shape.get("rotation", 0.0)
    return {"blades": blades, "rotation_deg": rotation - 180.0 / blades if blades else rotation,
            "ratio": shape.get("ratio", 1.0)}


def cycles_config_args(config):
    args = []
    ap = config.get("aperture")
    if ap:
        args += ["--aperture-blades", str(ap["blades"]), "--aperture-rotation",
                 repr(ap["rotation_deg"]), "--aperture-ratio", repr(ap["ratio"])]
    if config.get("adaptive_threshold") is not None:
        args += ["--adaptive-threshold", repr(config["adaptive_threshold"])]
    if config.get("light_threshold"):
        args += ["--light-threshold", repr(config["light_threshold"])]
    return args


def config_args(config):
    args = []
    if config.get("gather") is not None:
        args += ["--gather-rays", str(config["gather"])]
    if config.get("light") is not None:
        args += ["--light-samples", str(config["light"])]
    # Uncached unless a cache is named: render's own default is the vdb cache.
    args += ["--cache", config.get("cache") or "none"]
    # Adaptive lens sampling is render's default for drt; "off" samples every pixel alike.
    if config.get("adaptive"):
        args += ["--adaptive", config["adaptive"]]
    return args


def config_label(config):
    parts = []
    if config.get("cache"):
        parts.append("cache " + config["cache"])
    if config.get("gather") is not None:
        parts.append("gather %d" % config["gather"])
    if config.get("light") is not None:
        parts.append("light %d" % config["light"])
    if config.get("adaptive") == "off":
        parts.append("uniform lens sampling")
    return ", ".join(parts) if parts else "uncached, default shading"


# ---------------------------------------------------------------------------------------------
# error vs time


def time_to_error(points, target, key="seconds"):
    """Time at which a ladder [{spp, seconds, process_seconds, rel_mse}] reaches `target`.

    Returns (seconds, extrapolated). The crossing counted is the last one after which the ladder
    stays at or below the target (a ladder whose error jumps back up, as fireflies make it, is
    not credited with a lucky early point), log-log interpolated between the points around it.
    A ladder below the target from its first point, or never reaching it, is extrapolated with
    the slope of its first two or last three points (flagged); None where the error does not
    fall there.
    """
    pts = [(p[key], p["rel_mse"]) for p in points if p[key] > 0 and p["rel_mse"] > 0]
    if not pts:
        return None, False
    lt = [math.log(t) for t, _ in pts]
    le = [math.log(e) for _, e in pts]
    g = math.log(target)
    n = len(pts)
    # First index from which every point is at or below the target.
    k = n
    while k > 0 and le[k - 1] <= g:
        k -= 1
    if k == 0 and abs(le[0] - g) < 1e-9:  # the first point is the target (Cycles' own)
        return pts[0][0], False
    if k == 0:  # below the target from the first point: back to at most one sample per pixel
        floor = pts[0][0] / points[0]["spp"] if points[0]["spp"] > 0 else 0.0
        if n >= 2 and le[1] < le[0]:
            t = math.exp(lt[0] + (g - le[0]) * (lt[1] - lt[0]) / (le[1] - le[0]))
            return max(t, floor), True
        return pts[0][0], True
    if k < n:  # points k-1 (above) and k (at or below)
        i = k - 1
        if le[i] == le[k]:
            return pts[k][0], False
        return math.exp(lt[i] + (g - le[i]) * (lt[k] - lt[i]) / (le[k] - le[i])), False
    # Never reached: extrapolate with the slope of a least-squares fit over the last 3 points.
    tail = list(zip(lt, le))[-3:]
    if len(tail) < 2:
        return None, True
    mt = sum(a for a, _ in tail) / len(tail)
    me = sum(b for _, b in tail) / len(tail)
    num = sum((a - mt) * (b - me) for a, b in tail)
    den = sum((a - mt) ** 2 for a, _ in tail)
    slope = num / den if den > 0 else 0.0  # d log e / d log t
    if slope >= -0.05:
        return None, True
    return math.exp(lt[-1] + (g - le[-1]) / slope), True


def fitted_slope(points, x="spp"):
    pts = [(math.log(p[x]), math.log(p["rel_mse"])) for p in points if p["rel_mse"] > 0]
    if len(pts) < 2:
        return None
    mx = sum(a for a, _ in pts) / len(pts)
    my = sum(b for _, b in pts) / len(pts)
    den = sum((a - mx) ** 2 for a, _ in pts)
    return sum((a - mx) * (b - my) for a, b in pts) / den if den > 0 else None


def frame_path(pattern, frame):
    """`pattern` with its last run of '#' replaced by the zero-padded frame (as Blender and
    `dofcache sequence` do)."""
    i = pattern.rfind("#")
    j = i
    while j > 0 and pattern[j - 1] == "#":
        j -= 1
    return pattern[:j] + str(frame).zfill(i + 1 - j) + pattern[i + 1:]


def pow2_ceil(x):
    return 1 << max(0, math.ceil(math.log2(max(1.0, x))))


def pow2_floor(x):
    return 1 << max(0, math.floor(math.log2(max(1.0, x))))


def interleave(queues):
    """One timing pass's order over several renderers' ladder points.

    Each queue's points are spread evenly over the pass (the i-th of n at (i + 0.5) / n of it), so
    the renderers alternate and each meets the drift of the whole pass, whatever its length."""
    tagged = []
    for q, items in enumerate(queues):
        for i, item in enumerate(items):
            tagged.append(((i + 0.5) / len(items), q, i, item))
    tagged.sort(key=lambda x: x[:3])
    return [item for *_, item in tagged]


def timing_passes(queues, passes, render):
    """Times every point of `queues` (lists of point dicts) `passes` times, interleaved.

    Odd passes run the order backwards, so a drift over the run falls alike on early and late
    points. render(point) -> {"seconds", "process_seconds"}. Each point's times become the median
    of its runs (the runs are kept; its first, untimed discovery render's times are kept as
    discovery_*). Returns the number of renders."""
    order = interleave(queues)
    runs = {id(p): [] for p in order}
    for k in range(passes):
        for p in (order if k % 2 == 0 else order[::-1]):
            runs[id(p)].append(render(p))
    if passes < 1:
        return 0
    for p in order:
        rs = runs[id(p)]
        for key in ("seconds", "process_seconds"):
            p["discovery_" + key] = p[key]
            p[key + "_runs"] = [r[key] for r in rs]
            p[key] = statistics.median(p[key + "_runs"])
    return passes * len(order)


# ---------------------------------------------------------------------------------------------
# one scene


class SceneBench:
    def __init__(self, name, path, a, plan, cyc, dof, work, cache_dir, images_dir):
        self.name, self.path, self.a, self.plan = name, path, a, plan
        self.cyc, self.dof = cyc, dof
        self.work = os.path.join(work, name)
        os.makedirs(self.work, exist_ok=True)
        self.cache_dir, self.images_dir = cache_dir, images_dir
        self.scene_sha = sha256_file(path)
        self.seed = a.seed
        self.ref_factor = plan["reference_factor"]

    def out(self, stem):
        return os.path.join(self.work, stem + ".exr")

    # -- lens: what dofcache resolves (scene extras or autofocus), with the wide f-number
    def resolve_lens(self):
        probe = self.out("lens_probe")
        # The scene's own lens, as dofcache resolves it (extras.lens, defaults, autofocus).
        stats = probe + ".stats.json"
        cmd = [self.dof.path, "render", self.path, "--out", probe, "--spp", "1", "--width", "8",
               "--height", "6", "--threads", str(self.dof.threads), "--stats-json", stats, "-q"]
        run(cmd, "dofcache lens probe of %s" % self.name)
        with open(stats) as f:
            lens = json.load(f)["lens"]
        scene_fstop = float(lens["fstop"])
        if self.a.fstop:
            fstop = self.a.fstop
        elif self.name in WIDE_FSTOP and self.a.fstop_scale == 0.5:
            fstop = WIDE_FSTOP[self.name]
        else:
            fstop = scene_fstop * self.a.fstop_scale
        self.lens = {"focal_length": float(lens["focal_length"]), "fstop": fstop,
                     "focus_distance": float(lens["focus_distance"]), "scene_fstop": scene_fstop}
        self.lens["aperture_radius"] = self.lens["focal_length"] / (2.0 * fstop)
        return self.lens

    def lens_key(self):
        return {k: self.lens[k] for k in ("focal_length", "fstop", "focus_distance")}

    # -- references (cached)
    def cycles_reference(self, spp):
        key = {"renderer": "cycles", "blender": self.cyc.version, "script": self.cyc.script_sha,
               "scene": self.scene_sha, "size": [self.cyc.width, self.cyc.height],
               "lens": self.lens_key(), "bounces": self.cyc.bounces, "lambert": self.cyc.lambert,
               **({"aperture": self.cyc.aperture} if self.cyc.aperture else {}),
               "spp": spp, "seed": self.seed + 7919}
        path = os.path.join(self.cache_dir, "%s_cycles_%s.exr" % (self.name, key_of(key)))
        meta = path + ".meta.json"
        if os.path.isfile(path) and os.path.isfile(meta) and not self.a.fresh_references:
            with open(meta) as f:
                m = json.load(f)
            log("  Cycles reference: cached %s (%d spp)" % (os.path.basename(path), spp))
            return path, dict(m, cached=True)
        log("  Cycles reference: rendering %d spp ..." % spp)
        tmp = os.path.join(self.work, "cycles_ref.exr")
        r = self.cyc.render(self.path, self.lens, spp, self.seed + 7919, tmp)
        shutil.copyfile(tmp, path + ".tmp.exr")
        os.replace(path + ".tmp.exr", path)
        m = {"key": key, "spp": spp, "seconds": r["seconds"],
             "process_seconds": r["process_seconds"], "cached": False}
        write_atomically(meta, json.dumps(m, indent=2) + "\n")
        log("    %.1f s" % r["seconds"])
        return path, m

    def dofcache_base_key(self):
        return {"renderer": "dofcache", "binary": self.dof.binary_sha, "scene": self.scene_sha,
                "size": [self.dof.width, self.dof.height], "lens": self.lens_key(),
                "bounces": self.dof.bounces, "extra": list(self.dof.extra),
                "seed": self.seed + 7919}

    def cached_dofcache_reference(self):
        base = key_of(self.dofcache_base_key())
        path = os.path.join(self.cache_dir, "%s_dofcache_%s.exr" % (self.name, base))
        if os.path.isfile(path) and os.path.isfile(path + ".meta.json") \
                and not self.a.fresh_references:
            with open(path + ".meta.json") as f:
                return path, json.load(f)
        return path, None

    def dofcache_reference(self, config, spp, required_seconds):
        path, m = self.cached_dofcache_reference()
        if m is not None and ((m["config"] == config and m["spp"] >= spp)
                              or m["seconds"] >= 0.7 * required_seconds):
            log("  dofcache reference: cached %s (%s, %d spp, %.0f s)" % (
                os.path.basename(path), m["config_label"], m["spp"], m["seconds"]))
            m = dict(m, cached=True)
            return path, m
        log("  dofcache reference: rendering %s, %d spp ..." % (config_label(config), spp))
        tmp = os.path.join(self.work, "dofcache_ref.exr")
        # References sample uniformly: an adaptive sampler's counts depend on its own pilot.
        r = self.dof.render(self.path, self.lens, spp, self.seed + 7919, tmp,
                            dict(config, adaptive="off"), self.work)
        shutil.copyfile(tmp, path + ".tmp.exr")
        os.replace(path + ".tmp.exr", path)
        m = {"key": self.dofcache_base_key(), "config": config, "config_label": config_label(config),
             "spp": spp, "seconds": r["seconds"], "process_seconds": r["process_seconds"],
             "cached": False}
        write_atomically(path + ".meta.json", json.dumps(m, indent=2) + "\n")
        log("    %.1f s" % r["seconds"])
        return path, m

    def top_up_reference(self, path, meta, want_spp):
        """Adds renders with further seeds to a dofcache reference (spp-weighted mean)."""
        limit = 60.0 * self.a.max_reference_minutes
        per_spp = meta["seconds"] / meta["spp"]
        extra = want_spp - meta["spp"]
        if meta["seconds"] + per_spp * extra > limit:
            extra = int(max(0.0, limit - meta["seconds"]) / per_spp)
            if extra < meta["spp"] // 4:
                log("  note: no top-up of the dofcache reference (%d spp): --max-reference-minutes"
                    % meta["spp"])
                return path, meta
        log("  dofcache reference: topping up %d -> %d spp ..." % (meta["spp"], meta["spp"] + extra))
        tmp = os.path.join(self.work, "dofcache_ref_topup.exr")
        seed = self.seed + 7919 + 1000 * (1 + len(meta.get("top_ups", [])))
        r = self.dof.render(self.path, self.lens, extra, seed, tmp,
                            dict(meta["config"], adaptive="off"), self.work)
        total = meta["spp"] + extra
        mixed = os.path.join(self.work, "dofcache_ref_mixed.exr")
        run(["oiiotool", path, "--ch", "R,G,B", "--mulc", repr(meta["spp"] / total),
             tmp, "--ch", "R,G,B", "--mulc", repr(extra / total), "--add", "-d", "float",
             "-o", mixed], "oiiotool (reference top-up)")
        shutil.copyfile(mixed, path + ".tmp.exr")
        os.replace(path + ".tmp.exr", path)
        meta = dict(meta)
        meta["top_ups"] = meta.get("top_ups", []) + [{"spp": extra, "seed": seed,
                                                      "seconds": r["seconds"]}]
        meta["spp"] = total
        meta["seconds"] += r["seconds"]
        meta["process_seconds"] += r["process_seconds"]
        stored = {k: v for k, v in meta.items() if k != "cached"}
        write_atomically(path + ".meta.json", json.dumps(dict(stored, cached=False), indent=2) + "\n")
        log("    %.1f s" % r["seconds"])
        return path, meta

    # -- ladders
    # Discovery renders each ladder point once, for its image and error (and where a ladder stops);
    # its time is then measured in interleaved timing passes (timing_passes): one render per point
    # shows this machine's noise (the same 4-spp render took 0.37-0.55 s five times in a row), and
    # a drift over the minutes the ladders take would otherwise fall on one renderer only.
    def cycles_ladder(self, ref, config, tag):
        pts = []
        for spp in self.plan["cycles_ladder"]:
            out = self.out("%s_%d" % (tag, spp))
            r = self.cyc.render(self.path, self.lens, spp, self.seed, out, config)
            e = self.dof.compare(out, ref)
            pts.append({"seconds": r["seconds"], "process_seconds": r["process_seconds"],
                        "spp": spp, "rel_mse": e, "image": out, "renderer": "cycles",
                        "config": config})
            log("    Cycles %-9s %5d spp: relMSE %.5g  %.2f s (process %.2f s)" % (
                tag[len("cycles_"):], spp, e, r["seconds"], r["process_seconds"]))
        return pts

    def time_point(self, p):
        """Renders a ladder point again (same seed: the same image) for its time only."""
        scratch = self.out("timing_" + p["renderer"])
        if p["renderer"] == "cycles":
            return self.cyc.render(self.path, self.lens, p["spp"], self.seed, scratch, p["config"])
        return self.dof.render(self.path, self.lens, p["spp"], self.seed, scratch, p["config"],
                               self.work)

    def dof_point(self, config, spp, ref, stem):
        out = self.out(stem)
        r = self.dof.render(self.path, self.lens, spp, self.seed, out, config, self.work)
        r = {"seconds": r["seconds"], "process_seconds": r["process_seconds"],
             "renderer": "dofcache", "config": config}
        e = self.dof.compare(out, ref)
        log("    dofcache %-22s %5d spp: relMSE %.5g  %.2f s (process %.2f s)" % (
            config_label(config), spp, e, r["seconds"], r["process_seconds"]))
        return dict(r, spp=spp, rel_mse=e, image=out)

    def dof_ladder(self, config, start, ref, min_target, cap_seconds, tag, max_target=None):
        pts, spp = [], max(1, start)
        while True:
            p = self.dof_point(config, spp, ref, "%s_%d" % (tag, spp))
            pts.append(p)
            if len(pts) >= 3 and p["rel_mse"] <= min_target / 1.1:
                break
            if p["seconds"] > cap_seconds and len(pts) >= 2:
                break
            if spp * 2 > self.plan["spp_cap"]:
                break
            spp *= 2
        # Already below the largest target at its first point: go down (halving, to 1 spp) until
        # a point lies above it, so the time there is interpolated, not extrapolated.
        spp = pts[0]["spp"]
        while max_target is not None and pts[0]["rel_mse"] <= max_target and spp > 1:
            spp //= 2
            pts.insert(0, self.dof_point(config, spp, ref, "%s_%d" % (tag, spp)))
        return pts

    # -- the search: each budget rendered twice (two seeds) at a few spp. No reference exists yet:
    # the pilot, the mean of every probe render (all estimate the same image), stands in for it.
    def probe(self, config, tag):
        spp = self.plan["probe_spp"]
        a_out, b_out = self.out(tag + "_pa"), self.out(tag + "_pb")
        ra = self.dof.render(self.path, self.lens, spp, self.seed + 101, a_out, config, self.work)
        rb = self.dof.render(self.path, self.lens, spp, self.seed + 102, b_out, config, self.work)
        t = 0.5 * (ra["seconds"] + rb["seconds"])
        return {"config": config, "label": config_label(config), "spp": spp, "seconds": t,
                "images": [a_out, b_out]}

    def pilot(self, probes):
        images = [im for p in probes for im in p["images"]]
        out = self.out("pilot")
        cmd = ["oiiotool"]
        for i, im in enumerate(images):
            cmd += [im, "--ch", "R,G,B"]
            if i:
                cmd += ["--add"]
        cmd += ["--divc", repr(float(len(images))), "-d", "float", "-o", out]
        run(cmd, "oiiotool (pilot reference)")
        for p in probes:
            e = [self.dof.compare(im, out) for im in p["images"]]
            p["rel_mse_vs_pilot"] = 0.5 * (e[0] + e[1])
            p["rel_mse"] = p["rel_mse_vs_pilot"]
            p["merit"] = p["rel_mse"] * p["seconds"]
            del p["images"]
        return out

    def run(self):
        a, plan = self.a, self.plan
        log("%s: %s" % (self.name, os.path.relpath(self.path, REPO)))
        self.resolve_lens()
        log("  lens %.0f mm f/%.3g (scene f/%.3g), focus %.4g m, aperture radius %.4g m" % (
            self.lens["focal_length"] * 1e3, self.lens["fstop"], self.lens["scene_fstop"],
            self.lens["focus_distance"], self.lens["aperture_radius"]))

        # Cycles: reference, ladder, targets.
        cyc_ref_spp = self.ref_factor * max(plan["cycles_ladder"])
        cyc_ref, cyc_ref_meta = self.cycles_reference(cyc_ref_spp)
        cyc_ladders = {name: {"config": cfg,
                              "points": self.cycles_ladder(cyc_ref, cfg, "cycles_" + name)}
                       for name, cfg in CYCLES_CONFIGS}
        cyc_pts = cyc_ladders["fixed"]["points"]
        targets = []
        for spp in plan["targets"]:
            p = next(p for p in cyc_pts if p["spp"] == spp)
            targets.append({"label": "Cycles %d spp" % spp, "spp": spp, "rel_mse": p["rel_mse"]})
        min_target = min(t["rel_mse"] for t in targets)
        max_target = max(t["rel_mse"] for t in targets)
        cyc_slowest, _ = time_to_error(cyc_pts, min_target)
        cap = max(plan["min_cap_seconds"], plan["max_ratio"] * (cyc_slowest or 1.0))

        # dofcache search.
        log("  search over shading budgets (%d spp, two seeds each) ..." % plan["probe_spp"])
        configs = [{}]
        gathers = plan["gather"] if "--gather-rays" in self.dof.flags else [None]
        lights = plan["light"] if "--light-samples" in self.dof.flags else [None]
        for g in gathers:
            for l in lights:
                if g is not None or l is not None:
                    configs.append({"gather": g, "light": l})
        search = [self.probe(c, "probe%d" % i) for i, c in enumerate(configs)]
        self.pilot(search)
        for p in search:
            log("    %-22s relMSE %.4g (vs the pilot) at %d spp in %.2f s: merit %.4g" % (
                p["label"], p["rel_mse"], p["spp"], p["seconds"], p["merit"]))
        ranked = sorted(search, key=lambda p: p["merit"])
        default_probe = search[0]

        def start_spp(p):
            # 1/N: spp at which the predicted error is about twice the largest target.
            return pow2_floor(p["spp"] * p["rel_mse"] / (2.0 * max_target))

        def needed_spp(p, target):
            return p["spp"] * p["rel_mse"] / target

        # dofcache reference: the most efficient uncached budget (least noise x time in the search),
        # at 16x the samples of its own ladder's last point (predicted from the search by 1/N, as
        # dof_ladder will run it). Being the most efficient, its error is then about 1/16 of the
        # smallest target's or less, so it adds at most ~6% to any error interpolated there.
        tops = [p for p in ranked if p["config"]][:plan["top_configs"]]
        stop = min_target / 1.1

        def predicted_end(p, start):
            spp, n, per_spp = start, 1, p["seconds"] / p["spp"]
            while True:
                e, t = p["rel_mse"] * p["spp"] / spp, per_spp * spp
                if (n >= 3 and e <= stop) or (t > cap and n >= 2) or spp * 2 > plan["spp_cap"]:
                    return spp, t
                spp, n = spp * 2, n + 1

        best = ranked[0]
        best_end_spp, best_end_t = predicted_end(best, start_spp(best))
        ref_spp = min(self.ref_factor * max(best_end_spp, pow2_ceil(needed_spp(best, min_target))),
                      1 << 20)
        dof_ref, dof_ref_meta = self.dofcache_reference(
            best["config"], ref_spp, self.ref_factor * best["seconds"] / best["spp"]
            * needed_spp(best, min_target))

        # Ladders.
        log("  ladders (stop below %.4g relMSE or past %.1f s) ..." % (min_target / 1.1, cap))
        ladders = {}
        ladders["default"] = {"config": {}, "label": "default",
                              "points": self.dof_ladder({}, start_spp(default_probe), dof_ref,
                                                        min_target, cap, "default", max_target)}
        for i, p in enumerate(tops):
            ladders["uncached_%d" % i] = {
                "config": p["config"], "label": p["label"],
                "points": self.dof_ladder(p["config"], start_spp(p), dof_ref, min_target, cap,
                                          "search%d" % i, max_target)}
        cached_cfg = {"cache": "vdb"}
        ladders["cached"] = {"config": cached_cfg, "label": config_label(cached_cfg),
                             "points": self.dof_ladder(cached_cfg, plan["cached_start"], dof_ref,
                                                       min_target, cap, "cached", max_target)}
        # The cache without adaptive lens sampling: what each of the two contributes.
        uniform_cfg = {"cache": "vdb", "adaptive": "off"}
        ladders["cached_uniform"] = {
            "config": uniform_cfg, "label": config_label(uniform_cfg),
            "points": self.dof_ladder(uniform_cfg, plan["cached_start"], dof_ref, min_target, cap,
                                      "cached_uniform", max_target)}
        # The reference's budget may have needed more samples than the search predicted (fireflies
        # make the error fall slower than 1/N): top it up to 16x its ladder's largest point (within
        # --max-reference-minutes) and measure every dofcache render again.
        same = [p["spp"] for L in ladders.values() if L["config"] == dof_ref_meta["config"]
                for p in L["points"]]
        if same and dof_ref_meta["spp"] < self.ref_factor * max(same):
            dof_ref, dof_ref_meta = self.top_up_reference(dof_ref, dof_ref_meta,
                                                          self.ref_factor * max(same))
            for L in ladders.values():
                for p in L["points"]:
                    p["rel_mse"] = self.dof.compare(p["image"], dof_ref)
        for L in list(ladders.values()) + list(cyc_ladders.values()):
            L["slope_rel_mse_vs_spp"] = fitted_slope(L["points"])

        # Times: every ladder point rendered again --repeat times, Cycles' and dofcache's points
        # interleaved; each point's time is the median of its runs.
        if a.repeat > 0:
            queues = [[p for L in cyc_ladders.values() for p in L["points"]],
                      [p for L in ladders.values() for p in L["points"]]]
            log("  timing: %d interleaved pass(es) over %d Cycles and %d dofcache points ..." % (
                a.repeat, len(queues[0]), len(queues[1])))
            timing_passes(queues, a.repeat, self.time_point)
        longest = max(p["seconds"] for L in ladders.values() for p in L["points"])
        dof_ref_meta = dict(dof_ref_meta)
        if dof_ref_meta["config"] == best["config"]:
            dof_ref_meta["estimated_rel_mse_from_search"] = \
                best["rel_mse"] * best["spp"] / dof_ref_meta["spp"]
        dof_ref_meta["time_factor_over_longest_ladder_point"] = dof_ref_meta["seconds"] / longest
        same = [p["spp"] for L in ladders.values() if L["config"] == dof_ref_meta["config"]
                for p in L["points"]]
        dof_ref_meta["spp_factor_over_own_ladder"] = dof_ref_meta["spp"] / max(same) if same \
            else None
        if (dof_ref_meta["spp_factor_over_own_ladder"] or self.ref_factor) < self.ref_factor:
            log("  note: the dofcache reference has %.1fx the samples of its configuration's "
                "largest ladder point (aimed at %dx)" % (dof_ref_meta["spp_factor_over_own_ladder"],
                                                         self.ref_factor))

        # Times to equal error.
        rows = []
        for t in targets:
            row = {"scene": self.name, "width": self.cyc.width, "height": self.cyc.height,
                   "fstop": self.lens["fstop"], "scene_fstop": self.lens["scene_fstop"], "aperture_radius_m": self.lens["aperture_radius"],
                   "target": t["label"], "target_rel_mse": t["rel_mse"]}
            extrap = []
            for key, col in (("seconds", ""), ("process_seconds", "_process")):
                def reach(points, tag):
                    """Time to the target along a ladder; notes an extrapolated one."""
                    seconds, extrapolated = time_to_error(points, t["rel_mse"], key)
                    if extrapolated:
                        extrap.append(tag)
                    return seconds
                # Cycles at its best: whichever configuration reaches the error sooner.
                c_t, c_label = None, None
                for name, L in cyc_ladders.items():
                    v = row["cycles_%s%s_s" % (name, col)] = reach(L["points"], "cycles_" + name)
                    if v is not None and (c_t is None or v < c_t):
                        c_t, c_label = v, name
                row["cycles%s_s" % col] = c_t
                row["cycles_best_config%s" % col] = c_label
                d_t = row["dofcache_default%s_s" % col] = reach(ladders["default"]["points"],
                                                                  "default")
                best_t, best_label, best_x = None, None, False
                for k, L in ladders.items():
                    if not k.startswith("uncached_") and k != "default":
                        continue
                    u_t, u_x = time_to_error(L["points"], t["rel_mse"], key)
                    if u_t is not None and (best_t is None or u_t < best_t):
                        best_t, best_label, best_x = u_t, L["label"], u_x
                row["dofcache_best_uncached%s_s" % col] = best_t
                if key == "seconds":
                    row["dofcache_best_config"] = best_label
                if best_x:
                    extrap.append("best_uncached")
                k_t = row["dofcache_cached%s_s" % col] = reach(ladders["cached"]["points"],
                                                                 "cached")
                u_t = row["dofcache_cached_uniform%s_s" % col] = reach(
                    ladders["cached_uniform"]["points"], "cached_uniform")
                row["ratio_cached_uniform%s" % col] = u_t / c_t if u_t and c_t else None
                for name, v in (("default", d_t), ("best_uncached", best_t), ("cached", k_t)):
                    row["ratio_%s%s" % (name, col)] = v / c_t if v and c_t else None
                if key == "seconds":
                    row["cache_speedup_vs_best_uncached"] = best_t / k_t if best_t and k_t else None
            row["extrapolated"] = " ".join(sorted(set(extrap))) or None
            rows.append(row)

        image = self.side_by_side(cyc_pts, cyc_ref, ladders, dof_ref, targets)
        return {
            "rows": rows,
            "detail": {
                "scene": os.path.relpath(self.path, REPO), "scene_sha256": self.scene_sha,
                "lens": self.lens, "targets": targets,
                "cycles": {"reference": {"path": cyc_ref, **cyc_ref_meta},
                           "ladders": cyc_ladders},
                "dofcache": {"reference": {"path": dof_ref, **dof_ref_meta},
                             "search": search, "ladders": ladders},
                "image": image,
            },
        }

    # -- side-by-side images at about equal time
    def side_by_side(self, cyc_pts, cyc_ref, ladders, dof_ref, targets):
        if self.images_dir is None:
            return None
        mid = cyc_pts[len(cyc_pts) // 2]
        t = mid["seconds"]

        def closest(points):
            return min(points, key=lambda p: abs(math.log(p["seconds"] / t)))

        # The uncached ladder fastest at Cycles' middle error.
        best_key, best_time = "default", None
        for k, L in ladders.items():
            if not (k == "default" or k.startswith("uncached_")):
                continue
            v, _ = time_to_error(L["points"], mid["rel_mse"])
            if v is not None and (best_time is None or v < best_time):
                best_key, best_time = k, v
        panels = [("Cycles %d spp" % mid["spp"], mid, cyc_ref),
                  ("dofcache %s" % ladders[best_key]["label"], closest(ladders[best_key]["points"]),
                   dof_ref),
                  ("dofcache %s" % ladders["cached"]["label"], closest(ladders["cached"]["points"]),
                   dof_ref)]
        emax = 5.0 * mid["rel_mse"]
        tmpdir = os.path.join(self.work, "images")
        os.makedirs(tmpdir, exist_ok=True)
        tops, bottoms, info = [], [], []
        for i, (label, p, ref) in enumerate(panels):
            png = os.path.join(tmpdir, "panel%d.png" % i)
            emap = os.path.join(tmpdir, "error%d.png" % i)
            e = self.dof.compare(p["image"], ref, emap, emax)
            shrink = ["--resize", "640x0"] if self.cyc.width > 640 else []  # a page's width
            run(["oiiotool", p["image"], "--ch", "R,G,B"] + shrink + ["--tocolorspace", "sRGB",
                 "-d", "uint8", "-o", png], "oiiotool (EXR to sRGB PNG)")
            if shrink:
                run(["oiiotool", emap] + shrink + ["-o", emap], "oiiotool (error map)")
            tops.append(png)
            bottoms.append(emap)
            info.append({"panel": label, "spp": p["spp"], "seconds": p["seconds"],
                         "process_seconds": p["process_seconds"], "rel_mse": e})
        os.makedirs(self.images_dir, exist_ok=True)
        dest = os.path.join(self.images_dir, "peer_%s.png" % self.name)
        tmp_dest = os.path.join(tmpdir, "peer_%s.png" % self.name)
        run(["oiiotool"] + tops + bottoms + ["--mosaic:pad=4", "3x2", "-d", "uint8", "-o",
                                             tmp_dest], "oiiotool --mosaic")
        shutil.copyfile(tmp_dest, dest + ".tmp.png")
        os.replace(dest + ".tmp.png", dest)
        log("  wrote %s" % dest)
        return {"path": os.path.relpath(dest, REPO) if dest.startswith(REPO) else dest,
                "layout": "top: renders (sRGB), bottom: relative squared error maps "
                          "(white = %.3g); left to right as listed" % emax,
                "error_map_max": emax, "panels": info}


# ---------------------------------------------------------------------------------------------


def fmt(v, digits=3):
    if v is None:
        return "-"
    if isinstance(v, float):
        return "%.*g" % (digits, v)
    return str(v)


def print_table(rows):
    head = ["target", "relMSE", "Cycles s", "which", "fixed s", "defaults s", "dof default s", "dof best s", "best config",
            "dof cached s", "uniform s", "def/C", "best/C", "cached/C", "uniform/C",
            "best/cached", "extrapolated"]
    body = []
    for r in rows:
        body.append([r["target"], fmt(r["target_rel_mse"]), fmt(r["cycles_s"]),
                     fmt(r["cycles_best_config"]), fmt(r["cycles_fixed_s"]),
                     fmt(r["cycles_defaults_s"]),
                     fmt(r["dofcache_default_s"]), fmt(r["dofcache_best_uncached_s"]),
                     fmt(r["dofcache_best_config"]), fmt(r["dofcache_cached_s"]),
                     fmt(r["dofcache_cached_uniform_s"]),
                     fmt(r["ratio_default"]), fmt(r["ratio_best_uncached"]),
                     fmt(r["ratio_cached"]), fmt(r["ratio_cached_uniform"]),
                     fmt(r["cache_speedup_vs_best_uncached"]),
                     fmt(r["extrapolated"])])
    widths = [max(len(x[i]) for x in [head] + body) for i in range(len(head))]
    line = lambda cells: "  ".join(c.rjust(w) if i else c.ljust(w)
                                   for i, (c, w) in enumerate(zip(cells, widths)))
    print(line(head))
    for b in body:
        print(line(b))
    pr = [(r["target"], r["cycles_process_s"], r["dofcache_default_process_s"],
           r["dofcache_best_uncached_process_s"], r["dofcache_cached_process_s"],
           r["ratio_best_uncached_process"], r["ratio_cached_process"]) for r in rows]
    print("  whole-process seconds (Cycles, dof default, dof best, dof cached; best/C, cached/C):")
    for p in pr:
        print("    %-16s %s" % (p[0], "  ".join(fmt(x) for x in p[1:])))


def generated_atrium(directory):
    """The 2.1 M-triangle atrium (scenes/generate_atrium.py: the same bytes on every run)."""
    path = os.path.join(directory, "atrium.glb")
    if not os.path.isfile(path):
        log("generating %s ..." % path)
        tmp = os.path.join(directory, ".atrium.tmp.glb")
        run([sys.executable, os.path.join(REPO, "scenes", "generate_atrium.py"), tmp],
            "scenes/generate_atrium.py")
        os.replace(tmp, path)
    return path


def find_exe(given, name, fallback=None):
    cand = given or shutil.which(name, path=CHILD_ENV.get("PATH")) or fallback
    if cand and os.path.isfile(cand) and os.access(cand, os.X_OK):
        return os.path.abspath(cand)
    return None


def main(argv=None):
    p = argparse.ArgumentParser(
        prog="peer_bench.py",
        description="dofcache against Blender Cycles at equal relMSE (see bench/README.md).")
    p.add_argument("--scenes", nargs="+", default=None,
                   help="scene names (%s) or .gltf/.glb paths" % ", ".join(NAMED_SCENES))
    p.add_argument("--width", type=int, default=None, help="default 320 (80 with --quick)")
    p.add_argument("--height", type=int, default=None, help="default 240 (60 with --quick)")
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--repeat", type=int, default=None,
                   help="interleaved timing passes: each ladder point is rendered again this many "
                        "times, Cycles' and dofcache's points alternating, and its time is the "
                        "median (default 3; 1 with --quick, --medium and --production; 0: the "
                        "discovery render's time, not interleaved)")
    p.add_argument("--bounces", type=int, default=1,
                   help="Cycles max bounces and dofcache --bounces (default 1)")
    p.add_argument("--fstop", type=float, default=None,
                   help="one f-number for every scene (default: a wide one per shipped scene, "
                        "half the scene's own; other scenes: theirs times --fstop-scale)")
    p.add_argument("--fstop-scale", type=float, default=0.5)
    p.add_argument("--lambert", action="store_true",
                   help="the same physics in both: Cycles with Diffuse BSDFs, dofcache "
                        "--material-override lambert")
    p.add_argument("--aperture-blades", type=int, default=0,
                   help="both renderers through a polygonal aperture (Cycles' blades, its "
                        "rotation mapped: cycles_aperture)")
    p.add_argument("--aperture-rotation", type=float, default=0.0,
                   help="dofcache's rotation (a corner's angle), degrees")
    p.add_argument("--anamorphic-ratio", type=float, default=1.0,
                   help="both renderers' bokeh height over width")
    p.add_argument("--quick", action="store_true", help="tiny ladders at 80x60 (smoke test)")
    p.add_argument("--medium", action="store_true",
                   help="160x120, Cycles up to 128 spp (about 10 minutes a scene)")
    p.add_argument("--production", action="store_true",
                   help="1280x720, the gallery and the atrium (2.1 M triangles), Cycles up to 64 "
                        "spp, references 8x (hours)")
    p.add_argument("--blender", default=None, help="blender executable (default: on PATH)")
    p.add_argument("--dofcache", default=None,
                   help="dofcache executable (default: build/dofcache, then PATH)")
    p.add_argument("--out-dir", default=None,
                   help="scratch directory (default: $TMPDIR/dofcache_peer)")
    p.add_argument("--cache-dir", default=None,
                   help="converged references (default: OUT_DIR/references)")
    p.add_argument("--max-reference-minutes", type=float, default=None,
                   help="in-render time a dofcache reference may be topped up to (default 40; "
                        "2 with --quick)")
    p.add_argument("--fresh-references", action="store_true",
                   help="render the references again even if cached")
    p.add_argument("--results", default=None,
                   help="results name (default peer_cycles; peer_cycles_quick with --quick)")
    p.add_argument("--images-dir", default=None,
                   help="where peer_<scene>.png go (default docs/images; OUT_DIR/images with "
                        "--quick)")
    a = p.parse_args(argv)

    if a.quick + a.medium + a.production > 1:
        p.error("choose one of --quick, --medium and --production")
    plan = dict(QUICK if a.quick else MEDIUM if a.medium else PRODUCTION if a.production else FULL)
    if a.repeat is None:
        a.repeat = plan["repeat"]
    if a.max_reference_minutes is None:
        a.max_reference_minutes = 2.0 if a.quick else 40.0
    width = plan["size"][0] if a.width is None else a.width
    height = plan["size"][1] if a.height is None else a.height
    for name, v in (("--width", width), ("--height", height), ("--threads", a.threads),
                    ):
        if v < 1:
            p.error("%s must be at least 1" % name)
    if a.repeat < 0:
        p.error("--repeat must be >= 0")
    if a.aperture_blades and not 3 <= a.aperture_blades <= 16 or not a.anamorphic_ratio > 0:
        p.error("--aperture-blades must be 0 or 3-16, --anamorphic-ratio > 0")
    if a.bounces < 0 or (a.fstop is not None and a.fstop <= 0) or a.fstop_scale <= 0:
        p.error("--bounces must be >= 0, --fstop and --fstop-scale > 0")
    results_name = a.results or ("peer_cycles_quick" if a.quick else
                                 "peer_cycles_160" if a.medium else
                                 "peer_cycles_1280" if a.production else "peer_cycles")
    if not re.fullmatch(r"[A-Za-z0-9_][A-Za-z0-9_.-]*", results_name):
        p.error("the results name may hold only letters, digits, '_', '.', '-'")
    if a.lambert and not a.results:
        results_name += "_lambert"

    blender = find_exe(a.blender, "blender")
    if not blender:
        raise BenchError("blender not found (apt-get install --no-install-recommends blender "
                         "python3-numpy, or pass --blender PATH)")
    dof_path = a.dofcache or os.path.join(REPO, "build", "dofcache")
    dofcache = find_exe(dof_path, "dofcache") if a.dofcache else \
        find_exe(dof_path, "dofcache") or find_exe(None, "dofcache")
    if not dofcache:
        raise BenchError("dofcache not found at %s (build it, or pass --dofcache PATH)" % dof_path)
    if not shutil.which("oiiotool", path=CHILD_ENV.get("PATH")):
        raise BenchError("oiiotool not found (apt-get install openimageio-tools)")


    out_dir = os.path.abspath(a.out_dir or os.path.join(tempfile.gettempdir(), "dofcache_peer"))
    work = os.path.join(out_dir, "quick" if a.quick else "%dx%d" % (width, height))
    cache_dir = os.path.abspath(a.cache_dir or os.path.join(out_dir, "references"))
    os.makedirs(work, exist_ok=True)
    os.makedirs(cache_dir, exist_ok=True)
    scenes = []
    for s in (a.scenes or plan.get("scenes") or [n for n, _ in DEFAULT_SCENES]):
        if s in NAMED_SCENES:
            name = s
            path = os.path.join(REPO, NAMED_SCENES[s]) if NAMED_SCENES[s] else \
                generated_atrium(cache_dir)
        else:
            path = os.path.abspath(s)
            name = re.sub(r"[^A-Za-z0-9_.-]", "_", os.path.splitext(os.path.basename(s))[0])
        if not os.path.isfile(path):
            if a.scenes is None and name == "hanging_light_box":
                log("note: %s is not there yet; skipped" % os.path.relpath(path, REPO))
                continue
            raise BenchError("scene not found: %s" % path)
        scenes.append((name, path))
    images_dir = a.images_dir or (os.path.join(out_dir, "images") if a.quick
                                  else os.path.join(REPO, "docs", "images"))

    # The binary may be rebuilt while this runs: use a private copy of it (and note its hash).
    dof_copy = os.path.join(out_dir, "dofcache.bin")
    shutil.copy2(dofcache, dof_copy + ".tmp")
    os.replace(dof_copy + ".tmp", dof_copy)
    # The same physics in both: pure Lambertian reflectors (docs/peer.md, "Same physics").
    extra = ["--material-override", "lambert"] if a.lambert else []
    shape = None
    if a.aperture_blades or a.anamorphic_ratio != 1.0:
        shape = {"blades": a.aperture_blades, "rotation": a.aperture_rotation,
                 "ratio": a.anamorphic_ratio}
        extra += ["--aperture-blades", str(a.aperture_blades), "--aperture-rotation",
                  repr(a.aperture_rotation), "--anamorphic-ratio", repr(a.anamorphic_ratio)]
    dof = Dofcache(dof_copy, a.threads, width, height, a.bounces, extra)
    cyc = Cycles(blender, a.threads, width, height, a.bounces, a.lambert,
                 cycles_aperture(shape) if shape else None)
    log("peer benchmark: %d scene(s) at %dx%d, %d threads, %d bounce(s)%s; Blender %s; "
        "dofcache %s (sha256 %s)" % (len(scenes), width, height, a.threads, a.bounces,
                                     ", Lambert" if a.lambert else "", cyc.version,
                                     dof.version_text or "?", dof.binary_sha[:12]))

    t_start = time.perf_counter()
    load_before = os.getloadavg()
    rows, details = [], {}
    for name, path in scenes:
        sb = SceneBench(name, path, a, plan, cyc, dof, work, cache_dir, images_dir)
        r = sb.run()
        rows += r["rows"]
        details[name] = r["detail"]
        print("\n%s (%dx%d, f/%.3g, aperture radius %.4g m)" % (
            name, width, height, sb.lens["fstop"], sb.lens["aperture_radius"]))
        print_table(r["rows"])
        sys.stdout.flush()

    results = {
        "description": "Time to equal relMSE (each renderer against its own converged "
                       "reference), dofcache vs Blender Cycles; ratios are dofcache / Cycles",
        "columns": COLUMNS,
        "rows": rows,
        "settings": {
            "width": width, "height": height, "threads": a.threads, "seed": a.seed,
            "repeat": a.repeat,
            "bounces": a.bounces, "lambert": a.lambert, "quick": a.quick,
            "fstop": a.fstop, "fstop_scale": a.fstop_scale, "plan": plan,
            "reference_factor": plan["reference_factor"], "nice": 10,
            "blender": cyc.version, "cycles_script_sha256": cyc.script_sha,
            "dofcache_sha256": dof.binary_sha, "dofcache_version": dof.version_text,
            "dofcache_extra_args": extra,
            "aperture": shape, "cycles_aperture": cycles_aperture(shape) if shape else None,
            "timing": "seconds: in-render (Cycles: around bpy.ops.render.render, i.e. sync, BVH "
                      "and sampling; dofcache: its --stats-json 'seconds'); process_seconds: "
                      "the whole process (Blender start-up and glTF import, dofcache scene load "
                      "and BVH, image write)",
        },
        "run": {"wall_seconds": time.perf_counter() - t_start,
                "load_average_before": list(load_before),
                "load_average_after": list(os.getloadavg())},
        "scenes": details,
    }
    path = write_results(results_name, results, cyc.version)
    print("\nwrote %s (and .csv)" % path)
    return 0


if __name__ == "__main__":
    try:
        sys.exit(main())
    except BenchError as e:
        sys.stderr.write("peer_bench: error: %s\n" % e)
        sys.exit(1)
    except KeyboardInterrupt:
        sys.stderr.write("peer_bench: interrupted\n")
        sys.exit(130)
