"""A PNG encoder for the scene generators: 8-bit RGB or RGBA, no filter, zlib + struct only (no
third-party module)."""
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
