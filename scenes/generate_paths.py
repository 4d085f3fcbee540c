#!/usr/bin/env python3
"""Writes the shipped camera paths next to this file (python3 standard library only).

    python3 scenes/generate_paths.py

Outputs (docs/sequence.md):
  cornell_box_dolly.gltf         cornell_box.gltf plus a glTF animation "dolly" on the camera node:
                                 a slow dolly-in of 0.13 m with a small truck to the right over two
                                 seconds (translation CUBICSPLINE with zero end tangents: ease in and
                                 out), yawing 1.7 degrees to keep the boxes framed (rotation LINEAR).
                                 The focus stays at the scene's 1.13 m, so the short box drifts
                                 slowly out of focus as the camera approaches it.
  paths/cornell_focus_pull.json  a keyframe file for cornell_box.gltf: the camera holds still and
                                 the focus pulls from the sphere (0.97 m) to the tall box (1.30 m)
                                 over 1.5 seconds, eased in and out ("smooth").
  paths/gallery_walk.json        a keyframe file for gallery.glb: a 48-frame walk of 4.8 m down the
                                 gallery, turning slightly left, the focus held on the red sphere
                                 as the camera nears it, then racked to the gold ring further on.

The geometry is copied from cornell_box.gltf unchanged, so both render the same scene (same
content hash) and a cache saved from one can be used with the other.
"""
import base64
import json
import math
import os
import struct

HERE = os.path.dirname(os.path.abspath(__file__))
CAMERA_NODE = "camera"


def add_accessor(doc, blob, values, kind):
    """Appends float data to the animation buffer (buffer 1) and returns the accessor index."""
    offset = len(blob)
    blob += struct.pack("<%df" % len(values), *values)
    doc["bufferViews"].append({"buffer": 1, "byteOffset": offset, "byteLength": 4 * len(values)})
    components = {"SCALAR": 1, "VEC3": 3, "VEC4": 4}[kind]
    accessor = {"bufferView": len(doc["bufferViews"]) - 1, "componentType": 5126,
                "count": len(values) // components, "type": kind}
    if kind == "SCALAR":
        accessor["min"] = [min(values)]
        accessor["max"] = [max(values)]
    doc["accessors"].append(accessor)
    return len(doc["accessors"]) - 1


def yaw_quaternion(degrees):
    h = math.radians(degrees) / 2.0
    return [0.0, round(math.sin(h), 6), 0.0, round(math.cos(h), 6)]


def cornell_dolly():
    with open(os.path.join(HERE, "cornell_box.gltf"), encoding="utf-8") as f:
        doc = json.load(f)
    camera = [i for i, n in enumerate(doc["nodes"]) if n.get("name") == CAMERA_NODE][0]
    eye = doc["nodes"][camera]["translation"]
    end = [eye[0] + 0.03, eye[1], eye[2] - 0.13]
    blob = bytearray()
    times = add_accessor(doc, blob, [0.0, 2.0], "SCALAR")
    # CUBICSPLINE: per key in-tangent, value, out-tangent; zero tangents ease in and out.
    zero = [0.0, 0.0, 0.0]
    translation = add_accessor(doc, blob, zero + eye + zero + zero + end + zero, "VEC3")
    rotation = add_accessor(doc, blob, yaw_quaternion(0.0) + yaw_quaternion(1.7), "VEC4")
    doc["buffers"].append({"byteLength": len(blob),
                           "uri": "data:application/octet-stream;base64," +
                                  base64.b64encode(bytes(blob)).decode()})
    doc["animations"] = [{
        "name": "dolly",
        "samplers": [{"input": times, "output": translation, "interpolation": "CUBICSPLINE"},
                     {"input": times, "output": rotation, "interpolation": "LINEAR"}],
        "channels": [{"sampler": 0, "target": {"node": camera, "path": "translation"}},
                     {"sampler": 1, "target": {"node": camera, "path": "rotation"}}],
    }]
    doc["asset"]["generator"] = "dofcache scenes/generate_paths.py (cornell_box.gltf + dolly)"
    path = os.path.join(HERE, "cornell_box_dolly.gltf")
    with open(path, "w", encoding="utf-8") as f:
        json.dump(doc, f, indent=1)
        f.write("\n")
    print("%s: camera node %d, %s -> %s over 2 s, yaw 0 -> 1.7 deg" % (
        os.path.basename(path), camera, eye, end))


def cornell_focus_pull():
    path = {
        "dofcache_camera_path": 1,
        "description": "Focus pull on cornell_box.gltf: from the sphere to the tall box, camera still",
        "scene": "../cornell_box.gltf",
        "fps": 24,
        "interpolation": "smooth",
        "keys": [
            {"frame": 0, "focus_distance": 0.97},
            {"frame": 35, "focus_distance": 1.30},
        ],
    }
    os.makedirs(os.path.join(HERE, "paths"), exist_ok=True)
    out = os.path.join(HERE, "paths", "cornell_focus_pull.json")
    with open(out, "w", encoding="utf-8") as f:
        json.dump(path, f, indent=2)
        f.write("\n")
    print("paths/cornell_focus_pull.json: focus 0.97 -> 1.30 m over frames 0-35 at 24 fps")


def gallery_walk():
    """Keys every 14-17 frames along a straight walk (Catmull-Rom through evenly spaced keys: a
    steady pace, eased at both ends); the focus distance of each key is the axial distance of the
    object it holds (as generate_scenes.py computes a camera's focus)."""
    red_sphere, gold_ring = (-0.75, 1.05, -1.0), (-0.75, 1.0, -5.0)
    start, end = (0.0, 1.6, 1.5), (0.15, 1.55, -3.3)
    look_start, look_end = (0.0, 1.3, -10.0), (-0.6, 1.2, -10.0)
    keys = []
    for frame, subject in ((0, red_sphere), (14, red_sphere), (30, gold_ring), (47, gold_ring)):
        t = frame / 47.0
        eye = [round(a + (b - a) * t, 4) for a, b in zip(start, end)]
        target = [round(a + (b - a) * t, 4) for a, b in zip(look_start, look_end)]
        forward = [b - a for a, b in zip(eye, target)]
        norm = math.sqrt(sum(f * f for f in forward))
        focus = sum((o - e) * f / norm for o, e, f in zip(subject, eye, forward))
        keys.append({"frame": frame, "position": eye, "target": target,
                     "focus_distance": round(focus, 4)})
    path = {
        "dofcache_camera_path": 1,
        "description": "Walk-through of gallery.glb: 4.8 m in 48 frames, focus on the red sphere, "
                       "then racked to the gold ring",
        "scene": "../gallery.glb",
        "fps": 24,
        "interpolation": "smooth",
        "keys": keys,
    }
    out = os.path.join(HERE, "paths", "gallery_walk.json")
    with open(out, "w", encoding="utf-8") as f:
        json.dump(path, f, indent=2)
        f.write("\n")
    print("paths/gallery_walk.json: frames 0-47, focus %s m" %
          " -> ".join("%.2f" % k["focus_distance"] for k in keys))


if __name__ == "__main__":
    cornell_dolly()
    cornell_focus_pull()
    gallery_walk()
