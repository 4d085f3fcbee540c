"""Render a glTF scene with Blender Cycles, set up like dofcache's thin-lens path tracer.

Run inside Blender (headless):

    blender -b --factory-startup --python bench/peer/cycles_render.py -- SCENE --out OUT.exr \
        [--width 320 --height 240 --spp 64 --seed 1 --bounces 1 --threads 2 --fstop 0.7 ...]

What it sets (bench/README.md, "Peer benchmark: Blender Cycles"):
  * the scene through Blender's own glTF importer (numpy's removed `np.bool` alias restored first);
  * the camera's thin lens as dofcache reads it: focal length, f-number and focus distance from
    the camera node's `extras.lens` (the camera object's extras first, the node's winning key by
    key), each overridable; the glTF vertical field of view kept (sensor fit VERTICAL, sensor
    height = 2 * lens_mm * tan(yfov / 2)); a round aperture of radius focal_length / (2 fstop)
    in scene units; the focus distance axial (Cycles' convention, and dofcache's);
  * a 1 px box filter, no denoising, no adaptive sampling, no clamping, light threshold 0, no
    glossy filter, no path guiding, a black world, view transform Standard;
  * KHR_lights_punctual imported in "COMPAT" units (radiant intensity = the glTF intensity, as
    dofcache reads it) as point sources (radius 0); a spot becomes a point light whose emission
    node gives glTF's cone attenuation exactly (Cycles' own spot has another curve);
  * 8-bit sRGB textures turned into linear float images, so that Cycles filters linear values
    as dofcache does;
  * emission from the front face only on one-sided (not doubleSided) glTF materials, as dofcache
    does (Cycles would otherwise emit from both faces);
  * --lambert: every Principled BSDF replaced by a Diffuse BSDF (roughness 0: Lambert) with the
    same base colour and normal, emission kept, and its alpha kept as a mix with a Transparent
    BSDF (cut-outs and blending as before): the physics of dofcache's
    `--material-override lambert`.

Writes a linear float RGB OpenEXR and prints one JSON line (starting with {"cycles_render")
with the in-render seconds (around bpy.ops.render.render) and the import seconds.
"""

import argparse
import json
import math
import os
import struct
import sys
import time

import bpy

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from peer_bench import frame_path  # noqa: E402  (standard library only, like this script)

try:  # Blender's glTF importer uses np.bool, which numpy >= 1.24 removed.
    import warnings

    import numpy

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        if getattr(numpy, "bool", None) is not bool:
            numpy.bool = bool
except ImportError:
    numpy = None


def parse_args():
    argv = sys.argv[sys.argv.index("--") + 1:] if "--" in sys.argv else []
    p = argparse.ArgumentParser(prog="cycles_render.py",
                                description="Render a glTF scene with Cycles, dofcache's lens.")
    p.add_argument("scene", help=".gltf or .glb file")
    p.add_argument("--out", required=True, help="output .exr (linear float RGB)")
    p.add_argument("--width", type=int, default=320)
    p.add_argument("--height", type=int, default=240)
    p.add_argument("--spp", type=int, default=16, help="samples per pixel")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--bounces", type=int, default=1,
                   help="max bounces (diffuse, glossy and transmission capped alike)")
    p.add_argument("--threads", type=int, default=0, help="0: all cores")
    p.add_argument("--camera", default=None, help="camera node name (default: the first)")
    p.add_argument("--focal-length", type=float, default=None, help="metres")
    p.add_argument("--fstop", type=float, default=None)
    p.add_argument("--focus-distance", type=float, default=None, help="metres, axial")
    p.add_argument("--lambert", action="store_true",
                   help="replace Principled BSDFs by Diffuse BSDFs with the same base colour")
    p.add_argument("--two-sided-emission", action="store_true",
                   help="keep Cycles' emission from both faces of one-sided materials")
    p.add_argument("--adaptive-threshold", type=float, default=None,
                   help="adaptive sampling on, with this noise threshold (Blender's default: "
                        "0.01; --spp is then the maximum); default off")
    p.add_argument("--light-threshold", type=float, default=0.0,
                   help="Cycles' light sampling threshold (Blender's default: 0.01; default 0, "
                        "every light sampled)")
    p.add_argument("--aperture-blades", type=int, default=0,
                   help="Cycles' aperture blades (0: round; 3 or more: a polygon)")
    p.add_argument("--aperture-rotation", type=float, default=0.0,
                   help="Cycles' blade rotation, degrees as Cycles counts them (the peer "
                        "benchmark maps dofcache's --aperture-rotation onto it)")
    p.add_argument("--aperture-ratio", type=float, default=1.0,
                   help="Cycles' aperture ratio (anamorphic: > 1 taller bokeh)")
    p.add_argument("--frames-json", default=None,
                   help="render a camera path as an animation in this one process: the per-frame "
                        "cameras and lenses of a `dofcache sequence --stats-json` file (--out "
                        "then holds a run of '#' for the frame number; persistent data on)")
    p.add_argument("--json-out", default=None, help="also write the JSON line to this file")
    return p.parse_args(argv)


