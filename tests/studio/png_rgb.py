"""A PNG's pixels as rows of bytes, with nothing but the standard library (the tests' system Python
has no imaging package): 8-bit RGB or RGBA, not interlaced, which is what Qt writes."""
import struct
import zlib


def png_rgb(path):
    """(width, height, bytes a pixel, rows): rows[y][bpp * x + k] is channel k of pixel (x, y)."""
    data = open(path, "rb").read()
    pos, idat, w, h, bpp = 8, b"", 0, 0, 3
    while pos < len(data):
        n, kind = struct.unpack_from(">I4s", data, pos)
        body = data[pos + 8:pos + 8 + n]
        if kind == b"IHDR":
            w, h, depth, ctype = struct.unpack_from(">IIBB", body)
            assert depth == 8 and ctype in (2, 6), (depth, ctype)
            bpp = 3 if ctype == 2 else 4
        elif kind == b"IDAT":
            idat += body
        pos += 12 + n
    raw, rows, prev, i = zlib.decompress(idat), [], bytearray(w * bpp), 0
    for y in range(h):
        f, line = raw[i], bytearray(raw[i + 1:i + 1 + w * bpp])
        i += 1 + w * bpp
        for x in range(len(line)):
            a = line[x - bpp] if x >= bpp else 0
            b, c = prev[x], prev[x - bpp] if x >= bpp else 0
            if f == 1: line[x] = (line[x] + a) & 255
            elif f == 2: line[x] = (line[x] + b) & 255
            elif f == 3: line[x] = (line[x] + (a + b) // 2) & 255
            elif f == 4:
                p = a + b - c
                pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
                line[x] = (line[x] + (a if pa <= pb and pa <= pc else b if pb <= pc else c)) & 255
        rows.append(line)
        prev = line
    return w, h, bpp, rows


def pixels_near(path, x, y, colour, left=40, right=80, up=40, down=40, tolerance=8):
    """How many pixels within the box around (x, y) are `colour` ('#rrggbb'), each channel within tolerance."""
    w, h, bpp, rows = png_rgb(path)
    want = tuple(int(colour[k:k + 2], 16) for k in (1, 3, 5))
    return sum(1 for yy in range(max(0, int(y) - up), min(h, int(y) + down))
               for xx in range(max(0, int(x) - left), min(w, int(x) + right))
               if all(abs(rows[yy][bpp * xx + k] - want[k]) <= tolerance for k in range(3)))
