#!/usr/bin/env python3
"""Writes the text-format seed corpora: corpus/gltf (small .gltf and .glb files that between them
use every feature the loader reads: indexed and unindexed triangles, strips and fans, normals,
two texture coordinate sets, quantised attributes, PNG and JPEG textures from data URIs and
buffer views, samplers, emissive strength, punctual lights, a camera with extras.lens, a node
matrix, animations of the camera node, sparse accessors, COLOR_0, TANGENT, normal textures,
KHR_texture_transform and alpha modes) and corpus/keyframe (keyframe files).
The shipped scenes are too large to seed with (they are mostly base64 vertex data).
Usage: make_seeds.py <corpus directory>   (needs oiiotool for the JPEG)"""
import base64
import json
import os
import struct
import subprocess
import sys
import tempfile
import zlib


def png(width, height, rgba):
    rows = b"".join(b"\0" + bytes(rgba) * width for _ in range(height))

    def chunk(tag, data):
        return (struct.pack(">I", len(data)) + tag + data +
                struct.pack(">I", zlib.crc32(tag + data) & 0xffffffff))
    ihdr = struct.pack(">IIBBBBB", width, height, 8, 6, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(rows)) +
            chunk(b"IEND", b""))


def jpeg():
    with tempfile.TemporaryDirectory() as d:
        path = os.path.join(d, "t.jpg")
        subprocess.run(["oiiotool", "--pattern", "checker:width=2:height=2", "4x4", "3",
                        "-o", path], check=True)
        return open(path, "rb").read()


class Builder:
    """A glTF document with one binary buffer that views and accessors are appended to."""

    def __init__(self):
        self.bin = bytearray()
        self.doc = {"asset": {"version": "2.0"}, "bufferViews": [], "accessors": []}

    def view(self, data, target=None):
        while len(self.bin) % 4:
            self.bin.append(0)
        v = {"buffer": 0, "byteOffset": len(self.bin), "byteLength": len(data)}
        if target:
            v["target"] = target
        self.bin += data
        self.doc["bufferViews"].append(v)
        return len(self.doc["bufferViews"]) - 1

    def accessor(self, fmt, values, kind, component, normalized=False, minmax=False):
        flat = [x for v in values for x in (v if isinstance(v, (list, tuple)) else [v])]
        a = {"bufferView": self.view(struct.pack("<%d%s" % (len(flat), fmt), *flat)),
             "componentType": component, "count": len(values), "type": kind}
        if normalized:
            a["normalized"] = True
        if minmax:
            a["min"] = [min(v[i] for v in values) for i in range(3)]
            a["max"] = [max(v[i] for v in values) for i in range(3)]
        self.doc["accessors"].append(a)
        return len(self.doc["accessors"]) - 1

    def gltf(self):
        doc = dict(self.doc)
        doc["buffers"] = [{"byteLength": len(self.bin), "uri": "data:application/octet-stream;"
                           "base64," + base64.b64encode(bytes(self.bin)).decode()}]
        return json.dumps(doc, separators=(",", ":")).encode()

    def glb(self):
        doc = dict(self.doc)
        doc["buffers"] = [{"byteLength": len(self.bin)}]
        js = json.dumps(doc, separators=(",", ":")).encode()
        js += b" " * (-len(js) % 4)
        binary = bytes(self.bin) + b"\0" * (-len(self.bin) % 4)
        body = (struct.pack("<I4s", len(js), b"JSON") + js +
                struct.pack("<I4s", len(binary), b"BIN\0") + binary)
        return struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body


FLOAT, U8, U16, U32 = 5126, 5121, 5123, 5125
QUAD = [(-1, -1, 0), (1, -1, 0), (1, 1, 0), (-1, 1, 0)]


