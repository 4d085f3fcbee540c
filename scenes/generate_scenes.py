#!/usr/bin/env python3
"""Writes the shipped glTF 2.0 scenes next to this file (python3 standard library only).

    python3 scenes/generate_scenes.py

Every scene is in metres at tabletop scale, lit by emissive quads (KHR_materials_emissive_strength),
and has one perspective camera whose node carries `extras.lens` (focal_length, fstop,
focus_distance; see docs/scenes.md). For each scene the script prints the circle of confusion of
every object at a 480-pixel image height (paper eq. 2.4), and, for the two occlusion scenes, checks
by ray casting that the hidden object is invisible from the pinhole but visible from the lens edge.

Outputs:
  cornell_box.gltf                   self-contained (base64 data-URI buffer); the built-in default
  color_bars.gltf + color_bars.bin   external buffer, interleaved vertex data (byteStride)
  color_spheres.gltf                 self-contained; one KHR_lights_punctual spot light
  glossy_closeup.glb                 binary glTF with embedded PNG textures
  hanging_light_box.gltf             self-contained; a two-sided panel 2 cm below the ceiling, f/0.2
  lamp_corner.gltf                   self-contained; a small bright lamp 4 cm from a wall over a
                                     glossy floor (fireflies)
  gallery.glb                        a 12 m gallery to walk through (scenes/paths/gallery_walk.json):
                                     columns, pedestals with objects, a tiled floor texture, ceiling
                                     panels 5 cm below the ceiling, a lit doorway; 50 mm f/0.7
"""
import base64
import json
import math
import os
import struct

import gltf_files  # scenes/gltf_files.py, beside this script

HERE = os.path.dirname(os.path.abspath(__file__))
Y_RES = 480  # image height the CoC tables are computed for

# --------------------------------------------------------------------------------------------
# Small vector helpers (tuples of floats)


def add(a, b):
    return (a[0] + b[0], a[1] + b[1], a[2] + b[2])


def sub(a, b):
    return (a[0] - b[0], a[1] - b[1], a[2] - b[2])


def mul(a, s):
    return (a[0] * s, a[1] * s, a[2] * s)


def dot(a, b):
    return a[0] * b[0] + a[1] * b[1] + a[2] * b[2]


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def length(a):
    return math.sqrt(dot(a, a))


def normalize(a):
    n = length(a)
    return (a[0] / n, a[1] / n, a[2] / n)


# 3x3 matrices as tuples of rows.
def mat_vec(m, v):
    return tuple(m[i][0] * v[0] + m[i][1] * v[1] + m[i][2] * v[2] for i in range(3))


def rot_y(angle):
    c, s = math.cos(angle), math.sin(angle)
    return ((c, 0.0, s), (0.0, 1.0, 0.0), (-s, 0.0, c))


def rot_x(angle):
    c, s = math.cos(angle), math.sin(angle)
    return ((1.0, 0.0, 0.0), (0.0, c, -s), (0.0, s, c))


def turn_y_to(d):
    """Rotation (rows) taking +Y to the direction d."""
    y = normalize(d)
    helper = (0.0, 0.0, 1.0) if abs(y[2]) < 0.9 else (1.0, 0.0, 0.0)
    x = normalize(cross(y, helper))
    z = cross(x, y)
    return ((x[0], y[0], z[0]), (x[1], y[1], z[1]), (x[2], y[2], z[2]))


def quat_from_matrix(m):
    """Unit quaternion (x, y, z, w) of a rotation matrix given as rows."""
    tr = m[0][0] + m[1][1] + m[2][2]
    if tr > 0.0:
        s = math.sqrt(tr + 1.0) * 2.0
        q = ((m[2][1] - m[1][2]) / s, (m[0][2] - m[2][0]) / s, (m[1][0] - m[0][1]) / s, 0.25 * s)
    elif m[0][0] > m[1][1] and m[0][0] > m[2][2]:
        s = math.sqrt(1.0 + m[0][0] - m[1][1] - m[2][2]) * 2.0
        q = (0.25 * s, (m[0][1] + m[1][0]) / s, (m[0][2] + m[2][0]) / s, (m[2][1] - m[1][2]) / s)
    elif m[1][1] > m[2][2]:
        s = math.sqrt(1.0 + m[1][1] - m[0][0] - m[2][2]) * 2.0
        q = ((m[0][1] + m[1][0]) / s, 0.25 * s, (m[1][2] + m[2][1]) / s, (m[0][2] - m[2][0]) / s)
    else:
        s = math.sqrt(1.0 + m[2][2] - m[0][0] - m[1][1]) * 2.0
        q = ((m[0][2] + m[2][0]) / s, (m[1][2] + m[2][1]) / s, 0.25 * s, (m[1][0] - m[0][1]) / s)
    n = math.sqrt(sum(c * c for c in q))
    return tuple(c / n for c in q)


def quat_to_matrix(q):
    x, y, z, w = q
    return ((1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)),
            (2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)),
            (2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)))


def look_at(eye, target, up=(0.0, 1.0, 0.0)):
    """Rotation (rows) of a glTF camera at `eye` looking at `target` (camera looks down -Z)."""
    z = normalize(sub(eye, target))
    x = normalize(cross(up, z))
    y = cross(z, x)
    return ((x[0], y[0], z[0]), (x[1], y[1], z[1]), (x[2], y[2], z[2]))


# --------------------------------------------------------------------------------------------
# Geometry. Each generator returns a Geometry in local space; nodes place it with TRS.


class Geometry:
    def __init__(self, positions, normals, uvs, triangles):
        self.positions, self.normals, self.uvs, self.triangles = positions, normals, uvs, triangles
        self.check()

    def check(self):
        """Every triangle has positive area and is wound counter-clockwise seen from the side its
        vertex normals point to (glTF front faces)."""
        for t in self.triangles:
            p0, p1, p2 = (self.positions[i] for i in t)
            n = cross(sub(p1, p0), sub(p2, p0))
            assert length(n) > 1e-12, "degenerate triangle %s" % (t,)
            avg = add(add(self.normals[t[0]], self.normals[t[1]]), self.normals[t[2]])
            assert dot(n, avg) > 0.0, "triangle %s wound against its normals" % (t,)


def quad():
    """Unit square in the XZ plane, facing +Y."""
    p = [(-0.5, 0.0, 0.5), (0.5, 0.0, 0.5), (0.5, 0.0, -0.5), (-0.5, 0.0, -0.5)]
    uv = [(0.0, 1.0), (1.0, 1.0), (1.0, 0.0), (0.0, 0.0)]
    return Geometry(p, [(0.0, 1.0, 0.0)] * 4, uv, [(0, 1, 2), (0, 2, 3)])


def box():
    """Unit cube centred at the origin, one flat-shaded quad per face."""
    positions, normals, uvs, tris = [], [], [], []
    for axis in range(3):
        for sign in (1.0, -1.0):
            n = [0.0, 0.0, 0.0]
            n[axis] = sign
            u_axis, v_axis = (axis + 1) % 3, (axis + 2) % 3
            base = len(positions)
            for du, dv in ((-0.5, -0.5), (0.5, -0.5), (0.5, 0.5), (-0.5, 0.5)):
                p = [0.0, 0.0, 0.0]
                p[axis] = 0.5 * sign
                p[u_axis] = du
                p[v_axis] = dv
                positions.append(tuple(p))
                normals.append(tuple(n))
                uvs.append((du + 0.5, 0.5 - dv))
            # (u, v, n) is right-handed, so this order is counter-clockwise seen from +n; flip for -n.
            if sign > 0:
                tris += [(base, base + 1, base + 2), (base, base + 2, base + 3)]
            else:
                tris += [(base, base + 2, base + 1), (base, base + 3, base + 2)]
    return Geometry(positions, normals, uvs, tris)


