#!/usr/bin/env python3
"""Writes atrium.glb, a production-sized scene for the scale benchmark (docs/scenes.md, "Atrium").

A stone atrium 16 m wide, 12 m high and 36 m long: a tiled floor, plaster walls with a normal
texture, two rows of eight fluted marble columns (finely tessellated, with a normal texture),
semicircular stone arches between them, fourteen terracotta planters carrying bushes of cut-out
leaves (alphaMode MASK, double-sided, two species) and three emissive skylights under the ceiling.
One camera with `extras.lens` looks down the nave, focused on the third pair of columns.

The default size is about 2.1 million triangles with 11 PNG textures; `--triangles N` makes a
smaller (or larger) version with the same layout, the budget split between columns (60 %), arches
(15 %) and foliage (25 %). Columns, arches and bushes are meshes placed by several nodes
(instancing, as production files do); the loader flattens them, so the triangle count is that of
the flattened scene. Deterministic: the same arguments give the same bytes. Standard library only
(PNG written with zlib and struct).

  python3 scenes/generate_atrium.py                      # out/atrium.glb, ~2.1 M triangles
  python3 scenes/generate_atrium.py /tmp/a.glb --triangles 20000 --texture-size 32   # for tests
"""
import argparse
import array
import math
import os
import random
import sys

import gltf_files  # scenes/gltf_files.py, beside this script

GL_FLOAT, GL_UNSIGNED_INT = 5126, 5125
ARRAY_BUFFER, ELEMENT_ARRAY_BUFFER = 34962, 34963

# Layout (metres; +Y up, the nave runs along -Z from the entrance at z = 0).
HALF_WIDTH, HEIGHT, LENGTH = 8.0, 12.0, 36.0
COLUMN_X, COLUMN_Z0, COLUMN_PITCH, COLUMNS_PER_ROW = 4.0, -4.0, 4.0, 8
COLUMN_HEIGHT, COLUMN_RADIUS, FLUTES = 6.0, 0.35, 20
ARCH_RADIUS = COLUMN_PITCH / 2.0  # springs from one column's axis to the next
ARCH_DEPTH, ARCH_WIDTH = 0.45, 0.6  # radial thickness, thickness along x
PLANTER_X, PLANTER_SIZE, PLANTER_HEIGHT = 2.6, 1.2, 0.6
SKYLIGHTS = ((-8.0, 4.0), (-18.0, 4.0), (-28.0, 4.0))  # (z centre, length along z), 5 m wide


# --------------------------------------------------------------------------------------------
# Meshes: flat arrays (positions, normals, uvs, indices), built with the array module for speed.


class Mesh:
    def __init__(self):
        self.pos = array.array("f")
        self.nrm = array.array("f")
        self.uv = array.array("f")
        self.idx = array.array("I")

    def vertex_count(self):
        return len(self.pos) // 3

    def triangle_count(self):
        return len(self.idx) // 3

    def grid(self, nu, nv, point):
        """A (nu+1) x (nv+1) vertex grid; point(i, j) -> (position, normal, uv). Two triangles per
        cell, counter-clockwise seen from the side the normals point to when
        cross(d/di, d/dj) points along the normal."""
        base = self.vertex_count()
        for j in range(nv + 1):
            for i in range(nu + 1):
                p, n, t = point(i, j)
                self.pos.extend(p)
                self.nrm.extend(n)
                self.uv.extend(t)
        row = nu + 1
        for j in range(nv):
            for i in range(nu):
                a = base + j * row + i
                self.idx.extend((a, a + 1, a + row + 1, a, a + row + 1, a + row))


def normalize(v):
    length = math.sqrt(v[0] * v[0] + v[1] * v[1] + v[2] * v[2])
    return (v[0] / length, v[1] / length, v[2] / length)


def cross(a, b):
    return (a[1] * b[2] - a[2] * b[1], a[2] * b[0] - a[0] * b[2], a[0] * b[1] - a[1] * b[0])