def textured_scene(image_in_buffer):
    b = Builder()
    pos = b.accessor("f", QUAD, "VEC3", FLOAT, minmax=True)
    nrm = b.accessor("f", [(0, 0, 1)] * 4, "VEC3", FLOAT)
    uv0 = b.accessor("f", [(0, 0), (1, 0), (1, 1), (0, 1)], "VEC2", FLOAT)
    idx = b.accessor("H", [0, 1, 2, 0, 2, 3], "SCALAR", U16)
    png_bytes = png(2, 2, [200, 100, 50, 255])
    if image_in_buffer:
        images = [{"bufferView": b.view(png_bytes), "mimeType": "image/png"},
                  {"bufferView": b.view(jpeg()), "mimeType": "image/jpeg"}]
    else:
        images = [{"uri": "data:image/png;base64," + base64.b64encode(png_bytes).decode()},
                  {"uri": "data:image/jpeg;base64," + base64.b64encode(jpeg()).decode()}]
    times = b.accessor("f", [0.0, 1.0], "SCALAR", FLOAT)
    moves = b.accessor("f", [(0, 0, 4), (0.5, 0, 3.5)], "VEC3", FLOAT)
    b.doc.update({
        "extensionsUsed": ["KHR_lights_punctual", "KHR_materials_emissive_strength"],
        "scene": 0,
        "scenes": [{"name": "main", "nodes": [0, 1, 2]}],
        "nodes": [
            {"name": "quad", "mesh": 0, "rotation": [0, 0, 0, 1], "scale": [2, 2, 1]},
            {"name": "cam", "camera": 0, "translation": [0, 0, 4],
             "extras": {"lens": {"fstop": 2.8}}},
            {"name": "lamp", "translation": [0, 2, 2],
             "extensions": {"KHR_lights_punctual": {"light": 0}}}],
        "cameras": [{"type": "perspective", "perspective": {
            "yfov": 0.7, "aspectRatio": 1.5, "znear": 0.01},
            "extras": {"lens": {"focal_length": 0.05, "focus_distance": 4}}}],
        "meshes": [{"name": "quad", "primitives": [{
            "attributes": {"POSITION": pos, "NORMAL": nrm, "TEXCOORD_0": uv0},
            "indices": idx, "material": 0, "mode": 4}]}],
        "materials": [{"name": "tex", "pbrMetallicRoughness": {
            "baseColorFactor": [1, 1, 1, 1], "baseColorTexture": {"index": 0},
            "metallicRoughnessTexture": {"index": 1}, "metallicFactor": 0.2,
            "roughnessFactor": 0.6},
            "emissiveFactor": [0.1, 0.1, 0.1], "emissiveTexture": {"index": 0},
            "extensions": {"KHR_materials_emissive_strength": {"emissiveStrength": 2}},
            "doubleSided": True}],
        "textures": [{"source": 0, "sampler": 0}, {"source": 1}],
        "samplers": [{"magFilter": 9728, "wrapS": 33071, "wrapT": 33648}],
        "images": images,
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"type": "point", "color": [1, 0.9, 0.8], "intensity": 20}]}},
        "animations": [{"name": "dolly", "channels": [
            {"sampler": 0, "target": {"node": 1, "path": "translation"}}],
            "samplers": [{"input": times, "output": moves, "interpolation": "LINEAR"}]}],
    })
    return b