def uv_sphere(n_lon=48, n_lat=24):
    """Unit sphere with smooth normals; the poles are single triangles, so nothing degenerates."""
    positions, normals, uvs, tris = [], [], [], []
    rings = []  # vertex index of (ring i, column j); ring 0 and n_lat are the poles
    for i in range(n_lat + 1):
        theta = math.pi * i / n_lat
        ring = []
        columns = n_lon if i in (0, n_lat) else n_lon + 1  # one pole vertex per column for uvs
        for j in range(columns):
            u = (j + 0.5) / n_lon if i in (0, n_lat) else j / n_lon
            phi = 2.0 * math.pi * u
            p = (math.sin(theta) * math.cos(phi), math.cos(theta), -math.sin(theta) * math.sin(phi))
            ring.append(len(positions))
            positions.append(p)
            normals.append(p)
            uvs.append((u, i / n_lat))
        rings.append(ring)
    for i in range(n_lat):
        for j in range(n_lon):
            if i == 0:
                tris.append((rings[0][j], rings[1][j], rings[1][j + 1]))
            elif i == n_lat - 1:
                tris.append((rings[i][j], rings[i + 1][j], rings[i][j + 1]))
            else:
                a, b = rings[i][j], rings[i][j + 1]
                c, d = rings[i + 1][j], rings[i + 1][j + 1]
                tris += [(a, c, d), (a, d, b)]
    return Geometry(positions, normals, uvs, tris)


def lathe(profile, segments, u_repeat=1.0):
    """Surface of revolution about +Y of a smooth profile [(radius, height), ...] (radius > 0).
    Normals come from the profile tangent, so they point right of the direction of travel: a
    profile going up faces outwards, one coming down (an inner wall) faces the axis."""
    count = len(profile)
    arc = [0.0]
    for k in range(1, count):
        arc.append(arc[-1] + math.hypot(profile[k][0] - profile[k - 1][0],
                                        profile[k][1] - profile[k - 1][1]))
    positions, normals, uvs, tris = [], [], [], []
    for k, (r, y) in enumerate(profile):
        a, b = profile[max(k - 1, 0)], profile[min(k + 1, count - 1)]
        tr, ty = b[0] - a[0], b[1] - a[1]
        nr, ny = ty, -tr
        nl = math.hypot(nr, ny)
        nr, ny = nr / nl, ny / nl
        for j in range(segments + 1):
            phi = 2.0 * math.pi * j / segments
            c, s = math.cos(phi), -math.sin(phi)
            positions.append((r * c, y, r * s))
            normals.append((nr * c, ny, nr * s))
            uvs.append((u_repeat * j / segments, 1.0 - arc[k] / arc[-1]))
    for k in range(count - 1):
        for j in range(segments):
            a = k * (segments + 1) + j
            b, c, d = a + 1, a + segments + 1, a + segments + 2
            tris += [(a, b, d), (a, d, c)]
    return Geometry(positions, normals, uvs, tris)


def disc(radius, y, up, segments):
    """Flat disc at height y facing +Y (up) or -Y."""
    positions = [(0.0, y, 0.0)]
    for j in range(segments):
        phi = 2.0 * math.pi * j / segments
        positions.append((radius * math.cos(phi), y, -radius * math.sin(phi)))
    n = (0.0, 1.0 if up else -1.0, 0.0)
    uvs = [(0.5 + p[0] / (2 * radius), 0.5 + p[2] / (2 * radius)) for p in positions]
    tris = []
    for j in range(segments):
        a, b = 1 + j, 1 + (j + 1) % segments
        tris.append((0, a, b) if up else (0, b, a))
    return Geometry(positions, [n] * len(positions), uvs, tris)


def merge(*parts):
    positions, normals, uvs, tris = [], [], [], []
    for g in parts:
        base = len(positions)
        positions += g.positions
        normals += g.normals
        uvs += g.uvs
        tris += [(a + base, b + base, c + base) for a, b, c in g.triangles]
    return Geometry(positions, normals, uvs, tris)


def tiled_quad(u_repeat, v_repeat):
    """quad() with its texture coordinates repeated (the sampler wraps)."""
    q = quad()
    return Geometry(q.positions, q.normals, [(u * u_repeat, v * v_repeat) for u, v in q.uvs],
                    q.triangles)


def cylinder(segments=40):
    """Radius 1, from y = 0 to y = 1, smooth side and flat caps."""
    side = lathe([(1.0, 0.0), (1.0, 1.0)], segments)
    return merge(side, disc(1.0, 1.0, True, segments), disc(1.0, 0.0, False, segments))


def torus(major, minor, n_major=64, n_minor=24):
    """Torus about +Y (lying flat), smooth normals."""
    positions, normals, uvs, tris = [], [], [], []
    for i in range(n_major + 1):
        phi = 2.0 * math.pi * i / n_major
        cp, sp = math.cos(phi), -math.sin(phi)
        for j in range(n_minor + 1):
            theta = 2.0 * math.pi * j / n_minor
            ct, st = math.cos(theta), math.sin(theta)
            n = (ct * cp, st, ct * sp)
            positions.append(((major + minor * ct) * cp, minor * st, (major + minor * ct) * sp))
            normals.append(n)
            uvs.append((2.0 * i / n_major, j / n_minor))
    for i in range(n_major):
        for j in range(n_minor):
            a = i * (n_minor + 1) + j
            b, c, d = a + 1, a + n_minor + 1, a + n_minor + 2
            tris += [(a, c, d), (a, d, b)]
    return Geometry(positions, normals, uvs, tris)


def vase_profile():
    """Outer wall up, a rounded lip, inner wall down: one smooth profile (radius, height)."""
    height, thickness = 0.20, 0.006

    def outer_radius(t):  # t in [0, 1] from foot to rim: a belly, a neck, a flared rim
        return 0.034 + 0.026 * math.sin(math.pi * min(t / 0.75, 1.0)) ** 1.5 \
            - 0.012 * math.sin(math.pi * t) ** 8 + 0.010 * max(t - 0.78, 0.0) / 0.22

    outer = [(outer_radius(k / 40.0), 0.002 + (height - 0.002) * k / 40.0) for k in range(41)]
    r_rim, y_rim = outer[-1]
    lip = []
    for k in range(1, 8):  # half circle over the rim, from the outer to the inner wall
        a = math.pi * k / 8.0
        lip.append((r_rim - 0.5 * thickness + 0.5 * thickness * math.cos(a),
                    y_rim + 0.5 * thickness * math.sin(a)))
    inner = [(r - thickness, y) for r, y in reversed(outer) if y > thickness + 0.004]
    return outer + lip + inner, thickness