def fail(msg):
    sys.stderr.write("cycles_render: %s\n" % msg)
    sys.stderr.flush()
    # os._exit: Blender would otherwise carry on after an exception in a --python script.
    os._exit(1)


def read_gltf_json(path):
    """The glTF JSON of a .gltf, or the JSON chunk of a .glb."""
    with open(path, "rb") as f:
        data = f.read()
    if data[:4] == b"glTF":
        _, _, _ = struct.unpack_from("<4sII", data, 0)
        length, kind = struct.unpack_from("<II", data, 12)
        if kind != 0x4E4F534A:  # 'JSON'
            raise ValueError("the first .glb chunk is not JSON")
        return json.loads(data[20:20 + length].decode("utf-8"))
    return json.loads(data.decode("utf-8"))


def gltf_camera(doc, name):
    """(node name, yfov, lens extras) of the camera dofcache would use.

    dofcache's default is the first camera met walking the default scene's node tree depth first
    (the same order Blender's importer creates them in); --camera picks one by node name.
    """
    nodes = doc.get("nodes", [])
    cams = doc.get("cameras", [])
    scenes = doc.get("scenes", [])
    order = []

    def walk(i):
        order.append(i)
        for c in nodes[i].get("children", []):
            walk(c)

    if scenes:
        for r in scenes[doc.get("scene", 0)].get("nodes", []):
            walk(r)
    else:
        order = list(range(len(nodes)))
    found = []
    for i in order:
        n = nodes[i]
        if "camera" not in n:
            continue
        cam = cams[n["camera"]]
        if cam.get("type") != "perspective":
            continue
        label = n.get("name") or cam.get("name") or "camera%d" % len(found)
        lens = {}
        for extras in (cam.get("extras"), n.get("extras")):  # the node's wins key by key
            if isinstance(extras, dict) and isinstance(extras.get("lens"), dict):
                lens.update({k: float(v) for k, v in extras["lens"].items()
                             if k in ("focal_length", "fstop", "focus_distance")})
        found.append((label, float(cam["perspective"]["yfov"]), lens))
    if not found:
        return None
    if name is None:
        return found[0]
    for f in found:
        if f[0] == name:
            return f
    fail("no perspective camera named '%s' in the scene" % name)


def socket_source(socket):
    return socket.links[0].from_socket if socket.is_linked else None


