"""File formats the scene generators write: PNG textures (8-bit RGB or RGBA, no filter) and
binary glTF (.glb). zlib, json and struct only (no third-party module)."""
import json
import os
import struct
import zlib


def png(width, height, pixel, alpha=False, level=9):
    """pixel(x, y) -> (r, g, b) or, with alpha, (r, g, b, a), 0..255; row 0 is the top.
    level: zlib compression level."""
    raw = bytearray()
    for y in range(height):
        raw.append(0)  # filter: none
        for x in range(width):
            raw.extend(pixel(x, y))

    def chunk(tag, data):
        body = tag + data
        return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body) & 0xffffffff)

    ihdr = struct.pack(">IIBBBBB", width, height, 8, 6 if alpha else 2, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) +
            chunk(b"IDAT", zlib.compress(bytes(raw), level)) + chunk(b"IEND", b""))


def write_glb(path, doc, bin_data):
    """Writes doc (the glTF JSON, its one buffer set here) and bin_data as a .glb, atomically: a
    temporary file, then renamed, so a failure never leaves a half-written scene. bin_data (a
    bytearray) is padded to 4 bytes in place."""
    while len(bin_data) % 4:
        bin_data.append(0)
    doc["buffers"] = [{"byteLength": len(bin_data)}]
    text = json.dumps(doc, separators=(",", ":")).encode()
    while len(text) % 4:
        text += b" "
    total = 12 + 8 + len(text) + 8 + len(bin_data)
    tmp = path + ".tmp"
    try:
        with open(tmp, "wb") as f:
            f.write(struct.pack("<4sII", b"glTF", 2, total))
            f.write(struct.pack("<I4s", len(text), b"JSON") + text)
            f.write(struct.pack("<I4s", len(bin_data), b"BIN\x00") + bytes(bin_data))
        os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.remove(tmp)
        raise