def vase(segments=64):
    profile, thickness = vase_profile()
    body = lathe(profile, segments, u_repeat=2.0)
    foot_r = profile[0][0]
    inner_floor_y = profile[-1][1]
    inner_floor_r = profile[-1][0]
    # A short vertical skirt from the foot to the table, the base, and the inner floor.
    skirt = lathe([(foot_r, 0.0), (foot_r, profile[0][1])], segments)
    return merge(body, skirt, disc(foot_r, 0.0, False, segments),
                 disc(inner_floor_r, inner_floor_y, True, segments))


# --------------------------------------------------------------------------------------------
# PNG writer (8-bit RGB), zlib + struct only.


def png_bytes(width, height, pixel):
    """pixel(x, y) -> (r, g, b) bytes; row 0 is the top."""
    return gltf_files.png(width, height, pixel, alpha=False, level=9)


# --------------------------------------------------------------------------------------------
# glTF builder


GL_FLOAT, GL_UNSIGNED_SHORT, GL_UNSIGNED_INT = 5126, 5123, 5125
ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER = 34962, 34963


def r6(x):
    return round(x, 6) + 0.0  # + 0.0 turns -0.0 into 0.0


class SceneObject:
    """A placed mesh, kept for the CoC table and the visibility checks."""

    def __init__(self, name, geometry, matrix, translation, scale):
        self.name = name
        self.world = []
        for p in geometry.positions:
            q = mat_vec(matrix, (p[0] * scale[0], p[1] * scale[1], p[2] * scale[2]))
            self.world.append(add(q, translation))
        self.triangles = geometry.triangles
        self.lower = tuple(min(p[i] for p in self.world) for i in range(3))
        self.upper = tuple(max(p[i] for p in self.world) for i in range(3))


class Gltf:
    def __init__(self, name):
        self.name = name
        self.doc = {
            "asset": {"version": "2.0", "generator": "dofcache scenes/generate_scenes.py"},
            "scene": 0,
            "scenes": [{"name": name, "nodes": []}],
            "nodes": [], "meshes": [], "materials": [], "accessors": [], "bufferViews": [],
            "buffers": [],
        }
        self.bin = bytearray()
        self.geometry_cache = {}
        self.objects = []
        self.extensions = set()
        self.camera = None

    # -- buffers
    def _view(self, data, target=None, stride=None):
        while len(self.bin) % 4:
            self.bin.append(0)
        view = {"buffer": 0, "byteOffset": len(self.bin), "byteLength": len(data)}
        if target:
            view["target"] = target
        if stride:
            view["byteStride"] = stride
        self.bin += data
        self.doc["bufferViews"].append(view)
        return len(self.doc["bufferViews"]) - 1

    def _accessor(self, view, offset, component, count, kind, lo=None, hi=None):
        acc = {"bufferView": view, "componentType": component, "count": count, "type": kind}
        if offset:
            acc["byteOffset"] = offset
        if lo is not None:
            acc["min"], acc["max"] = [r6(v) for v in lo], [r6(v) for v in hi]
        self.doc["accessors"].append(acc)
        return len(self.doc["accessors"]) - 1

    def geometry(self, geom, index_type=GL_UNSIGNED_SHORT, interleaved=False, uvs=True):
        """Writes a geometry's vertex and index data once; returns the primitive attributes."""
        key = id(geom)
        if key in self.geometry_cache:
            return self.geometry_cache[key]
        n = len(geom.positions)
        f32 = [struct.unpack("<f", struct.pack("<f", c))[0] for p in geom.positions for c in p]
        lo = [min(f32[i::3]) for i in range(3)]
        hi = [max(f32[i::3]) for i in range(3)]
        attrs = {}
        if interleaved:  # POSITION and NORMAL in one bufferView, byteStride 24
            data = b"".join(struct.pack("<6f", *p, *q) for p, q in zip(geom.positions, geom.normals))
            view = self._view(data, ARRAY_BUFFER, 24)
            attrs["POSITION"] = self._accessor(view, 0, GL_FLOAT, n, "VEC3", lo, hi)
            attrs["NORMAL"] = self._accessor(view, 12, GL_FLOAT, n, "VEC3")
        else:
            view = self._view(b"".join(struct.pack("<3f", *p) for p in geom.positions), ARRAY_BUFFER)
            attrs["POSITION"] = self._accessor(view, 0, GL_FLOAT, n, "VEC3", lo, hi)
            view = self._view(b"".join(struct.pack("<3f", *q) for q in geom.normals), ARRAY_BUFFER)
            attrs["NORMAL"] = self._accessor(view, 0, GL_FLOAT, n, "VEC3")
        if uvs:
            view = self._view(b"".join(struct.pack("<2f", *t) for t in geom.uvs), ARRAY_BUFFER)
            attrs["TEXCOORD_0"] = self._accessor(view, 0, GL_FLOAT, n, "VEC2")
        if index_type == GL_UNSIGNED_SHORT:
            assert n < 65536
            data = b"".join(struct.pack("<3H", *t) for t in geom.triangles)
        else:
            data = b"".join(struct.pack("<3I", *t) for t in geom.triangles)
        view = self._view(data, ELEMENT_ARRAY_BUFFER)
        indices = self._accessor(view, 0, index_type, 3 * len(geom.triangles), "SCALAR")
        self.geometry_cache[key] = (attrs, indices)
        return attrs, indices

    # -- materials and textures
    def material(self, name, base, metallic=0.0, roughness=1.0, emissive=None, strength=1.0,
                 double_sided=False, base_texture=None, mr_texture=None):
        pbr = {"baseColorFactor": [r6(c) for c in base] + [1.0], "metallicFactor": metallic,
               "roughnessFactor": roughness}
        if base_texture is not None:
            pbr["baseColorTexture"] = {"index": base_texture}
        if mr_texture is not None:
            pbr["metallicRoughnessTexture"] = {"index": mr_texture}
        mat = {"name": name, "pbrMetallicRoughness": pbr}
        if emissive:
            mat["emissiveFactor"] = [r6(c) for c in emissive]
            if strength != 1.0:
                mat["extensions"] = {"KHR_materials_emissive_strength": {"emissiveStrength": strength}}
                self.extensions.add("KHR_materials_emissive_strength")
        if double_sided:
            mat["doubleSided"] = True
        self.doc["materials"].append(mat)
        return len(self.doc["materials"]) - 1

    def texture(self, png, name):
        """A PNG stored in a bufferView (binary glTF), repeat-wrapped, trilinear."""
        view = self._view(png)
        self.doc.setdefault("images", []).append({"name": name, "bufferView": view,
                                                  "mimeType": "image/png"})
        if "samplers" not in self.doc:
            self.doc["samplers"] = [{"magFilter": 9729, "minFilter": 9987, "wrapS": 10497,
                                     "wrapT": 10497}]
        self.doc.setdefault("textures", []).append(
            {"name": name, "sampler": 0, "source": len(self.doc["images"]) - 1})
        return len(self.doc["textures"]) - 1

    # -- nodes
    def add(self, name, geom, material, translation=(0.0, 0.0, 0.0), rotation=None,
            scale=(1.0, 1.0, 1.0), parent=None, **geometry_options):
        """One mesh instance. `rotation` is a 3x3 matrix (rows); the node stores a quaternion.
        With `parent` (a node index with a pure translation) the node becomes its child."""
        attrs, indices = self.geometry(geom, **geometry_options)
        self.doc["meshes"].append({"name": name, "primitives": [
            {"attributes": attrs, "indices": indices, "material": material, "mode": 4}]})
        node = {"name": name, "mesh": len(self.doc["meshes"]) - 1}
        matrix = rotation or ((1.0, 0.0, 0.0), (0.0, 1.0, 0.0), (0.0, 0.0, 1.0))
        if any(abs(t) > 0 for t in translation):
            node["translation"] = [r6(t) for t in translation]
        if rotation is not None:
            node["rotation"] = [r6(q) for q in quat_from_matrix(rotation)]
            matrix = quat_to_matrix(node["rotation"])
        if scale != (1.0, 1.0, 1.0):
            node["scale"] = [r6(s) for s in scale]
        world_translation = tuple(r6(t) for t in translation)
        if parent is not None:
            parent_translation = tuple(self.doc["nodes"][parent]["translation"])
            world_translation = add(world_translation, parent_translation)
        self.objects.append(SceneObject(name, geom, matrix, world_translation,
                                        tuple(r6(s) for s in scale)))
        return self._node(node, parent)

    def group(self, name, translation):
        return self._node({"name": name, "translation": [r6(t) for t in translation]}, None)

    def _node(self, node, parent):
        self.doc["nodes"].append(node)
        index = len(self.doc["nodes"]) - 1
        if parent is None:
            self.doc["scenes"][0]["nodes"].append(index)
        else:
            self.doc["nodes"][parent].setdefault("children", []).append(index)
        return index

    def light_quad(self, name, material, center, size, target):
        """An emissive rectangle at `center` shining towards `target` (one-sided)."""
        return self.add(name, quad(), material, center, turn_y_to(sub(target, center)),
                        (size[0], 1.0, size[1]))

    def spot_light(self, name, position, target, color, intensity, inner, outer):
        self.extensions.add("KHR_lights_punctual")
        lights = self.doc.setdefault("extensions", {}).setdefault("KHR_lights_punctual",
                                                                   {"lights": []})["lights"]
        lights.append({"name": name, "type": "spot", "color": list(color), "intensity": intensity,
                       "spot": {"innerConeAngle": inner, "outerConeAngle": outer}})
        node = {"name": name, "translation": [r6(p) for p in position],
                "rotation": [r6(q) for q in quat_from_matrix(look_at(position, target, (0, 0, -1)))],
                "extensions": {"KHR_lights_punctual": {"light": len(lights) - 1}}}
        return self._node(node, None)

    def add_camera(self, eye, target, yfov, focal_length, fstop, focus_object):
        rotation = look_at(eye, target)
        forward = normalize(sub(target, eye))
        focus = self.object(focus_object)
        center = mul(add(focus.lower, focus.upper), 0.5)
        focus_distance = r6(dot(sub(center, eye), forward))
        self.doc["cameras"] = [{"name": "camera", "type": "perspective", "perspective": {
            "yfov": yfov, "aspectRatio": r6(4.0 / 3.0), "znear": 0.01, "zfar": 100.0}}]
        self._node({"name": "camera", "camera": 0, "translation": [r6(e) for e in eye],
                    "rotation": [r6(q) for q in quat_from_matrix(rotation)],
                    "extras": {"lens": {"focal_length": focal_length, "fstop": fstop,
                                        "focus_distance": focus_distance}}}, None)
        self.camera = {"eye": eye, "forward": forward,
                       "right": (rotation[0][0], rotation[1][0], rotation[2][0]),
                       "up": (rotation[0][1], rotation[1][1], rotation[2][1]), "yfov": yfov,
                       "F": focal_length, "n": fstop, "P": focus_distance, "focus": focus_object}

    def object(self, name):
        return next(o for o in self.objects if o.name == name)

    # -- output
    def finish(self):
        if self.extensions:
            self.doc["extensionsUsed"] = sorted(self.extensions)
        triangles = sum(len(o.triangles) for o in self.objects)
        assert triangles < 30000, triangles
        return triangles

    def write_gltf_embedded(self, path):
        self.finish()
        uri = "data:application/octet-stream;base64," + base64.b64encode(bytes(self.bin)).decode()
        self.doc["buffers"] = [{"byteLength": len(self.bin), "uri": uri}]
        with open(path, "w", encoding="utf-8") as f:
            json.dump(self.doc, f, indent=1)
            f.write("\n")

    def write_gltf_external(self, path):
        self.finish()
        bin_name = os.path.splitext(os.path.basename(path))[0] + ".bin"
        self.doc["buffers"] = [{"byteLength": len(self.bin), "uri": bin_name}]
        with open(os.path.join(os.path.dirname(path), bin_name), "wb") as f:
            f.write(self.bin)
        with open(path, "w", encoding="utf-8") as f:
            json.dump(self.doc, f, indent=1)
            f.write("\n")

    def write_glb(self, path):
        self.finish()
        gltf_files.write_glb(path, self.doc, self.bin)