def gltf_spot_as_point_light(light, cos_inner, cos_outer):
    """A spot turned into a point light of the same radiant intensity whose emission strength is
    glTF's cone attenuation, ((cos t - cos_outer) / (cos_inner - cos_outer))^2 clamped to [0, 1],
    t the angle between the light's axis (its local -Z) and the direction to the lit point, which
    a light's shader sees as its object-space normal."""
    light.type = "POINT"
    light.use_nodes = True
    nodes, links = light.node_tree.nodes, light.node_tree.links
    emission = next(n for n in nodes if n.type == "EMISSION")
    coords = nodes.new("ShaderNodeTexCoord")
    xyz = nodes.new("ShaderNodeSeparateXYZ")
    links.new(coords.outputs["Normal"], xyz.inputs[0])
    along = nodes.new("ShaderNodeMath")  # cos t = -z
    along.operation = "MULTIPLY"
    along.inputs[1].default_value = -1.0
    links.new(xyz.outputs["Z"], along.inputs[0])
    shifted = nodes.new("ShaderNodeMath")
    shifted.operation = "SUBTRACT"
    shifted.inputs[1].default_value = cos_outer
    links.new(along.outputs[0], shifted.inputs[0])
    smooth = nodes.new("ShaderNodeMath")
    smooth.operation = "DIVIDE"
    smooth.use_clamp = True
    smooth.inputs[1].default_value = max(cos_inner - cos_outer, 1e-6)
    links.new(shifted.outputs[0], smooth.inputs[0])
    squared = nodes.new("ShaderNodeMath")
    squared.operation = "MULTIPLY"
    links.new(smooth.outputs[0], squared.inputs[0])
    links.new(smooth.outputs[0], squared.inputs[1])
    links.new(squared.outputs[0], emission.inputs["Strength"])


def srgb_textures_to_linear_float():
    """8-bit sRGB images as linear float images, so that Cycles filters linear values, as dofcache
    does (Cycles filters byte sRGB images before decoding them: darker texel edges)."""
    converted = 0
    for img in list(bpy.data.images):
        if img.source != "FILE" or img.is_float or img.colorspace_settings.name != "sRGB":
            continue
        w, h = img.size
        if w == 0 or h == 0:
            continue
        px = numpy.empty(w * h * 4, dtype=numpy.float32)
        img.pixels.foreach_get(px)  # Blender gives byte images' pixels still sRGB-encoded
        rgb = px.reshape(-1, 4)[:, :3]
        px.reshape(-1, 4)[:, :3] = numpy.where(rgb <= 0.04045, rgb / 12.92,
                                               ((rgb + 0.055) / 1.055) ** 2.4)
        lin = bpy.data.images.new(img.name + ".linear", w, h, alpha=True, float_buffer=True)
        lin.colorspace_settings.name = "Linear"
        lin.pixels.foreach_set(px)
        lin.alpha_mode = img.alpha_mode
        img.user_remap(lin)
        converted += 1
    return converted