def strips_and_fans():
    b = Builder()
    pos = b.accessor("f", QUAD + [(0, 0, -1)], "VEC3", FLOAT, minmax=True)
    uv = b.accessor("B", [(0, 0), (255, 0), (255, 255), (0, 255), (128, 128)], "VEC2", U8,
                    normalized=True)
    uv1 = b.accessor("H", [(0, 0), (65535, 0), (65535, 65535), (0, 65535), (9, 9)], "VEC2", U16,
                     normalized=True)
    strip = b.accessor("B", [0, 1, 3, 2, 2, 4], "SCALAR", U8)
    fan = b.accessor("I", [4, 0, 1, 2, 3, 0], "SCALAR", U32)
    times = b.accessor("f", [0.0, 1.0, 2.0], "SCALAR", FLOAT)
    # CUBICSPLINE: in-tangent, value, out-tangent per key.
    rots = b.accessor("f", [(0, 0, 0, 0), (0, 0, 0, 1), (0, 0, 0, 0),
                            (0, 0, 0, 0), (0, 0.38268, 0, 0.92388), (0, 0, 0, 0),
                            (0, 0, 0, 0), (0, 0.70711, 0, 0.70711), (0, 0, 0, 0)],
                      "VEC4", FLOAT)
    b.doc.update({
        "extensionsUsed": ["KHR_mesh_quantization", "KHR_lights_punctual"],
        "extensionsRequired": ["KHR_mesh_quantization"],
        "scenes": [{"nodes": [0]}, {"nodes": [3]}],
        "nodes": [
            {"name": "root", "children": [1, 2],
             "matrix": [1, 0, 0, 0, 0, 1, 0, 0, 0, 0, 1, 0, 0, 0.5, 0, 1]},
            {"name": "shape", "mesh": 0, "scale": [-1, 1, 1]},
            {"name": "rig", "rotation": [0, 0, 0, 1], "children": [4]},
            {"name": "other", "mesh": 0},
            {"name": "view", "camera": 0, "translation": [0, 0, 5],
             "extensions": {"KHR_lights_punctual": {"light": 0}}}],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.9, "znear": 0.1}}],
        "meshes": [{"primitives": [
            {"attributes": {"POSITION": pos, "TEXCOORD_0": uv, "TEXCOORD_1": uv1},
             "indices": strip, "mode": 5, "material": 0},
            {"attributes": {"POSITION": pos}, "indices": fan, "mode": 6},
            {"attributes": {"POSITION": pos}, "mode": 1}]}],
        "materials": [{"emissiveFactor": [1, 1, 1], "alphaMode": "BLEND"}],
        "extensions": {"KHR_lights_punctual": {"lights": [
            {"type": "spot", "intensity": 5, "range": 10,
             "spot": {"innerConeAngle": 0.2, "outerConeAngle": 0.6}}]}},
        "animations": [{"channels": [
            {"sampler": 0, "target": {"node": 2, "path": "rotation"}}],
            "samplers": [{"input": times, "output": rots, "interpolation": "CUBICSPLINE"}]}],
    })
    return b


def unindexed_flat():
    b = Builder()
    pos = b.accessor("f", [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 0, 1), (0, 1, 1)],
                     "VEC3", FLOAT, minmax=True)
    b.doc.update({"nodes": [{"mesh": 0}],
                  "meshes": [{"primitives": [{"attributes": {"POSITION": pos}}]}]})
    return b


def material_features():
    """Sparse accessors (with and without a base view), COLOR_0, TANGENT, a normal texture,
    KHR_texture_transform on two textures, alphaMode MASK and BLEND, single and double sides."""
    b = Builder()
    base = b.view(struct.pack("<12f", *[c for v in QUAD for c in v]))
    sparse_idx = b.view(struct.pack("<2H", 1, 3))
    sparse_val = b.view(struct.pack("<6f", 2, -1, 0, -2, 1, 0))
    b.doc["accessors"].append({
        "bufferView": base, "componentType": FLOAT, "count": 4, "type": "VEC3",
        "sparse": {"count": 2, "indices": {"bufferView": sparse_idx, "componentType": U16},
                   "values": {"bufferView": sparse_val}}})
    pos = len(b.doc["accessors"]) - 1
    zero_idx = b.view(struct.pack("<B", 2) + b"\0\0\0")
    zero_val = b.view(struct.pack("<2f", 0.5, 0.5))
    b.doc["accessors"].append({
        "componentType": FLOAT, "count": 4, "type": "VEC2",
        "sparse": {"count": 1, "indices": {"bufferView": zero_idx, "componentType": U8},
                   "values": {"bufferView": zero_val}}})
    uv1 = len(b.doc["accessors"]) - 1
    uv0 = b.accessor("f", [(0, 0), (1, 0), (1, 1), (0, 1)], "VEC2", FLOAT)
    nrm = b.accessor("f", [(0, 0, 1)] * 4, "VEC3", FLOAT)
    tan = b.accessor("f", [(1, 0, 0, 1)] * 4, "VEC4", FLOAT)
    col = b.accessor("B", [(255, 128, 0, 255), (0, 255, 0, 128), (0, 0, 255, 64),
                           (255, 255, 255, 0)], "VEC4", U8, normalized=True)
    col3 = b.accessor("f", [(1, 0.5, 0.25)] * 4, "VEC3", FLOAT)
    idx = b.accessor("H", [0, 1, 2, 0, 2, 3], "SCALAR", U16)
    transform = {"KHR_texture_transform": {"offset": [0.5, 0.25], "rotation": 0.3,
                                           "scale": [2, 0.5], "texCoord": 1}}
    b.doc.update({
        "extensionsUsed": ["KHR_texture_transform"],
        "extensionsRequired": ["KHR_texture_transform"],
        "nodes": [{"mesh": 0}, {"mesh": 0, "translation": [0, 0, -1]}],
        "meshes": [{"primitives": [
            {"attributes": {"POSITION": pos, "NORMAL": nrm, "TEXCOORD_0": uv0,
                            "TEXCOORD_1": uv1, "TANGENT": tan, "COLOR_0": col},
             "indices": idx, "material": 0},
            {"attributes": {"POSITION": pos, "TEXCOORD_0": uv0, "COLOR_0": col3},
             "indices": idx, "material": 1}]}],
        "materials": [
            {"alphaMode": "MASK", "alphaCutoff": 0.4,
             "pbrMetallicRoughness": {"baseColorTexture": {"index": 0,
                                                           "extensions": transform}},
             "normalTexture": {"index": 0, "scale": 0.5, "texCoord": 1,
                               "extensions": {"KHR_texture_transform": {"offset": [0.1, 0]}}}},
            {"alphaMode": "BLEND", "doubleSided": True,
             "pbrMetallicRoughness": {"baseColorFactor": [1, 1, 1, 0.5]},
             "normalTexture": {"index": 0}}],
        "textures": [{"source": 0}],
        "images": [{"uri": "data:image/png;base64," +
                    base64.b64encode(png(2, 2, [128, 128, 255, 200])).decode()}],
    })
    return b