# --------------------------------------------------------------------------------------------
# Optics (paper section 2) and the checks


def coc_pixels(cam, depth):
    """Signed CoC diameter in pixels at a 480-pixel image height: eq. (2.4) written as
    C = A V_P |D - P| / (D P) with A = F / n, V_P = F P / (P - F), divided by the pixel pitch
    i_height / y_res, where i_height = 2 V_P tan(yfov / 2). Negative in front of the focal plane."""
    F, n, P = cam["F"], cam["n"], cam["P"]
    A = F / n
    v_p = F * P / (P - F)
    c = A * v_p * abs(depth - P) / (depth * P)
    pitch = 2.0 * v_p * math.tan(0.5 * cam["yfov"]) / Y_RES
    return math.copysign(c / pitch, depth - P)


def clip_polygon(poly, plane):
    """Sutherland-Hodgman: the part of a convex polygon where plane(p) >= 0."""
    out = []
    for k, p in enumerate(poly):
        q = poly[(k + 1) % len(poly)]
        fp, fq = plane(p), plane(q)
        if fp >= 0.0:
            out.append(p)
        if (fp >= 0.0) != (fq >= 0.0):
            t = fp / (fp - fq)
            out.append(tuple(a + t * (b - a) for a, b in zip(p, q)))
    return out


def coc_table(g):
    """Depth range of each object's part inside the view frustum (occlusion ignored) and the
    signed CoC at both ends."""
    cam = g.camera
    ty = math.tan(0.5 * cam["yfov"])
    tx = ty * 4.0 / 3.0
    planes = [lambda p: p[2] - 0.01, lambda p: tx * p[2] - p[0], lambda p: tx * p[2] + p[0],
              lambda p: ty * p[2] - p[1], lambda p: ty * p[2] + p[1]]
    rows = []
    for o in g.objects:
        # Camera space: (right, up, depth along the optical axis).
        local = [(dot(sub(p, cam["eye"]), cam["right"]), dot(sub(p, cam["eye"]), cam["up"]),
                  dot(sub(p, cam["eye"]), cam["forward"])) for p in o.world]
        depths = []
        for t in o.triangles:
            poly = [local[i] for i in t]
            for plane in planes:
                poly = clip_polygon(poly, plane) if poly else poly
            depths += [p[2] for p in poly]
        if not depths:
            continue  # outside the frame
        lo, hi = min(depths), max(depths)
        rows.append((o.name, lo, hi, coc_pixels(cam, lo), coc_pixels(cam, hi)))
    return rows