def rewire_materials(lambert, one_sided_emission):
    """Principled -> Diffuse (with --lambert); emission moved to a front-face-only Emission node."""
    changed = {"diffuse": 0, "one_sided_emitters": 0, "emitters": 0, "alpha": 0}
    for mat in bpy.data.materials:
        if not mat.use_nodes or mat.node_tree is None:
            continue
        tree = mat.node_tree
        nodes, links = tree.nodes, tree.links
        for p in [n for n in nodes if n.type == "BSDF_PRINCIPLED"]:
            out_targets = [l.to_socket for l in p.outputs[0].links]
            shader_out = p.outputs[0]
            if lambert:
                d = nodes.new("ShaderNodeBsdfDiffuse")
                d.inputs["Roughness"].default_value = 0.0
                src = socket_source(p.inputs["Base Color"])
                if src is not None:
                    links.new(src, d.inputs["Color"])
                else:
                    d.inputs["Color"].default_value = p.inputs["Base Color"].default_value
                nsrc = socket_source(p.inputs["Normal"])
                if nsrc is not None:
                    links.new(nsrc, d.inputs["Normal"])
                shader_out = d.outputs[0]
                changed["diffuse"] += 1
            # Emission: the Principled node's own, moved to a separate Emission node.
            ecol, estr = p.inputs["Emission"], p.inputs["Emission Strength"]
            col_src, str_src = socket_source(ecol), socket_source(estr)
            col_val = tuple(ecol.default_value)
            emits = (col_src is not None or any(c > 0.0 for c in col_val[:3])) and \
                    (str_src is not None or estr.default_value > 0.0)
            if emits:
                changed["emitters"] += 1
                e = nodes.new("ShaderNodeEmission")
                if col_src is not None:
                    links.new(col_src, e.inputs["Color"])
                else:
                    e.inputs["Color"].default_value = col_val
                strength = str_src
                if one_sided_emission and mat.use_backface_culling:  # glTF doubleSided false
                    geo = nodes.new("ShaderNodeNewGeometry")
                    front = nodes.new("ShaderNodeMath")
                    front.operation = "SUBTRACT"
                    front.inputs[0].default_value = 1.0
                    links.new(geo.outputs["Backfacing"], front.inputs[1])
                    mul = nodes.new("ShaderNodeMath")
                    mul.operation = "MULTIPLY"
                    links.new(front.outputs[0], mul.inputs[0])
                    if str_src is not None:
                        links.new(str_src, mul.inputs[1])
                    else:
                        mul.inputs[1].default_value = estr.default_value
                    strength = mul.outputs[0]
                    changed["one_sided_emitters"] += 1
                if strength is not None:
                    links.new(strength, e.inputs["Strength"])
                else:
                    e.inputs["Strength"].default_value = estr.default_value
                # Take it off the Principled node so it is not counted twice.
                for l in list(ecol.links) + list(estr.links):
                    links.remove(l)
                ecol.default_value = (0.0, 0.0, 0.0, 1.0)
                estr.default_value = 0.0
                add = nodes.new("ShaderNodeAddShader")
                links.new(shader_out, add.inputs[0])
                links.new(e.outputs[0], add.inputs[1])
                shader_out = add.outputs[0]
            if lambert:
                # Alpha (cut-outs, blending): the Principled node's own mix with a transparent
                # surface, kept outside the Diffuse BSDF that replaces it, emission included.
                asrc, aval = socket_source(p.inputs["Alpha"]), p.inputs["Alpha"].default_value
                if asrc is not None or aval < 1.0:
                    mix = nodes.new("ShaderNodeMixShader")
                    if asrc is not None:
                        links.new(asrc, mix.inputs["Fac"])
                    else:
                        mix.inputs["Fac"].default_value = aval
                    links.new(nodes.new("ShaderNodeBsdfTransparent").outputs[0], mix.inputs[1])
                    links.new(shader_out, mix.inputs[2])
                    shader_out = mix.outputs[0]
                    changed["alpha"] += 1
            if shader_out is not p.outputs[0]:
                for t in out_targets:
                    links.new(shader_out, t)
            if lambert:
                nodes.remove(p)
    return changed


def read_frames(path, out):
    """The per-frame cameras of a `dofcache sequence --stats-json` file, in frame order."""
    try:
        with open(path) as f:
            rows = json.load(f)["per_frame"]
        frames = sorted(({"frame": int(r["frame"]), "camera_to_world": r["camera"]["camera_to_world"],
                          "yfov": float(r["camera"]["yfov"]), "lens": r["lens"]} for r in rows),
                        key=lambda r: r["frame"])
    except (OSError, ValueError, KeyError, TypeError) as e:
        fail("cannot read the frames' cameras from %s: %s" % (path, e))
    if not frames:
        fail("%s lists no frames" % path)
    numbers = [f["frame"] for f in frames]
    if len(set(numbers)) != len(numbers):
        fail("%s lists a frame twice" % path)
    if "#" not in os.path.basename(out):
        fail("--out needs a run of '#' for the frame number with --frames-json")
    return frames