def quad(mesh, origin, du, dv, nu, nv, uv_scale):
    """A planar rectangle origin + s du + t dv, s, t in [0, 1], facing cross(du, dv)."""
    n = normalize(cross(du, dv))
    su, sv = uv_scale

    def point(i, j):
        s, t = i / nu, j / nv
        p = (origin[0] + s * du[0] + t * dv[0], origin[1] + s * du[1] + t * dv[1],
             origin[2] + s * du[2] + t * dv[2])
        return p, n, (s * su, (1.0 - t) * sv)

    mesh.grid(nu, nv, point)


def box(mesh, lower, upper, uv_per_metre=1.0):
    """An axis-aligned box with outward faces (no bottom: boxes stand on something)."""
    (x0, y0, z0), (x1, y1, z1) = lower, upper
    sx, sy, sz = (x1 - x0) * uv_per_metre, (y1 - y0) * uv_per_metre, (z1 - z0) * uv_per_metre
    quad(mesh, (x0, y0, z1), (x1 - x0, 0, 0), (0, y1 - y0, 0), 1, 1, (sx, sy))  # +z
    quad(mesh, (x1, y0, z0), (x0 - x1, 0, 0), (0, y1 - y0, 0), 1, 1, (sx, sy))  # -z
    quad(mesh, (x1, y0, z1), (0, 0, z0 - z1), (0, y1 - y0, 0), 1, 1, (sz, sy))  # +x
    quad(mesh, (x0, y0, z0), (0, 0, z1 - z0), (0, y1 - y0, 0), 1, 1, (sz, sy))  # -x
    quad(mesh, (x0, y1, z1), (x1 - x0, 0, 0), (0, 0, z0 - z1), 1, 1, (sx, sz))  # +y


def column_profile(h):
    """Radius factor and flute depth factor at height h in [0, COLUMN_HEIGHT]: a torus-like base,
    a fluted shaft with a slight entasis, and a flaring capital."""
    t = h / COLUMN_HEIGHT
    radius = 1.0 - 0.08 * t + 0.05 * math.sin(math.pi * t)  # entasis
    flutes = 1.0
    if h < 0.35:  # base moulding: a half-round bulge, no flutes
        radius += 0.25 * math.sin(math.pi * h / 0.35)
        flutes = 0.0
    elif h < 0.5:
        flutes = (h - 0.35) / 0.15
    if h > COLUMN_HEIGHT - 0.6:  # capital: flares out, flutes fade
        s = (h - (COLUMN_HEIGHT - 0.6)) / 0.6
        radius += 0.45 * s * s
        flutes *= max(0.0, 1.0 - 2.0 * s)
    return radius, flutes


def column(segments, rings):
    """A fluted column around the y axis from y = 0 to COLUMN_HEIGHT, plus a square plinth and
    abacus. Normals from the surface's partial derivatives (central differences)."""
    mesh = Mesh()

    def surface(theta, h):
        radius, flutes = column_profile(h)
        r = COLUMN_RADIUS * radius * (1.0 - 0.04 * flutes * max(0.0, math.cos(FLUTES * theta)))
        return (r * math.sin(theta), h, r * math.cos(theta))

    d_theta, d_h = 1e-4, 1e-4

    def point(i, j):
        theta = 2.0 * math.pi * i / segments
        h = COLUMN_HEIGHT * j / rings
        p = surface(theta, h)
        a, b = surface(theta + d_theta, h), surface(theta - d_theta, h)
        c, d = surface(theta, min(h + d_h, COLUMN_HEIGHT)), surface(theta, max(h - d_h, 0.0))
        tangent_theta = (a[0] - b[0], a[1] - b[1], a[2] - b[2])
        tangent_h = (c[0] - d[0], c[1] - d[1], c[2] - d[2])
        n = normalize(cross(tangent_theta, tangent_h))
        return p, n, (2.0 * i / segments, 4.0 * h / COLUMN_HEIGHT)

    mesh.grid(segments, rings, point)
    w = COLUMN_RADIUS * 1.45
    box(mesh, (-w, 0.0, -w), (w, 0.12, w))  # plinth
    w = COLUMN_RADIUS * 1.75
    box(mesh, (-w, COLUMN_HEIGHT, -w), (w, COLUMN_HEIGHT + 0.15, w))  # abacus
    return mesh