def ray_hits_triangle(origin, direction, p0, p1, p2, t_max):
    """Moller-Trumbore; True if the ray hits the triangle at 1e-6 < t < t_max."""
    e1, e2 = sub(p1, p0), sub(p2, p0)
    h = cross(direction, e2)
    a = dot(e1, h)
    if abs(a) < 1e-14:
        return False
    f = 1.0 / a
    s = sub(origin, p0)
    u = f * dot(s, h)
    if u < 0.0 or u > 1.0:
        return False
    q = cross(s, e1)
    v = f * dot(direction, q)
    if v < 0.0 or u + v > 1.0:
        return False
    t = f * dot(e2, q)
    return 1e-6 < t < t_max


def ray_hits_box(origin, direction, lower, upper, t_max):
    t0, t1 = 0.0, t_max
    for i in range(3):
        if abs(direction[i]) < 1e-15:
            if origin[i] < lower[i] or origin[i] > upper[i]:
                return False
            continue
        a = (lower[i] - origin[i]) / direction[i]
        b = (upper[i] - origin[i]) / direction[i]
        t0, t1 = max(t0, min(a, b)), min(t1, max(a, b))
        if t0 > t1:
            return False
    return True


def visible(g, target, point, eye):
    """Is `point` (on object `target`, facing the eye) unobstructed from `eye`?"""
    d = sub(point, eye)
    for o in g.objects:
        if o is target or not ray_hits_box(eye, d, o.lower, o.upper, 1.0):
            continue
        for t in o.triangles:
            if ray_hits_triangle(eye, d, o.world[t[0]], o.world[t[1]], o.world[t[2]], 1.0 - 1e-6):
                return False
    return True


def occlusion_check(g, hidden_name):
    """The hidden object must be invisible from the pinhole yet seen from part of the lens."""
    cam = g.camera
    hidden = g.object(hidden_name)
    eye = cam["eye"]
    # Sample points: triangle centroids and vertices facing the lens centre.
    points = []
    for t in hidden.triangles:
        p0, p1, p2 = (hidden.world[i] for i in t)
        n = cross(sub(p1, p0), sub(p2, p0))
        if dot(n, sub(eye, p0)) <= 0.0:
            continue
        points += [mul(add(add(p0, p1), p2), 1.0 / 3.0), p0, p1, p2]
    assert not any(visible(g, hidden, p, eye) for p in points), \
        "%s is visible from the pinhole" % hidden_name
    radius = 0.5 * cam["F"] / cam["n"]
    lens_points = []
    for ring in (0.5, 0.75, 1.0):
        for k in range(24):
            a = 2.0 * math.pi * k / 24
            offset = add(mul(cam["right"], ring * radius * math.cos(a)),
                         mul(cam["up"], ring * radius * math.sin(a)))
            lens_points.append(add(eye, offset))
    seen = sum(1 for lp in lens_points if any(visible(g, hidden, p, lp) for p in points[::2]))
    assert seen > 0, "%s is not visible from any lens point" % hidden_name
    return seen / len(lens_points)


def report(g, triangles, extra=""):
    cam = g.camera
    print("%s: %d triangles, camera F = %.0f mm f/%g, focus %.3f m on '%s', yfov %.3f rad" %
          (g.name, triangles, cam["F"] * 1000, cam["n"], cam["P"], cam["focus"], cam["yfov"]))
    for name, lo, hi, c_lo, c_hi in coc_table(g):
        print("  %-16s depth %.3f..%.3f m  CoC %+6.1f..%+6.1f px" % (name, lo, hi, c_lo, c_hi))
    if extra:
        print("  " + extra)


# --------------------------------------------------------------------------------------------
# The scenes


def cornell_box():
    g = Gltf("cornell_box")
    white = g.material("white", (0.73, 0.73, 0.73), double_sided=True)
    red = g.material("red", (0.63, 0.065, 0.05), double_sided=True)
    green = g.material("green", (0.14, 0.45, 0.091), double_sided=True)
    light = g.material("light", (0.78, 0.78, 0.78), emissive=(1.0, 0.85, 0.65), strength=12.0)
    yellow = g.material("yellow", (0.8, 0.62, 0.18))
    q = quad()
    w, h, d = 0.6, 0.6, 0.6
    flip = rot_x(math.pi)  # +Y normal to -Y
    g.add("floor", q, white, (0.0, 0.0, -d / 2), None, (w, 1.0, d))
    g.add("ceiling", q, white, (0.0, h, -d / 2), flip, (w, 1.0, d))
    g.add("back_wall", q, white, (0.0, h / 2, -d), rot_x(math.pi / 2), (w, 1.0, h))
    to_plus_x = ((0, 1, 0), (-1, 0, 0), (0, 0, 1))  # +Y normal to +X (facing into the box)
    to_minus_x = ((0, -1, 0), (1, 0, 0), (0, 0, 1))
    g.add("left_wall", q, red, (-w / 2, h / 2, -d / 2), to_plus_x, (h, 1.0, d))
    g.add("right_wall", q, green, (w / 2, h / 2, -d / 2), to_minus_x, (h, 1.0, d))
    g.add("ceiling_light", q, light, (0.0, h - 0.0005, -d / 2), flip, (0.2, 1.0, 0.2))
    b = box()
    g.add("tall_box", b, white, (-0.1, 0.165, -0.42), rot_y(math.radians(20)), (0.16, 0.33, 0.16))
    g.add("short_box", b, white, (0.1, 0.08, -0.28), rot_y(math.radians(-18)), (0.16, 0.16, 0.16))
    g.add("sphere", uv_sphere(), yellow, (-0.08, 0.07, -0.12), None, (0.07, 0.07, 0.07))
    g.add_camera(eye=(0.0, 0.3, 0.85), target=(0.0, 0.3, 0.0), yfov=0.72, focal_length=0.1,
                 fstop=1.4, focus_object="short_box")
    return g


BAR_COLORS = [("red", (0.75, 0.06, 0.05)), ("orange", (0.85, 0.35, 0.04)),
              ("yellow", (0.85, 0.75, 0.08)), ("green", (0.10, 0.55, 0.12)),
              ("cyan", (0.06, 0.55, 0.65)), ("blue", (0.06, 0.12, 0.70)),
              ("magenta", (0.65, 0.08, 0.55))]