def key_camera_path(scene, cam_obj, frames):
    """Keys the camera and its lens on every frame, held constant until the next (no in-between).

    dofcache's camera-to-world matrix is glTF's (Y up, looking down -Z, +Y up); Blender's world is
    Z up, with the same camera axes, so the camera's world matrix is the axis change times it."""
    import mathutils

    y_up_to_z_up = mathutils.Matrix(((1, 0, 0, 0), (0, 0, -1, 0), (0, 1, 0, 0), (0, 0, 0, 1)))
    cam = cam_obj.data
    cam_obj.parent = None
    cam_obj.animation_data_clear()
    cam.animation_data_clear()
    cam_obj.rotation_mode = "QUATERNION"
    cam_obj.scale = (1.0, 1.0, 1.0)
    for f in frames:
        m = f["camera_to_world"]  # column-major
        world = y_up_to_z_up @ mathutils.Matrix([[m[c * 4 + r] for c in range(4)] for r in range(4)])
        loc, rot, _ = world.decompose()
        n = f["frame"]
        cam_obj.location = loc
        cam_obj.rotation_quaternion = rot
        cam_obj.keyframe_insert("location", frame=n)
        cam_obj.keyframe_insert("rotation_quaternion", frame=n)
        lens = f["lens"]
        cam.lens = 1000.0 * float(lens["focal_length"])
        cam.sensor_height = 2.0 * cam.lens * math.tan(0.5 * f["yfov"])
        cam.dof.focus_distance = float(lens["focus_distance"])
        cam.dof.aperture_fstop = float(lens["fstop"])
        cam.keyframe_insert("lens", frame=n)
        cam.keyframe_insert("sensor_height", frame=n)
        cam.dof.keyframe_insert("focus_distance", frame=n)
        cam.dof.keyframe_insert("aperture_fstop", frame=n)
    for data in (cam_obj, cam):
        for fc in data.animation_data.action.fcurves:
            for k in fc.keyframe_points:
                k.interpolation = "CONSTANT"
    scene.frame_start, scene.frame_end, scene.frame_step = frames[0]["frame"], frames[-1]["frame"], 1


def render_animation(scene, frames, out):
    """Renders the keyed frames as a user renders an animation: one process, persistent data on
    (frames that are not consecutive, such as a reference set, one still after another).
    Returns the whole animation's seconds and each frame's in-render seconds."""
    r = scene.render
    r.use_persistent_data = True
    r.filepath = out
    r.use_file_extension = False
    times = {}

    def pre(sc, *_):
        times[sc.frame_current] = [time.perf_counter()]

    def post(sc, *_):
        times[sc.frame_current].append(time.perf_counter())

    bpy.app.handlers.render_pre.append(pre)
    bpy.app.handlers.render_post.append(post)
    numbers = [f["frame"] for f in frames]
    t0 = time.perf_counter()
    if numbers == list(range(numbers[0], numbers[0] + len(numbers))):
        bpy.ops.render.render(animation=True)
    else:
        for n in numbers:
            scene.frame_set(n)
            r.filepath = frame_path(out, n)
            bpy.ops.render.render(write_still=True)
    total = time.perf_counter() - t0
    per_frame = []
    for f in frames:
        n = f["frame"]
        path = frame_path(out, n)
        if not os.path.isfile(path):
            fail("Cycles wrote no image to %s" % path)
        t = times.get(n, [])
        per_frame.append({"frame": n, "out": path,
                          "render_seconds": t[1] - t[0] if len(t) == 2 else None})
    if any(f["render_seconds"] is None for f in per_frame):
        fail("the render handlers did not time every frame")
    return total, per_frame


