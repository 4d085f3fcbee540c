#!/usr/bin/env python3
"""Writes scenes/env/afternoon_sky.hdr: a small generated lat-long environment map (256 x 128,
Radiance RGBE, about 130 KB) for `dofcache render --env`: a blue sky brightening towards the
horizon, a warm sun of about 1.5 degrees 35 degrees above the horizon, a grey-brown ground.
Plain Python, no dependencies; deterministic.

Layout (docs/design.md): the top row is the zenith (+Y), the centre of each row looks towards -Z,
u grows towards +X. The sun sits at azimuth 40 degrees (towards -Z turned towards +X).
"""
import math
import os
import struct
import sys

WIDTH, HEIGHT = 256, 128
SUN_ELEVATION = math.radians(35.0)
SUN_AZIMUTH = math.radians(40.0)
SUN_RADIUS = math.radians(1.5)
SUN_RADIANCE = (3000.0, 2600.0, 2000.0)


def direction(u, v):
    theta, phi = math.pi * v, 2.0 * math.pi * (u - 0.5)
    s = math.sin(theta)
    return (s * math.sin(phi), math.cos(theta), -s * math.cos(phi))


def radiance(d):
    sun = direction(0.5 + SUN_AZIMUTH / (2 * math.pi), 0.5 - SUN_ELEVATION / math.pi)
    cos_sun = sum(a * b for a, b in zip(d, sun))
    if cos_sun > math.cos(SUN_RADIUS):
        return SUN_RADIANCE
    y = d[1]
    if y >= 0.0:
        t = math.sqrt(y)
        sky = [h * (1 - t) + z * t for h, z in zip((1.1, 1.15, 1.25), (0.25, 0.45, 0.95))]
        glow = 0.6 * max(0.0, cos_sun) ** 8  # brighter around the sun
        return tuple(c + glow * w for c, w in zip(sky, (1.0, 0.85, 0.6)))
    t = min(1.0, -y * 8.0)
    return tuple(h * (1 - t) + g * t for h, g in zip((1.1, 1.15, 1.25), (0.22, 0.19, 0.16)))


def rgbe(c):
    m = max(c)
    if m < 1e-32:
        return b"\0\0\0\0"
    mantissa, exponent = math.frexp(m)
    scale = mantissa * 256.0 / m
    return bytes([int(c[0] * scale), int(c[1] * scale), int(c[2] * scale), exponent + 128])


def main(path):
    rows = []
    for y in range(HEIGHT):
        row = bytearray()
        for x in range(WIDTH):
            # Average 3 x 3 points per texel so the sun's disc is anti-aliased.
            acc = [0.0, 0.0, 0.0]
            for sy in range(3):
                for sx in range(3):
                    c = radiance(direction((x + (sx + 0.5) / 3) / WIDTH, (y + (sy + 0.5) / 3) / HEIGHT))
                    acc = [a + b / 9.0 for a, b in zip(acc, c)]
            row += rgbe(acc)
        rows.append(bytes(row))
    os.makedirs(os.path.dirname(path) or ".", exist_ok=True)
    with open(path, "wb") as f:
        f.write(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n")
        f.write(b"-Y %d +X %d\n" % (HEIGHT, WIDTH))
        for row in rows:  # flat (uncompressed) scanlines
            f.write(row)


if __name__ == "__main__":
    main(sys.argv[1] if len(sys.argv) > 1 else
         os.path.join(os.path.dirname(os.path.abspath(__file__)), "env", "afternoon_sky.hdr"))
