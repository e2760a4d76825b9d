#!/usr/bin/env python3
"""Whether two single-part scanline EXRs hold the same channels and pixel
bytes, whatever their header attributes say (a describe() string or a
version differs between two builds). Exit 0 if equal, 1 if not, 2 on error.

    python3 scripts/exr_pixels_equal.py A.exr B.exr
"""
import struct
import sys


def chunks(path):
    data = open(path, "rb").read()
    if data[:4] != b"\x76\x2f\x31\x01":
        raise ValueError(path + ": not an OpenEXR file")
    pos, attrs = 8, {}
    while data[pos] != 0:
        name_end = data.index(b"\0", pos)
        type_end = data.index(b"\0", name_end + 1)
        (size,) = struct.unpack_from("<i", data, type_end + 1)
        value_at = type_end + 5
        attrs[data[pos:name_end]] = data[value_at:value_at + size]
        pos = value_at + size
    pos += 1
    ymin, ymax = struct.unpack_from("<ii", attrs[b"dataWindow"], 4)[0], struct.unpack_from("<i", attrs[b"dataWindow"], 12)[0]
    lines_per_chunk = {0: 1, 1: 1, 2: 1, 3: 16, 4: 32, 5: 16, 6: 32, 7: 32, 8: 256, 9: 256}[attrs[b"compression"][0]]
    count = (ymax - ymin + lines_per_chunk) // lines_per_chunk
    offsets = struct.unpack_from("<%dQ" % count, data, pos)
    out = []
    for off in offsets:
        y, size = struct.unpack_from("<ii", data, off)
        out.append((y, data[off + 8:off + 8 + size]))
    return attrs[b"channels"], attrs[b"compression"], out


try:
    a, b = chunks(sys.argv[1]), chunks(sys.argv[2])
except (OSError, ValueError, KeyError, struct.error) as e:
    print("error:", e, file=sys.stderr)
    sys.exit(2)
sys.exit(0 if a == b else 1)