def main():
    a = parse_args()
    t_start = time.perf_counter()
    if not os.path.isfile(a.scene):
        fail("scene not found: %s" % a.scene)
    for name, v in (("--width", a.width), ("--height", a.height), ("--spp", a.spp)):
        if v < 1:
            fail("%s must be at least 1" % name)
    try:
        doc = read_gltf_json(a.scene)
    except (OSError, ValueError) as e:
        fail("cannot read %s: %s" % (a.scene, e))
    cam_info = gltf_camera(doc, a.camera)
    if cam_info is None:
        fail("the scene has no perspective camera")
    cam_name, yfov, lens_extras = cam_info

    # Lens: the same defaults as dofcache (50 mm, f/4); dofcache autofocuses on the image centre
    # when the scene gives no focus distance, which this script cannot do: require one then.
    focal_length = a.focal_length or lens_extras.get("focal_length", 0.05)
    fstop = a.fstop or lens_extras.get("fstop", 4.0)
    focus = a.focus_distance or lens_extras.get("focus_distance")
    frames = read_frames(a.frames_json, a.out) if a.frames_json else None
    if frames:
        focus = frames[0]["lens"]["focus_distance"]  # every lens value is keyed per frame
    if focus is None:
        fail("the camera has no extras.lens.focus_distance; pass --focus-distance")
    if a.adaptive_threshold is not None and not a.adaptive_threshold >= 0.0:
        fail("--adaptive-threshold must be >= 0")
    if not a.light_threshold >= 0.0:
        fail("--light-threshold must be >= 0")

    if numpy is None:
        fail("numpy is not importable in Blender's Python, and the glTF importer needs it "
             "(apt-get install python3-numpy; started from a pyenv/virtualenv python3, put "
             "/usr/bin first on PATH)")
    bpy.ops.wm.read_factory_settings(use_empty=True)
    t0 = time.perf_counter()
    res = bpy.ops.import_scene.gltf(filepath=os.path.abspath(a.scene),
                                    convert_lighting_mode="COMPAT")
    import_seconds = time.perf_counter() - t0
    if "FINISHED" not in res:
        fail("the glTF importer failed on %s" % a.scene)
    scene = bpy.context.scene

    cams = [o for o in scene.objects if o.type == "CAMERA"]
    if not cams:
        fail("the importer created no camera")
    cam_obj = next((o for o in cams if o.name == cam_name), None)
    if cam_obj is None:
        cam_obj = next((o for o in cams if o.name.split(".")[0] == cam_name), cams[0])
    scene.camera = cam_obj
    cam = cam_obj.data
    lens_mm = focal_length * 1000.0
    cam.type = "PERSP"
    cam.lens_unit = "MILLIMETERS"
    cam.sensor_fit = "VERTICAL"
    cam.lens = lens_mm
    cam.sensor_height = 2.0 * lens_mm * math.tan(0.5 * yfov)
    cam.shift_x = cam.shift_y = 0.0
    cam.clip_start = 1e-5  # dofcache's lens rays are not clipped
    cam.clip_end = 1e6
    cam.dof.use_dof = True
    cam.dof.focus_object = None
    cam.dof.focus_distance = focus
    cam.dof.aperture_fstop = fstop  # Cycles: radius = lens_mm * 1e-3 / (2 fstop)
    cam.dof.aperture_blades = a.aperture_blades
    cam.dof.aperture_rotation = math.radians(a.aperture_rotation)
    cam.dof.aperture_ratio = a.aperture_ratio
    if frames:
        key_camera_path(scene, cam_obj, frames)

    # Punctual lights: point sources, as in glTF and dofcache.
    lights = []
    for o in scene.objects:
        if o.type == "LIGHT":
            o.data.shadow_soft_size = 0.0
            if o.data.type == "SUN":
                o.data.angle = 0.0
            cone = None
            if o.data.type == "SPOT":
                # glTF / dofcache: ((cos - cos_outer) / (cos_inner - cos_outer))^2, clamped to
                # [0, 1]; Cycles' spot is cos(angle to the axis) times a smoothstep, another
                # curve. So the spot becomes a point light whose emission node gives glTF's
                # (the importer's spot_blend is 1 - inner / outer).
                outer = 0.5 * o.data.spot_size
                inner = outer * (1.0 - o.data.spot_blend)
                cone = (math.cos(inner), math.cos(outer))
                gltf_spot_as_point_light(o.data, *cone)
            lights.append({"name": o.name, "type": o.data.type, "energy": o.data.energy,
                           "radiant_intensity": o.data.energy / (4.0 * math.pi)
                           if o.data.type in ("POINT", "SPOT") else None,
                           "gltf_spot_cos_inner_outer": cone})

    materials = rewire_materials(a.lambert, not a.two_sided_emission)
    materials["srgb_textures_as_linear_float"] = srgb_textures_to_linear_float()

    # World: black.
    world = bpy.data.worlds.new("black")
    world.use_nodes = True
    bg = world.node_tree.nodes.get("Background")
    if bg is not None:
        bg.inputs["Color"].default_value = (0.0, 0.0, 0.0, 1.0)
        bg.inputs["Strength"].default_value = 0.0
    scene.world = world

    r = scene.render
    r.engine = "CYCLES"
    r.resolution_x, r.resolution_y = a.width, a.height
    r.resolution_percentage = 100
    r.pixel_aspect_x = r.pixel_aspect_y = 1.0
    r.use_border = False
    r.film_transparent = False
    r.use_motion_blur = False
    r.threads_mode = "FIXED" if a.threads > 0 else "AUTO"
    if a.threads > 0:
        r.threads = a.threads
    c = scene.cycles
    c.device = "CPU"
    c.feature_set = "SUPPORTED"
    c.samples = a.spp
    c.use_adaptive_sampling = a.adaptive_threshold is not None
    if c.use_adaptive_sampling:  # as a user leaves it: min samples automatic
        c.adaptive_threshold = a.adaptive_threshold
        c.adaptive_min_samples = 0
    c.use_denoising = False
    if hasattr(c, "use_preview_denoising"):
        c.use_preview_denoising = False
    c.seed = a.seed
    c.use_animated_seed = False
    c.pixel_filter_type = "BOX"
    c.filter_width = 1.0
    c.max_bounces = a.bounces
    c.diffuse_bounces = a.bounces
    c.glossy_bounces = a.bounces
    c.transmission_bounces = a.bounces
    c.volume_bounces = 0
    c.sample_clamp_direct = 0.0
    c.sample_clamp_indirect = 0.0
    c.light_sampling_threshold = a.light_threshold
    c.blur_glossy = 0.0
    c.time_limit = 0.0
    for attr in ("use_guiding", "use_surface_guiding", "use_volume_guiding"):
        if hasattr(c, attr):
            setattr(c, attr, False)
    vs = scene.view_settings
    vs.view_transform = "Standard"
    vs.look = "None"
    vs.exposure = 0.0
    vs.gamma = 1.0
    vs.use_curve_mapping = False
    im = r.image_settings
    im.file_format = "OPEN_EXR"
    im.color_mode = "RGB"
    im.color_depth = "32"
    im.exr_codec = "ZIP"

    out = os.path.abspath(a.out)
    os.makedirs(os.path.dirname(out), exist_ok=True)
    per_frame = None
    if frames:
        render_seconds, per_frame = render_animation(scene, frames, out)
    else:
        t0 = time.perf_counter()
        bpy.ops.render.render()
        render_seconds = time.perf_counter() - t0
        bpy.data.images["Render Result"].save_render(out, scene=scene)
        if not os.path.isfile(out):
            fail("Cycles wrote no image to %s" % out)

    principled = []
    for mat in bpy.data.materials:
        if mat.use_nodes and mat.node_tree:
            for n in mat.node_tree.nodes:
                if n.type == "BSDF_PRINCIPLED":
                    principled.append(n.distribution)
    result = {
        "cycles_render": 1,
        "blender_version": bpy.app.version_string,
        "scene": a.scene, "out": out, "width": a.width, "height": a.height, "spp": a.spp,
        "seed": a.seed, "bounces": a.bounces, "threads": r.threads,
        "render_seconds": render_seconds, "import_seconds": import_seconds,
        "script_seconds": time.perf_counter() - t_start,
        "camera": cam_obj.name,
        "lens": {"focal_length": focal_length, "fstop": fstop, "focus_distance": focus,
                 "aperture_radius": focal_length / (2.0 * fstop), "yfov": yfov,
                 "sensor_height_mm": cam.sensor_height},
        "materials": {"lambert": a.lambert, "principled_distributions": sorted(set(principled)),
                      **materials},
        "lights": lights,
        "adaptive_threshold": a.adaptive_threshold, "light_threshold": a.light_threshold,
    }
    if per_frame is not None:
        result["frames"] = per_frame
        result["render_seconds_sum"] = sum(f["render_seconds"] for f in per_frame)
    line = json.dumps(result)
    if a.json_out:
        with open(a.json_out + ".tmp", "w") as f:
            f.write(line + "\n")
        os.replace(a.json_out + ".tmp", a.json_out)
    sys.stdout.write(line + "\n")
    sys.stdout.flush()


try:
    main()
except SystemExit as e:  # argparse errors and --help
    sys.stdout.flush()
    sys.stderr.flush()
    os._exit(e.code if isinstance(e.code, int) else 1)
except Exception as e:  # noqa: BLE001 - one line, non-zero status
    fail("%s: %s" % (type(e).__name__, e))