def color_bars():
    g = Gltf("color_bars")
    floor = g.material("floor", (0.7, 0.7, 0.68))
    wall = g.material("wall", (0.75, 0.75, 0.75))
    light = g.material("light", (0.78, 0.78, 0.78), emissive=(1.0, 0.95, 0.9), strength=6.0)
    glow = g.material("glow", (1.0, 0.9, 0.5), emissive=(1.0, 0.85, 0.4), strength=4.0)
    options = {"index_type": GL_UNSIGNED_INT, "interleaved": True, "uvs": False}
    q, b = quad(), box()
    g.add("floor", q, floor, (0.0, 0.0, -0.95), None, (3.0, 1.0, 2.5), **options)
    g.add("back_wall", q, wall, (0.0, 0.75, -2.2), rot_x(math.pi / 2), (3.0, 1.0, 1.5), **options)
    g.light_quad("key_light", light, (0.0, 1.2, -0.3), (0.8, 0.8), (0.0, 0.0, -1.4))
    # (x, depth) of the bars: staggered, the yellow one in front hides the glowing ball.
    layout = [(-0.24, 1.20), (-0.20, 1.55), (-0.08, 1.00), (0.00, 1.30), (0.08, 1.10),
              (0.16, 1.45), (0.24, 1.70)]
    bars = g.group("bars", (0.0, 0.0, 0.0))
    for (name, color), (x, depth) in zip(BAR_COLORS, layout):
        mat = g.material(name, color)
        g.add(name + "_bar", b, mat, (x, 0.15, -depth), None, (0.04, 0.30, 0.04), parent=bars,
              **options)
    # The glowing ball sits on the line of sight through the yellow bar, 0.5 m behind it.
    g.add("hidden_ball", uv_sphere(32, 16), glow, (-0.08 * 1.5, 0.027, -1.5), None,
          (0.027, 0.027, 0.027), **options)
    g.add_camera(eye=(0.0, 0.16, 0.0), target=(0.0, 0.16, -1.0), yfov=0.35, focal_length=0.1,
                 fstop=2.0, focus_object="green_bar")
    return g


SPHERE_COLORS = [("red", (0.75, 0.07, 0.06)), ("orange", (0.85, 0.38, 0.05)),
                 ("yellow", (0.85, 0.76, 0.10)), ("green", (0.12, 0.55, 0.14)),
                 ("blue", (0.08, 0.16, 0.72)), ("purple", (0.45, 0.10, 0.62))]


def color_spheres():
    g = Gltf("color_spheres")
    floor = g.material("floor", (0.72, 0.72, 0.70))
    wall = g.material("backdrop", (0.70, 0.72, 0.75))
    light = g.material("light", (0.78, 0.78, 0.78), emissive=(1.0, 0.95, 0.9), strength=5.0)
    cube_mat = g.material("cube", (0.92, 0.92, 0.92))
    q, s = quad(), uv_sphere()
    g.add("floor", q, floor, (0.0, 0.0, -1.25), None, (3.0, 1.0, 3.1))
    g.add("backdrop", q, wall, (0.0, 0.75, -2.8), rot_x(math.pi / 2), (3.0, 1.0, 1.5))
    g.light_quad("area_light", light, (0.4, 1.1, -0.8), (0.7, 0.7), (0.0, 0.0, -1.5))
    radius, c = 0.08, 0.075  # sphere radius, cube half size
    near, far = 0.9 + 0.22, 1.68  # depths of the orange sphere and of the cube behind it
    # Eye height that puts the cube's centre on the line of sight through the sphere's centre.
    ratio = far / near
    eye = (0.0, r6((radius * ratio - c) / (ratio - 1.0)), 0.0)
    centers = []
    for k, (name, color) in enumerate(SPHERE_COLORS):
        x, depth = -0.20 + 0.09 * k, 0.9 + 0.22 * k
        centers.append((x, radius, -depth))
        g.add(name + "_sphere", s, g.material(name, color), centers[-1], None, (radius,) * 3)
    # The cube rests on the floor, turned to face the eye, just inside the orange sphere's
    # silhouette: the pinhole cannot see it, the lens edge sees its corners.
    direction = sub(centers[1], eye)
    t = far / -direction[2]
    where = (eye[0] + t * direction[0], c, -far)
    g.add("hidden_cube", box(), cube_mat, where, rot_y(math.atan2(-where[0], -where[2])), (2 * c,) * 3)
    g.spot_light("spot_light", (-0.3, 0.9, -1.1), (0.0, 0.0, -1.4), (1.0, 0.9, 0.75), 1.5, 0.25, 0.45)
    g.add_camera(eye=eye, target=(0.0, eye[1], -1.0), yfov=0.42, focal_length=0.1, fstop=1.8,
                 focus_object="yellow_sphere")
    return g