def arch(steps, subdivisions):
    """A semicircular arch in the y-z plane spanning z in [-ARCH_RADIUS, ARCH_RADIUS], springing at
    y = 0 (the node lifts it onto the capitals): a rectangular section swept along the half
    circle, each of its four faces a grid of steps x subdivisions cells."""
    mesh = Mesh()
    r_in, r_out = ARCH_RADIUS - ARCH_DEPTH, ARCH_RADIUS
    hw = ARCH_WIDTH / 2.0

    def at(angle, radius, x):
        return (x, radius * math.sin(angle), radius * math.cos(angle))

    def radial(angle):
        return (0.0, math.sin(angle), math.cos(angle))

    k = subdivisions

    # Intrados (inner face, normal towards the centre) and extrados (outer face).
    def intrados(i, j):
        a = math.pi * i / steps
        x = -hw + ARCH_WIDTH * j / k
        r = radial(a)
        return at(a, r_in, x), (-r[0], -r[1], -r[2]), (3.0 * i / steps, j / k)

    def extrados(i, j):
        a = math.pi * i / steps
        x = hw - ARCH_WIDTH * j / k
        return at(a, r_out, x), radial(a), (3.0 * i / steps, j / k)

    # The two side faces (normals along +x and -x).
    def side(sign):
        def point(i, j):
            a = math.pi * i / steps
            r = r_in + ARCH_DEPTH * j / k if sign > 0 else r_out - ARCH_DEPTH * j / k
            return at(a, r, sign * hw), (float(sign), 0.0, 0.0), (3.0 * i / steps, j / k)
        return point

    # Winding: each face's cells turn counter-clockwise around its normal (checked by the loader's
    # tests rendering the front faces; angle increases from z = +r towards y = +r).
    mesh.grid(steps, k, intrados)
    mesh.grid(steps, k, extrados)
    mesh.grid(steps, k, side(+1))
    mesh.grid(steps, k, side(-1))
    return mesh


def bush(leaves, seed):
    """`leaves` cut-out leaf quads (two triangles each) scattered in a half ellipsoid above a
    planter, each turned at random; double-sided, so the winding does not matter."""
    rng = random.Random(seed)
    mesh = Mesh()
    for _ in range(leaves):
        while True:  # uniform in the half ellipsoid
            x, y, z = rng.uniform(-1, 1), rng.uniform(0, 1), rng.uniform(-1, 1)
            if x * x + y * y + z * z <= 1.0:
                break
        center = (0.75 * x, PLANTER_HEIGHT + 0.05 + 1.1 * y, 0.75 * z)
        # A random frame: the leaf's axis and its face normal.
        yaw, pitch, roll = rng.uniform(0, 2 * math.pi), rng.uniform(-1.2, 0.6), rng.uniform(-0.5, 0.5)
        axis = (math.cos(pitch) * math.sin(yaw), math.sin(pitch), math.cos(pitch) * math.cos(yaw))
        side = normalize(cross(axis, (math.sin(roll), math.cos(roll), 0.0 + 1e-3)))
        n = normalize(cross(side, axis))
        length, width = rng.uniform(0.16, 0.26), rng.uniform(0.07, 0.11)
        base = mesh.vertex_count()
        for s, t in ((0.0, -0.5), (0.0, 0.5), (1.0, 0.5), (1.0, -0.5)):
            mesh.pos.extend((center[0] + (s - 0.3) * length * axis[0] + t * width * side[0],
                             center[1] + (s - 0.3) * length * axis[1] + t * width * side[1],
                             center[2] + (s - 0.3) * length * axis[2] + t * width * side[2]))
            mesh.nrm.extend(n)
            mesh.uv.extend((t + 0.5, 1.0 - s))  # the leaf's stem at the bottom of its texture
        mesh.idx.extend((base, base + 1, base + 2, base, base + 2, base + 3))
    return mesh


# --------------------------------------------------------------------------------------------
# Textures: procedural RGBA PNGs (zlib + struct).


def png_rgba(width, height, pixel):
    """pixel(x, y) -> (r, g, b, a), 0..255; row 0 is the top."""
    return gltf_files.png(width, height, pixel, alpha=True, level=6)