KEYFRAMES = {
    "focus_pull.json": None,  # scenes/paths/cornell_focus_pull.json
    "look_at.json": {"dofcache_camera_path": 1, "fps": 10, "up": [0, 1, 0], "keys": [
        {"frame": 0, "position": [0, 0, 5], "target": [0, 0, 0], "focus_distance": 5,
         "fstop": 2},
        {"frame": 10, "position": [1, 0, 5], "target": [1, 0, 0], "focus_distance": 3},
        {"time": 2.0, "position": [1, 0, 5], "target": [1, 1, 0], "yfov": 0.6}]},
    "rotation_step.json": {"dofcache_camera_path": 1, "interpolation": "step", "keys": [
        {"time": 0, "rotation": [0, 0, 0, 1], "focal_length": 0.035},
        {"time": 1, "rotation": [0, 0.70711, 0, 0.70711], "focal_length": 0.05}]},
    "smooth_rotation.json": {"dofcache_camera_path": 1, "interpolation": "smooth",
                             "description": "three keys", "keys": [
        {"time": 0, "position": [0, 0, 3], "rotation": [0, 0, 0, 1]},
        {"time": 0.5, "position": [0, 1, 3], "rotation": [0, 0.38268, 0, 0.92388]},
        {"time": 1.5, "position": [1, 1, 3], "rotation": [0, -0.38268, 0, -0.92388]}]},
}


def main():
    root = sys.argv[1]
    here = os.path.dirname(os.path.abspath(__file__))
    gltf_dir, key_dir = os.path.join(root, "gltf"), os.path.join(root, "keyframe")
    os.makedirs(gltf_dir, exist_ok=True)
    os.makedirs(key_dir, exist_ok=True)
    seeds = {"textured.gltf": textured_scene(False).gltf(),
             "textured.glb": textured_scene(True).glb(),
             "strips_fans.gltf": strips_and_fans().gltf(),
             "strips_fans.glb": strips_and_fans().glb(),
             "unindexed.gltf": unindexed_flat().gltf(),
             "material_features.gltf": material_features().gltf()}
    for name, data in seeds.items():
        open(os.path.join(gltf_dir, name), "wb").write(data)
    for name, doc in KEYFRAMES.items():
        if doc is None:
            src = os.path.join(here, "..", "..", "scenes", "paths", "cornell_focus_pull.json")
            data = open(src, "rb").read()
        else:
            data = json.dumps(doc, indent=1).encode()
        open(os.path.join(key_dir, name), "wb").write(data)


if __name__ == "__main__":
    main()