def glossy_closeup():
    g = Gltf("glossy_closeup")

    def checker(x, y):
        return (232, 220, 196) if ((x // 16) + (y // 16)) % 2 == 0 else (176, 58, 38)

    def roughness_bands(x, y):  # G = roughness 0.2 or 0.35 in bands, B = metallic 0 (linear)
        return (255, round(255 * (0.2 if (y // 8) % 2 == 0 else 0.35)), 0)

    base_tex = g.texture(png_bytes(128, 128, checker), "checker")
    mr_tex = g.texture(png_bytes(32, 64, roughness_bands), "roughness_bands")
    table = g.material("table", (0.46, 0.32, 0.22))
    backdrop = g.material("backdrop", (0.72, 0.74, 0.78))
    light = g.material("softbox", (0.78, 0.78, 0.78), emissive=(1.0, 0.96, 0.9), strength=8.0)
    glaze = g.material("glazed_vase", (1.0, 1.0, 1.0), metallic=1.0, roughness=1.0,
                       base_texture=base_tex, mr_texture=mr_tex)
    chrome = g.material("chrome", (0.95, 0.93, 0.88), metallic=1.0, roughness=0.05)
    enamel = g.material("teal_enamel", (0.05, 0.42, 0.45), roughness=0.3)
    q = quad()
    options = {"index_type": GL_UNSIGNED_INT}
    g.add("table", q, table, (0.0, 0.0, -0.95), None, (3.0, 1.0, 2.5), **options)
    g.add("backdrop", q, backdrop, (0.0, 0.8, -2.2), rot_x(math.pi / 2), (3.0, 1.0, 1.6), **options)
    g.light_quad("softbox", light, (-0.35, 0.65, -0.15), (0.45, 0.45), (0.0, 0.1, -0.45))
    g.add("vase", vase(), glaze, (0.0, 0.0, -0.45), rot_y(math.radians(15)), **options)
    g.add("chrome_ball", uv_sphere(), chrome, (0.13, 0.05, -0.58), None, (0.05,) * 3, **options)
    g.add("ring", torus(0.035, 0.012), enamel, (-0.12, 0.012, -0.43), None, **options)
    background = [("red_block", box(), (0.70, 0.10, 0.08), (-0.30, 0.08, -1.05), (0.12, 0.16, 0.12)),
                  ("blue_can", cylinder(), (0.10, 0.20, 0.65), (0.25, 0.0, -1.3), (0.06, 0.22, 0.06)),
                  ("yellow_ball", uv_sphere(), (0.85, 0.70, 0.10), (-0.05, 0.09, -1.6), (0.09,) * 3)]
    for name, geom, color, where, size in background:
        g.add(name, geom, g.material(name, color), where, None, size, **options)
    g.add_camera(eye=(0.0, 0.17, 0.05), target=(0.0, 0.10, -0.45), yfov=0.5, focal_length=0.1,
                 fstop=4.0, focus_object="vase")
    return g


def add_room(g, floor, ceiling, back, left, right, w=2.0, h=2.0, d=2.0):
    """A room w wide, h high and d deep, open towards +Z: floor at y = 0, its back wall at z = -d,
    each surface a quad of the given material facing inwards. Returns the quad, for the scene's
    other quads to share its mesh."""
    q = quad()
    to_plus_x = ((0, 1, 0), (-1, 0, 0), (0, 0, 1))
    to_minus_x = ((0, -1, 0), (1, 0, 0), (0, 0, 1))
    g.add("floor", q, floor, (0.0, 0.0, -d / 2), None, (w, 1.0, d))
    g.add("ceiling", q, ceiling, (0.0, h, -d / 2), rot_x(math.pi), (w, 1.0, d))
    g.add("back_wall", q, back, (0.0, h / 2, -d), rot_x(math.pi / 2), (w, 1.0, h))
    g.add("left_wall", q, left, (-w / 2, h / 2, -d / 2), to_plus_x, (h, 1.0, d))
    g.add("right_wall", q, right, (w / 2, h / 2, -d / 2), to_minus_x, (h, 1.0, d))
    return q


def hanging_light_box():
    """A 2 m room lit by a 0.5 m square panel hanging 2 cm below the ceiling, emitting on both sides,
    so the ceiling right above it and the walls' nearest points see a light centimetres away; two
    diffuse spheres; every material diffuse (roughness 1, metallic 0); a very wide aperture. The
    kind of scene the shipped ones are not: it punishes light sampling by area (1/d^2 spikes next
    to the panel) and any estimator without multiple importance sampling."""
    g = Gltf("hanging_light_box")
    white = g.material("white", (0.73, 0.73, 0.73), double_sided=True)
    red = g.material("red", (0.63, 0.065, 0.05), double_sided=True)
    green = g.material("green", (0.14, 0.45, 0.091), double_sided=True)
    panel = g.material("panel", (0.78, 0.78, 0.78), emissive=(1.0, 0.9, 0.75), strength=16.0,
                       double_sided=True)
    blue = g.material("blue", (0.12, 0.2, 0.6))
    ivory = g.material("ivory", (0.8, 0.75, 0.6))
    h, d = 2.0, 2.0
    q = add_room(g, white, white, white, red, green, h=h, d=d)
    g.add("panel", q, panel, (0.0, h - 0.02, -d / 2), rot_x(math.pi), (0.5, 1.0, 0.5))
    s = uv_sphere()
    g.add("near_sphere", s, ivory, (-0.45, 0.35, -0.75), None, (0.35, 0.35, 0.35))
    g.add("far_sphere", s, blue, (0.5, 0.3, -1.45), None, (0.3, 0.3, 0.3))
    # 50 mm f/0.2: a 0.125 m aperture radius, focused on the near sphere's centre (3.65 m).
    g.add_camera(eye=(0.0, 1.0, 2.9), target=(0.0, 0.98, 0.0), yfov=0.62, focal_length=0.05,
                 fstop=0.2, focus_object="near_sphere")
    return g


def lamp_corner():
    """A 2 m room lit only by a small bright lamp (a 10 cm square, both sides emitting) 4 cm in
    front of the back wall near a corner, above a glossy floor (roughness 0.15), with a polished
    metal sphere and a diffuse cube. Light reaches most of the room by one bounce off the wall
    patch beside the lamp, and the floor reflects both: the paths a path tracer turns into
    fireflies (the clean-frames benchmark's firefly count). 50 mm f/1.0, focused on the sphere."""
    g = Gltf("lamp_corner")
    white = g.material("white", (0.75, 0.75, 0.72), double_sided=True)
    floor = g.material("glossy_floor", (0.35, 0.3, 0.26), roughness=0.15, double_sided=True)
    lamp = g.material("lamp", (0.8, 0.8, 0.8), emissive=(1.0, 0.85, 0.6), strength=400.0,
                      double_sided=True)
    chrome = g.material("chrome", (0.9, 0.9, 0.92), metallic=1.0, roughness=0.05)
    clay = g.material("clay", (0.7, 0.35, 0.2))
    d = 2.0
    q = add_room(g, floor, white, white, white, white, d=d)
    g.add("lamp", q, lamp, (0.7, 1.5, -d + 0.04), rot_x(math.pi / 2), (0.1, 1.0, 0.1))
    sphere, cube = uv_sphere(), box()  # both kept alive: meshes are shared by identity
    g.add("chrome_sphere", sphere, chrome, (-0.3, 0.3, -1.1), None, (0.3, 0.3, 0.3))
    g.add("clay_cube", cube, clay, (0.45, 0.2, -1.4), rot_y(math.radians(30)), (0.4, 0.4, 0.4))
    g.add_camera(eye=(0.0, 1.0, 1.6), target=(0.0, 0.8, -1.0), yfov=0.8, focal_length=0.05,
                 fstop=1.0, focus_object="chrome_sphere")
    return g


def bokeh_lights():
    """For bokeh: a vase and a chrome ball on a dark floor in focus at 1.5 m, 48 small
    coloured lamps (spheres of 3 cm radius) 6 to 11 m behind them and four 0.7 m in front of
    the camera, under a soft overhead panel; black beyond. Every lamp far from the focus draws
    the aperture's shape (about 20 px across at 640x480); the chrome ball and the floor add
    specular highlights. 85 mm f/1.4 (docs/lens.md)."""
    g = Gltf("bokeh_lights")
    floor = g.material("dark_floor", (0.05, 0.05, 0.06), roughness=0.6)
    clay = g.material("clay", (0.72, 0.4, 0.25))
    chrome = g.material("chrome", (0.9, 0.9, 0.92), metallic=1.0, roughness=0.05)
    panel = g.material("panel", (0.8, 0.8, 0.8), emissive=(1.0, 1.0, 1.0), strength=6.0)
    colours = [(1.0, 0.78, 0.45), (1.0, 0.55, 0.2), (0.45, 0.8, 1.0), (1.0, 0.45, 0.7),
               (0.7, 1.0, 0.55)]
    lamps = [g.material("lamp_%d" % i, (0.8, 0.8, 0.8), emissive=c, strength=40.0)
             for i, c in enumerate(colours)]
    q = quad()
    g.add("floor", q, floor, (0.0, 0.0, -5.0), None, (12.0, 1.0, 16.0))
    g.add("panel", q, panel, (0.0, 3.0, -2.5), rot_x(math.pi), (2.0, 1.0, 2.0))
    vase_mesh, ball = vase(24), uv_sphere(12, 6)
    g.add("vase", vase_mesh, clay, (-0.08, 0.0, -0.5), None, (2.0, 2.0, 2.0))
    g.add("chrome_ball", uv_sphere(24, 12), chrome, (0.2, 0.1, -0.55), None, (0.1, 0.1, 0.1))
    seed = 12345
    def rand():  # a fixed LCG: the file is the same on every run
        nonlocal seed
        seed = (1103515245 * seed + 12345) % (1 << 31)
        return seed / float(1 << 31)
    for i in range(48):
        x, y, z = -4.0 + 8.0 * rand(), 0.3 + 2.6 * rand(), -6.5 - 4.0 * rand()
        g.add("lamp_%02d" % i, ball, lamps[i % len(lamps)], (r6(x), r6(y), r6(z)), None,
              (0.03, 0.03, 0.03))
    for i, (x, y) in enumerate([(-0.2, 0.42), (0.21, 0.44), (-0.18, 0.75), (0.2, 0.73)]):
        g.add("near_lamp_%d" % i, ball, lamps[(i + 2) % len(lamps)], (x, y, 0.3), None,
              (0.005, 0.005, 0.005))
    g.add_camera(eye=(0.0, 0.6, 1.0), target=(0.0, 0.45, -0.5), yfov=0.45, focal_length=0.085,
                 fstop=1.4, focus_object="vase")
    return g


def gallery():
    """A gallery 3 m wide, 3 m high and 12 m long that a camera walks through (the sequence
    benchmark's production-sized path, scenes/paths/gallery_walk.json): a tiled floor, columns
    along both walls, pedestals carrying a glossy sphere, a vase, a gold ring and a stack of
    blocks, four ceiling panels 5 cm below the ceiling (lights near a surface) and a lit doorway in
    the far wall. 50 mm f/0.7: the foreground and the far end are blurred by several pixels."""
    g = Gltf("gallery")

    def tiles(x, y):  # 0.25 m tiles at 6 x 24 repeats: light stone with dark joints
        if x % 32 in (0, 31) or y % 32 in (0, 31):
            return (70, 64, 58)
        return (214, 204, 186) if ((x // 32) + (y // 32)) % 2 == 0 else (168, 150, 128)

    options = {"index_type": GL_UNSIGNED_INT}
    floor_tex = g.texture(png_bytes(64, 64, tiles), "floor_tiles")
    floor = g.material("floor", (1.0, 1.0, 1.0), roughness=0.6, base_texture=floor_tex)
    plaster = g.material("plaster", (0.78, 0.74, 0.66), double_sided=True)
    slate = g.material("slate_wall", (0.32, 0.40, 0.48), double_sided=True)
    ceiling = g.material("ceiling", (0.85, 0.85, 0.84), double_sided=True)
    stone = g.material("column_stone", (0.70, 0.68, 0.62), roughness=0.8)
    plinth = g.material("pedestal", (0.22, 0.22, 0.24), roughness=0.5)
    panel = g.material("ceiling_panel", (0.8, 0.8, 0.8), emissive=(1.0, 0.93, 0.82), strength=6.0)
    doorway = g.material("doorway", (0.8, 0.8, 0.8), emissive=(0.85, 0.92, 1.0), strength=3.0)
    red = g.material("red_glaze", (0.62, 0.06, 0.05), roughness=0.25)
    ivory = g.material("ivory", (0.82, 0.78, 0.66), roughness=0.45)
    gold = g.material("gold", (0.95, 0.74, 0.32), metallic=1.0, roughness=0.3)
    blocks = [g.material("block_%s" % n, c) for n, c in
              (("teal", (0.06, 0.45, 0.42)), ("ochre", (0.78, 0.55, 0.12)),
               ("violet", (0.35, 0.16, 0.55)))]
    w, h, z0, z1 = 3.0, 3.0, 2.0, -10.0  # x in [-w/2, w/2], y in [0, h], z from z0 to z1
    length_z = z0 - z1
    mid = 0.5 * (z0 + z1)
    flip = rot_x(math.pi)
    to_plus_x = ((0, 1, 0), (-1, 0, 0), (0, 0, 1))
    to_minus_x = ((0, -1, 0), (1, 0, 0), (0, 0, 1))
    q = quad()
    g.add("floor", tiled_quad(6.0, 24.0), floor, (0.0, 0.0, mid), None, (w, 1.0, length_z),
          **options)
    g.add("ceiling", q, ceiling, (0.0, h, mid), flip, (w, 1.0, length_z), **options)
    g.add("left_wall", q, plaster, (-w / 2, h / 2, mid), to_plus_x, (h, 1.0, length_z), **options)
    g.add("right_wall", q, slate, (w / 2, h / 2, mid), to_minus_x, (h, 1.0, length_z), **options)
    g.add("far_wall", q, plaster, (0.0, h / 2, z1), rot_x(math.pi / 2), (w, 1.0, h), **options)
    g.add("entrance_wall", q, plaster, (0.0, h / 2, z0), rot_x(-math.pi / 2), (w, 1.0, h),
          **options)
    g.light_quad("doorway", doorway, (0.0, 1.1, z1 + 0.01), (0.9, 2.2), (0.0, 1.1, 0.0))
    for k, z in enumerate((0.5, -2.5, -5.5, -8.5)):
        g.add("ceiling_panel_%d" % k, q, panel, (0.0, h - 0.05, z), flip, (0.6, 1.0, 1.2),
              **options)
    column = cylinder()
    for k, z in enumerate((0.0, -2.0, -4.0, -6.0, -8.0)):
        for side, x in (("left", -1.25), ("right", 1.25)):
            g.add("column_%s_%d" % (side, k), column, stone, (x, 0.0, z), None, (0.14, h, 0.14),
                  **options)
    b = box()
    sphere = uv_sphere()
    pedestals = [(-0.75, -1.0), (0.75, -3.0), (-0.75, -5.0), (0.75, -7.0)]
    for k, (x, z) in enumerate(pedestals):
        g.add("pedestal_%d" % k, b, plinth, (x, 0.45, z), None, (0.4, 0.9, 0.4), **options)
    g.add("red_sphere", sphere, red, (-0.75, 1.05, -1.0), None, (0.15,) * 3, **options)
    g.add("vase", vase(), ivory, (0.75, 0.9, -3.0), rot_y(math.radians(20)), (2.0,) * 3,
          **options)
    g.add("gold_ring", torus(0.12, 0.035), gold, (-0.75, 1.0, -5.0), rot_x(math.radians(70)),
          **options)
    for k, m in enumerate(blocks):
        g.add("block_%d" % k, b, m, (0.75 + 0.03 * (k - 1), 0.98 + 0.16 * k, -7.0),
              rot_y(math.radians(25 * k)), (0.16, 0.16, 0.16), **options)
    g.add_camera(eye=(0.0, 1.6, 1.5), target=(0.0, 1.3, -10.0), yfov=0.75, focal_length=0.05,
                 fstop=0.7, focus_object="red_sphere")
    return g


def main():
    g = hanging_light_box()
    g.write_gltf_embedded(os.path.join(HERE, "hanging_light_box.gltf"))
    report(g, g.finish())

    g = cornell_box()
    g.write_gltf_embedded(os.path.join(HERE, "cornell_box.gltf"))
    report(g, g.finish())

    g = color_bars()
    g.write_gltf_external(os.path.join(HERE, "color_bars.gltf"))
    share = occlusion_check(g, "hidden_ball")
    report(g, g.finish(), "hidden_ball: hidden from the pinhole, seen from %.0f%% of the test "
           "lens points" % (100 * share))

    g = color_spheres()
    g.write_gltf_embedded(os.path.join(HERE, "color_spheres.gltf"))
    share = occlusion_check(g, "hidden_cube")
    report(g, g.finish(), "hidden_cube: hidden from the pinhole, seen from %.0f%% of the test "
           "lens points" % (100 * share))

    g = glossy_closeup()
    g.write_glb(os.path.join(HERE, "glossy_closeup.glb"))
    report(g, g.finish())

    g = gallery()
    g.write_glb(os.path.join(HERE, "gallery.glb"))
    report(g, g.finish())

    g = lamp_corner()
    g.write_gltf_embedded(os.path.join(HERE, "lamp_corner.gltf"))
    report(g, g.finish())

    g = bokeh_lights()
    g.write_gltf_embedded(os.path.join(HERE, "bokeh_lights.gltf"))
    report(g, g.finish())


if __name__ == "__main__":
    main()