def hash01(x, y, seed):
    h = (x * 374761393 + y * 668265263 + seed * 1442695041) & 0xffffffff
    h = ((h ^ (h >> 13)) * 1274126177) & 0xffffffff
    return ((h ^ (h >> 16)) & 0xffff) / 65535.0


def value_noise(x, y, cell, seed, period):
    """Smooth value noise, tileable with `period` cells."""
    fx, fy = x / cell, y / cell
    ix, iy = int(math.floor(fx)), int(math.floor(fy))
    tx, ty = fx - ix, fy - iy
    tx, ty = tx * tx * (3 - 2 * tx), ty * ty * (3 - 2 * ty)

    def corner(i, j):
        return hash01(i % period, j % period, seed)

    top = corner(ix, iy) * (1 - tx) + corner(ix + 1, iy) * tx
    bottom = corner(ix, iy + 1) * (1 - tx) + corner(ix + 1, iy + 1) * tx
    return top * (1 - ty) + bottom * ty


def fbm(x, y, size, seed, octaves=3):
    total, amplitude, cells = 0.0, 0.5, 4
    for o in range(octaves):
        total += amplitude * value_noise(x, y, size / cells, seed + o, cells)
        amplitude *= 0.5
        cells *= 2
    return total / (1.0 - 0.5 ** octaves)


def byte(v):
    return max(0, min(255, int(round(v * 255.0))))


def normal_texel(height_at, x, y, strength):
    """A tangent-space normal (0..255 encoded) from a height field by central differences."""
    dx = height_at(x + 1, y) - height_at(x - 1, y)
    dy = height_at(x, y + 1) - height_at(x, y - 1)
    n = normalize((-strength * dx, strength * dy, 1.0))  # v grows downwards in the image
    return (byte(0.5 + 0.5 * n[0]), byte(0.5 + 0.5 * n[1]), byte(0.5 + 0.5 * n[2]), 255)


def textures(size):
    """The scene's eleven textures, name -> PNG bytes: colour textures of size x size texels,
    roughness, normal, leaf and skylight textures of half that."""
    out = {}
    s, q = size, max(8, size // 2)

    def floor_color(x, y):  # 2 x 2 marble tiles, light and dark, with grout lines
        tile = (x * 2 // s + y * 2 // s) % 2
        grout = (x % (s // 2)) * 128 < s or (y % (s // 2)) * 128 < s
        vein = abs(math.sin(12.8 * (x + 2 * y) / s + 6.0 * fbm(x, y, s, 7)))
        base = (0.82, 0.79, 0.72) if tile == 0 else (0.35, 0.33, 0.32)
        v = 0.85 + 0.15 * vein
        if grout:
            return (90, 85, 80, 255)
        return (byte(base[0] * v), byte(base[1] * v), byte(base[2] * v), 255)

    out["floor_color"] = png_rgba(s, s, floor_color)

    def floor_roughness(x, y):  # G roughness, B metallic (0): polished tiles, rough grout
        grout = (x % (q // 2)) * 128 < q or (y % (q // 2)) * 128 < q
        return (0, 140 if grout else byte(0.15 + 0.25 * fbm(x, y, q, 3)), 0, 255)

    out["floor_roughness"] = png_rgba(q, q, floor_roughness)

    def plaster(x, y):
        v = 0.78 + 0.12 * fbm(x, y, s, 11)
        return (byte(v), byte(v * 0.95), byte(v * 0.86), 255)

    out["plaster_color"] = png_rgba(s, s, plaster)
    out["plaster_normal"] = png_rgba(
        q, q, lambda x, y: normal_texel(lambda a, b: fbm(a % q, b % q, q, 13, 4), x, y, 0.05 * q))

    def marble(x, y):
        v = 0.5 + 0.5 * math.sin(20.0 * x / s + 9.0 * fbm(x, y, s, 21, 4))
        return (byte(0.92 - 0.2 * v), byte(0.9 - 0.2 * v), byte(0.86 - 0.18 * v), 255)

    out["marble_color"] = png_rgba(s, s, marble)
    out["marble_normal"] = png_rgba(
        q, q, lambda x, y: normal_texel(lambda a, b: fbm(a % q, b % q, q, 23, 3), x, y, 0.025 * q))

    def stone(x, y):  # ashlar blocks: four courses, staggered joints
        course = y * 4 // s
        joint = (y % (s // 4)) * 128 < s or ((x + (3 * s // 16) * (course % 2)) % (s // 2)) * 128 < s
        v = 0.62 + 0.18 * fbm(x, y, s, 31)
        if joint:
            v *= 0.55
        return (byte(v * 1.0), byte(v * 0.92), byte(v * 0.8), 255)

    out["stone_color"] = png_rgba(s, s, stone)

    def terracotta(x, y):
        v = 0.75 + 0.25 * fbm(x, y, q, 41)
        band = 0.8 if 0.75 <= y / q < 0.81 else 1.0
        return (byte(0.72 * v * band), byte(0.36 * v * band), byte(0.22 * v * band), 255)

    out["terracotta_color"] = png_rgba(q, q, terracotta)

    def leaf(shape):
        def pixel(x, y):
            u = (x + 0.5) / q - 0.5  # across the leaf
            t = 1.0 - (y + 0.5) / q  # along it, stem at the bottom
            if shape == 0:  # a lanceolate leaf with a serrated edge
                half = 0.42 * math.sin(math.pi * t) ** 0.8 * (1.0 + 0.06 * math.sin(60.0 * t))
            else:  # a lobed leaf
                half = 0.45 * math.sin(math.pi * t) * (0.7 + 0.3 * abs(math.sin(3.0 * math.pi * t)))
            inside = abs(u) < half and 0.04 < t < 0.98
            stem = abs(u) < 0.015 and t <= 0.2
            vein = abs(u) < 0.01 + 0.01 * (1 - t)
            g = 0.45 + 0.2 * fbm(x, y, q, 51 + shape)
            if shape == 0:
                color = (0.18 * g, 0.9 * g, 0.22 * g)
            else:
                color = (0.45 * g, 0.85 * g, 0.15 * g)
            if vein or stem:
                color = (color[0] * 1.5, color[1] * 1.2, color[2] * 1.3)
            return (byte(color[0]), byte(color[1]), byte(color[2]), 255 if inside or stem else 0)
        return pixel

    out["leaf_a"] = png_rgba(q, q, leaf(0))
    out["leaf_b"] = png_rgba(q, q, leaf(1))

    def skylight(x, y):  # glass panes between mullions: the mullions do not glow
        mullion = (x % (q // 4)) * 40 < 3 * q or (y % (q // 4)) * 40 < 3 * q
        v = 0.0 if mullion else 0.9 + 0.1 * fbm(x, y, q, 61)
        return (byte(v), byte(v * 0.97), byte(v * 0.9), 255)

    out["skylight_emission"] = png_rgba(q, q, skylight)
    return out


# --------------------------------------------------------------------------------------------
# glTF writer


class Gltf:
    def __init__(self):
        self.doc = {"asset": {"version": "2.0", "generator": "dofcache scenes/generate_atrium.py"},
                    "scene": 0, "scenes": [{"name": "atrium", "nodes": []}], "nodes": [],
                    "meshes": [], "materials": [], "accessors": [], "bufferViews": [],
                    "images": [], "textures": [], "samplers": [{"wrapS": 10497, "wrapT": 10497}],
                    "extensionsUsed": ["KHR_materials_emissive_strength"]}
        self.bin = bytearray()
        self.texture_ids = {}
        self.triangles = 0

    def _view(self, data, target=None):
        while len(self.bin) % 4:
            self.bin.append(0)
        view = {"buffer": 0, "byteOffset": len(self.bin), "byteLength": len(data)}
        if target:
            view["target"] = target
        self.bin.extend(data)
        self.doc["bufferViews"].append(view)
        return len(self.doc["bufferViews"]) - 1

    def _accessor(self, values, component, kind, count, target, bounds=False):
        acc = {"bufferView": self._view(values.tobytes(), target), "componentType": component,
               "count": count, "type": kind}
        if bounds:
            acc["min"] = [min(values[c::3]) for c in range(3)]
            acc["max"] = [max(values[c::3]) for c in range(3)]
        self.doc["accessors"].append(acc)
        return len(self.doc["accessors"]) - 1

    def texture(self, name, png):
        self.doc["images"].append({"name": name, "mimeType": "image/png",
                                   "bufferView": self._view(png)})
        self.doc["textures"].append({"source": len(self.doc["images"]) - 1, "sampler": 0})
        self.texture_ids[name] = len(self.doc["textures"]) - 1

    def material(self, name, color=None, roughness=0.8, mr=None, normal=None, emission=None,
                 strength=1.0, mask=False):
        pbr = {"metallicFactor": 0.0, "roughnessFactor": roughness}
        if color:
            pbr["baseColorTexture"] = {"index": self.texture_ids[color]}
        if mr:
            pbr["metallicRoughnessTexture"] = {"index": self.texture_ids[mr]}
            pbr["roughnessFactor"] = 1.0
        mat = {"name": name, "pbrMetallicRoughness": pbr}
        if normal:
            mat["normalTexture"] = {"index": self.texture_ids[normal]}
        if emission:
            mat["emissiveFactor"] = [1.0, 1.0, 1.0]
            mat["emissiveTexture"] = {"index": self.texture_ids[emission]}
            mat["extensions"] = {"KHR_materials_emissive_strength": {"emissiveStrength": strength}}
        if mask:
            mat["alphaMode"] = "MASK"
            mat["alphaCutoff"] = 0.5
            mat["doubleSided"] = True
        self.doc["materials"].append(mat)
        return len(self.doc["materials"]) - 1

    def mesh(self, name, mesh, material):
        n = mesh.vertex_count()
        prim = {"attributes": {
            "POSITION": self._accessor(mesh.pos, GL_FLOAT, "VEC3", n, ARRAY_BUFFER, bounds=True),
            "NORMAL": self._accessor(mesh.nrm, GL_FLOAT, "VEC3", n, ARRAY_BUFFER),
            "TEXCOORD_0": self._accessor(mesh.uv, GL_FLOAT, "VEC2", n, ARRAY_BUFFER)},
            "indices": self._accessor(mesh.idx, GL_UNSIGNED_INT, "SCALAR", len(mesh.idx),
                                      ELEMENT_ARRAY_BUFFER),
            "material": material}
        self.doc["meshes"].append({"name": name, "primitives": [prim],
                                   "extras": {"triangles": mesh.triangle_count()}})
        return len(self.doc["meshes"]) - 1

    def node(self, name, mesh=None, translation=None, rotation=None, extra=None):
        node = {"name": name}
        if mesh is not None:
            node["mesh"] = mesh
            self.triangles += self.doc["meshes"][mesh]["extras"]["triangles"]
        if translation:
            node["translation"] = [round(v, 6) + 0.0 for v in translation]
        if rotation:
            node["rotation"] = [round(v, 9) + 0.0 for v in rotation]
        if extra:
            node.update(extra)
        self.doc["nodes"].append(node)
        self.doc["scenes"][0]["nodes"].append(len(self.doc["nodes"]) - 1)

    def write_glb(self, path):
        gltf_files.write_glb(path, self.doc, self.bin)  # atomic: never a half-written scene


def quat_y(angle):
    return (0.0, math.sin(angle / 2.0), 0.0, math.cos(angle / 2.0))


# --------------------------------------------------------------------------------------------
# The scene


def budget(triangles):
    """Tessellation for a total of about `triangles`: (column segments, rings), (arch steps,
    subdivisions), leaves per bush."""
    columns, arches, bushes = 2 * COLUMNS_PER_ROW, 2 * (COLUMNS_PER_ROW - 1), 2 * (COLUMNS_PER_ROW - 1)
    rest = max(triangles - 1500, 3000)  # the floor, walls, planters and skylights: ~1.3k
    per_column = 0.60 * rest / columns
    # 2 s r triangles; rings about 3 x segments keeps the cells near square (6 m x 2.2 m).
    segments = max(8, int(math.ceil(math.sqrt(per_column / 6.0))))
    rings = max(8, int(math.ceil(per_column / (2.0 * segments))))
    per_arch = 0.15 * rest / arches  # 4 faces x 2 s k triangles, steps about 8 x subdivisions
    subdivisions = max(1, int(math.ceil(math.sqrt(per_arch / 64.0))))
    steps = max(8, int(math.ceil(per_arch / (8.0 * subdivisions))))
    leaves = max(4, int(math.ceil(0.25 * rest / bushes / 2.0)))
    return (segments, rings), (steps, subdivisions), leaves


def build(triangles, texture_size):
    g = Gltf()
    for name, png in textures(texture_size).items():
        g.texture(name, png)
    floor_m = g.material("floor", color="floor_color", mr="floor_roughness")
    wall_m = g.material("plaster", color="plaster_color", normal="plaster_normal", roughness=0.9)
    marble_m = g.material("marble", color="marble_color", normal="marble_normal", roughness=0.35)
    stone_m = g.material("stone", color="stone_color", roughness=0.85)
    pot_m = g.material("terracotta", color="terracotta_color", roughness=0.7)
    leaf_a_m = g.material("leaf_a", color="leaf_a", roughness=0.6, mask=True)
    leaf_b_m = g.material("leaf_b", color="leaf_b", roughness=0.6, mask=True)
    sky_m = g.material("skylight", emission="skylight_emission", strength=12.0, roughness=1.0)

    (segments, rings), (steps, subdivisions), leaves = budget(triangles)

    # The hall: floor, walls and ceiling, facing inwards.
    hall = Mesh()
    quad(hall, (-HALF_WIDTH, 0.0, 0.0), (2 * HALF_WIDTH, 0, 0), (0, 0, -LENGTH), 16, 36,
         (HALF_WIDTH, LENGTH / 2.0))  # a texture repeat is 2 m: four 1 m tiles
    floor = g.mesh("floor", hall, floor_m)
    walls = Mesh()
    quad(walls, (-HALF_WIDTH, 0.0, 0.0), (0, 0, -LENGTH), (0, HEIGHT, 0), 4, 2, (LENGTH / 4, HEIGHT / 4))
    quad(walls, (HALF_WIDTH, 0.0, -LENGTH), (0, 0, LENGTH), (0, HEIGHT, 0), 4, 2, (LENGTH / 4, HEIGHT / 4))
    quad(walls, (-HALF_WIDTH, 0.0, -LENGTH), (2 * HALF_WIDTH, 0, 0), (0, HEIGHT, 0), 4, 2,
         (HALF_WIDTH / 2, HEIGHT / 4))
    quad(walls, (HALF_WIDTH, 0.0, 1.0), (-2 * HALF_WIDTH, 0, 0), (0, HEIGHT, 0), 4, 2,
         (HALF_WIDTH / 2, HEIGHT / 4))  # the entrance wall, behind the camera
    quad(walls, (-HALF_WIDTH, HEIGHT, -LENGTH), (2 * HALF_WIDTH, 0, 0), (0, 0, LENGTH + 1.0), 4, 8,
         (HALF_WIDTH / 2, LENGTH / 4))  # ceiling, facing down
    g.node("floor", floor)
    g.node("walls", g.mesh("walls", walls, wall_m))
    sky = Mesh()
    for zc, length in SKYLIGHTS:  # 5 cm under the ceiling, facing down
        quad(sky, (-2.5, HEIGHT - 0.05, zc - length / 2), (5.0, 0, 0), (0, 0, length), 1, 1, (1.0, 1.0))
    g.node("skylights", g.mesh("skylights", sky, sky_m))

    column_mesh = g.mesh("column", column(segments, rings), marble_m)
    arch_mesh = g.mesh("arch", arch(steps, subdivisions), stone_m)
    for side in (-1, 1):
        for k in range(COLUMNS_PER_ROW):
            z = COLUMN_Z0 - COLUMN_PITCH * k
            g.node("column_%s%d" % ("lr"[side > 0], k), column_mesh, (side * COLUMN_X, 0.0, z))
            if k + 1 < COLUMNS_PER_ROW:
                g.node("arch_%s%d" % ("lr"[side > 0], k), arch_mesh,
                       (side * COLUMN_X, COLUMN_HEIGHT + 0.15, z - COLUMN_PITCH / 2))

    pot = Mesh()
    h = PLANTER_SIZE / 2
    box(pot, (-h, 0.0, -h), (h, PLANTER_HEIGHT, h), 1.0 / PLANTER_SIZE)
    pot_mesh = g.mesh("planter", pot, pot_m)
    bush_meshes = (g.mesh("bush_a", bush(leaves, 1), leaf_a_m),
                   g.mesh("bush_b", bush(leaves, 2), leaf_b_m))
    for side in (-1, 1):
        for k in range(COLUMNS_PER_ROW - 1):
            z = COLUMN_Z0 - COLUMN_PITCH * (k + 0.5)
            name = "%s%d" % ("lr"[side > 0], k)
            g.node("planter_" + name, pot_mesh, (side * PLANTER_X, 0.0, z))
            g.node("bush_" + name, bush_meshes[(k + (side > 0)) % 2], (side * PLANTER_X, 0.0, z),
                   quat_y(0.7 * k + (1.3 if side > 0 else 0.0)))

    # The camera at eye height by the entrance, looking down the nave, a little upwards; focused
    # on the third pair of columns (axial distance).
    eye, target = (0.6, 1.6, -0.5), (0.0, 3.2, -30.0)
    forward = normalize((target[0] - eye[0], target[1] - eye[1], target[2] - eye[2]))
    focus_point = (COLUMN_X, 2.0, COLUMN_Z0 - 2 * COLUMN_PITCH)
    focus = sum((focus_point[i] - eye[i]) * forward[i] for i in range(3))
    g.doc["cameras"] = [{"name": "camera", "type": "perspective", "perspective": {
        "yfov": 0.9, "aspectRatio": round(4.0 / 3.0, 6), "znear": 0.01, "zfar": 100.0}}]
    yaw = math.atan2(-forward[0], -forward[2])
    pitch = math.asin(forward[1])
    qy, qx = quat_y(yaw), (math.sin(pitch / 2), 0.0, 0.0, math.cos(pitch / 2))
    rotation = (qy[3] * qx[0], qy[1] * qx[3], -qy[1] * qx[0], qy[3] * qx[3])  # qy * qx
    g.node("camera", translation=eye, rotation=rotation,
           extra={"camera": 0, "extras": {"lens": {"focal_length": 0.035, "fstop": 2.0,
                                                   "focus_distance": round(focus, 6)}}})
    return g


class Parser(argparse.ArgumentParser):
    def error(self, message):  # one line, as dofcache's own commands do
        print("generate_atrium.py: error: %s" % message, file=sys.stderr)
        sys.exit(2)


def main():
    parser = Parser(description=__doc__.split("\n")[0])
    parser.add_argument("out", nargs="?", default=os.path.join("out", "atrium.glb"),
                        help="output .glb (default: out/atrium.glb)")
    parser.add_argument("--triangles", type=int, default=2_100_000,
                        help="about how many triangles the flattened scene has (default 2100000)")
    parser.add_argument("--texture-size", type=int, default=256,
                        help="texels along a colour texture's side, a power of two (default 256; "
                             "the others have half)")
    args = parser.parse_args()
    if not 5000 <= args.triangles <= 50_000_000:
        print("generate_atrium.py: error: --triangles must be in 5000..50000000", file=sys.stderr)
        return 2
    if args.texture_size not in (16, 32, 64, 128, 256, 512, 1024, 2048):
        print("generate_atrium.py: error: --texture-size must be a power of two in 16..2048",
              file=sys.stderr)
        return 2
    g = build(args.triangles, args.texture_size)
    try:
        os.makedirs(os.path.dirname(os.path.abspath(args.out)), exist_ok=True)
        g.write_glb(args.out)
    except OSError as e:
        print("generate_atrium.py: error: cannot write %s: %s" % (args.out, e.strerror),
              file=sys.stderr)
        return 1
    print("%s: %d triangles, %d textures, %d materials, %.1f MB" % (
        args.out, g.triangles, len(g.doc["textures"]), len(g.doc["materials"]),
        os.path.getsize(args.out) / 1e6))
    return 0


if __name__ == "__main__":
    sys.exit(main())
