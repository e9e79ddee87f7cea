#!/usr/bin/env python3
"""Writes the PNG test maps of test_map_formats.cpp and their expected samples, without libpng.

The loader decodes PNGs with libpng; the test checks it against an independent decoder and
encoder, this script (zlib + the PNG specification only). For every PNG it writes a PAM file
(P7, 8-bit samples) holding the pixels as map_server's image loader (SDL_image) hands them over:
16-bit samples keep their high byte, 1/2/4-bit grey is scaled to 0..255, grey + alpha becomes
(g, g, g, a), a palette becomes its colours (plus alpha from tRNS).

    python3 make_png_maps.py        # run in this directory; rewrites the generated files
"""
import struct
import zlib

# Adam7 passes: (x0, y0, dx, dy).
ADAM7 = [(0, 0, 8, 8), (4, 0, 8, 8), (0, 4, 4, 8), (2, 0, 4, 4), (0, 2, 2, 4), (1, 0, 2, 2),
         (0, 1, 1, 2)]
CHANNELS = {0: 1, 2: 3, 3: 1, 4: 2, 6: 4}


def chunk(kind, data):
    body = kind + data
    return struct.pack(">I", len(data)) + body + struct.pack(">I", zlib.crc32(body) & 0xffffffff)


def paeth(a, b, c):
    p = a + b - c
    pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
    return a if pa <= pb and pa <= pc else (b if pb <= pc else c)


def filter_rows(rows, bpp):
    """Filters each scanline with type (row index % 5), so that every filter is exercised."""
    out = bytearray()
    prev = bytes(len(rows[0])) if rows else b""
    for r, line in enumerate(rows):
        ftype = r % 5
        f = bytearray()
        for i, x in enumerate(line):
            a = line[i - bpp] if i >= bpp else 0
            b = prev[i]
            c = prev[i - bpp] if i >= bpp else 0
            pred = [0, a, b, (a + b) // 2, paeth(a, b, c)][ftype]
            f.append((x - pred) & 0xff)
        out += bytes([ftype]) + f
        prev = line
    return bytes(out)


def pack_row(values, bit_depth):
    """Packs one row of samples (ints) at the given bit depth."""
    if bit_depth == 8:
        return bytes(values)
    if bit_depth == 16:
        return b"".join(struct.pack(">H", v) for v in values)
    per = 8 // bit_depth
    out = bytearray()
    for i in range(0, len(values), per):
        byte = 0
        for k in range(per):
            v = values[i + k] if i + k < len(values) else 0
            byte |= v << (8 - bit_depth * (k + 1))
        out.append(byte)
    return bytes(out)


def encode_png(width, height, color_type, bit_depth, samples, palette=None, trns=None,
               interlace=False):
    """samples: flat list, row-major, CHANNELS[color_type] values per pixel."""
    ch = CHANNELS[color_type]
    bpp = max(1, ch * bit_depth // 8)

    def rows_of(xs, ys):
        rows = []
        for y in ys:
            vals = []
            for x in xs:
                vals += samples[(y * width + x) * ch:(y * width + x + 1) * ch]
            rows.append(pack_row(vals, bit_depth))
        return rows

    if interlace:
        raw = b""
        for x0, y0, dx, dy in ADAM7:
            xs, ys = range(x0, width, dx), range(y0, height, dy)
            if len(xs) and len(ys):
                raw += filter_rows(rows_of(xs, ys), bpp)
    else:
        raw = filter_rows(rows_of(range(width), range(height)), bpp)
    png = b"\x89PNG\r\n\x1a\n"
    png += chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, bit_depth, color_type, 0, 0,
                                      1 if interlace else 0))
    if palette is not None:
        png += chunk(b"PLTE", b"".join(bytes(c) for c in palette))
    if trns is not None:
        png += chunk(b"tRNS", bytes(trns))
    png += chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")
    return png


def unfilter(data, pos, width, height, ch, bit_depth):
    """Reconstructs height scanlines of width pixels starting at data[pos]; returns rows, pos."""
    stride = (width * ch * bit_depth + 7) // 8
    bpp = max(1, ch * bit_depth // 8)
    prev = bytearray(stride)
    rows = []
    for _ in range(height):
        ftype = data[pos]
        line = bytearray(data[pos + 1:pos + 1 + stride])
        pos += 1 + stride
        for i in range(stride):
            a = line[i - bpp] if i >= bpp else 0
            b = prev[i]
            c = prev[i - bpp] if i >= bpp else 0
            line[i] = (line[i] + [0, a, b, (a + b) // 2, paeth(a, b, c)][ftype]) & 0xff
        rows.append(bytes(line))
        prev = line
    return rows, pos


def unpack_row(line, count, bit_depth):
    if bit_depth == 8:
        return list(line[:count])
    if bit_depth == 16:
        return [line[2 * i] << 8 | line[2 * i + 1] for i in range(count)]
    per = 8 // bit_depth
    mask = (1 << bit_depth) - 1
    return [(line[i // per] >> (8 - bit_depth * (i % per + 1))) & mask for i in range(count)]


def decode_png(png):
    """Returns (width, height, depth, samples) as SDL_image gives them to map_server."""
    assert png[:8] == b"\x89PNG\r\n\x1a\n"
    pos, idat, palette, trns = 8, b"", None, None
    while pos < len(png):
        (n,) = struct.unpack(">I", png[pos:pos + 4])
        kind, data = png[pos + 4:pos + 8], png[pos + 8:pos + 8 + n]
        pos += 12 + n
        if kind == b"IHDR":
            width, height, bit_depth, color_type, _, _, interlace = struct.unpack(">IIBBBBB", data)
        elif kind == b"PLTE":
            palette = [tuple(data[i:i + 3]) for i in range(0, n, 3)]
        elif kind == b"tRNS":
            trns = list(data)
        elif kind == b"IDAT":
            idat += data
    raw = zlib.decompress(idat)
    ch = CHANNELS[color_type]
    pix = [None] * (width * height)
    passes = ADAM7 if interlace else [(0, 0, 1, 1)]
    p = 0
    for x0, y0, dx, dy in passes:
        xs, ys = range(x0, width, dx), range(y0, height, dy)
        if not (len(xs) and len(ys)):
            continue
        rows, p = unfilter(raw, p, len(xs), len(ys), ch, bit_depth)
        for y, line in zip(ys, rows):
            vals = unpack_row(line, len(xs) * ch, bit_depth)
            for k, x in enumerate(xs):
                pix[y * width + x] = vals[k * ch:(k + 1) * ch]
    out, depth = [], None
    for v in pix:
        if color_type == 3:
            rgb = list(palette[v[0]])
            if trns is not None:
                rgb.append(trns[v[0]] if v[0] < len(trns) else 255)
            px = rgb
        elif bit_depth == 16:
            px = [s >> 8 for s in v]
        elif bit_depth < 8:
            px = [s * 255 // ((1 << bit_depth) - 1) for s in v]
        else:
            px = list(v)
        if color_type == 4:
            px = [px[0], px[0], px[0], px[1]]
        depth = len(px)
        out += px
    return width, height, depth, out


def write_pam(path, width, height, depth, samples):
    header = "P7\nWIDTH %d\nHEIGHT %d\nDEPTH %d\nMAXVAL 255\nENDHDR\n" % (width, height, depth)
    with open(path, "wb") as f:
        f.write(header.encode() + bytes(samples))


def read_pgm(path):
    data = open(path, "rb").read()
    tokens, pos = [], 2
    while len(tokens) < 3:
        while data[pos:pos + 1].isspace():
            pos += 1
        if data[pos:pos + 1] == b"#":
            pos = data.index(b"\n", pos)
            continue
        end = pos
        while data[end:end + 1].isdigit():
            end += 1
        tokens.append(int(data[pos:end]))
        pos = end
    width, height, maxval = tokens
    assert maxval == 255
    return width, height, list(data[pos + 1:pos + 1 + width * height])


def main():
    w, h, _, grey = decode_png(open("ms_spectrum.png", "rb").read())
    n = w * h
    alpha = [0 if i % 5 == 0 else (255 if i % 5 < 3 else 37 * i % 256) for i in range(n)]
    rgb = []
    for i, g in enumerate(grey):
        rgb += [g, (g * 7 + 13) % 256, (255 - g + i) % 256]
    rgba = []
    for i in range(n):
        rgba += rgb[3 * i:3 * i + 3] + [alpha[i]]
    # A palette not ordered by brightness: map_server must see colours, not indices.
    palette = [((k * 73) % 256, (k * 151 + 9) % 256, (255 - k * 29) % 256) for k in range(256)]
    trns = [0 if k % 3 == 0 else (255 if k % 3 == 1 else k) for k in range(200)]
    variants = {
        "png_gray16": (0, 16, [g * 256 + (i % 7) * 31 for i, g in enumerate(grey)], {}),
        "png_gray4": (0, 4, [g >> 4 for g in grey], {}),
        "png_gray2": (0, 2, [g >> 6 for g in grey], {}),
        "png_gray1": (0, 1, [g >> 7 for g in grey], {}),
        "png_gray_alpha": (4, 8, [s for g, a in zip(grey, alpha) for s in (g, a)], {}),
        "png_gray_alpha16": (4, 16, [s * 256 + 5 for g, a in zip(grey, alpha) for s in (g, a)],
                             {}),
        "png_rgb": (2, 8, rgb, {}),
        "png_rgb16": (2, 16, [s * 256 + (s ^ 0x5a) for s in rgb], {}),
        "png_rgba": (6, 8, rgba, {}),
        "png_rgba16": (6, 16, [s * 257 for s in rgba], {}),
        "png_palette": (3, 8, grey, {"palette": palette}),
        "png_palette_trns": (3, 8, grey, {"palette": palette, "trns": trns}),
        "png_palette4": (3, 4, [g >> 4 for g in grey], {"palette": palette[:16]}),
        "png_interlaced": (2, 8, rgb, {"interlace": True}),
        # A tRNS colour key on grey / RGB: SDL_image makes it a colour key, map_server ignores it.
        "png_gray_trns": (0, 4, [g >> 4 for g in grey], {"trns": [0, 8]}),
        "png_rgb_trns": (2, 8, rgb, {"trns": [0, 128, 0, 13, 0, 127]}),
    }
    for name, (color_type, bit_depth, samples, extra) in variants.items():
        png = encode_png(w, h, color_type, bit_depth, samples, **extra)
        open(name + ".png", "wb").write(png)
        write_pam(name + ".pam", *decode_png(png))
    for name in ("ms_spectrum", "ms_testmap", "ms_testmap2"):
        write_pam(name + ".pam", *decode_png(open(name + ".png", "rb").read()))
    tw, th, tgrey = read_pgm("turtlebot3_map.pgm")
    open("turtlebot3_map_png.png", "wb").write(encode_png(tw, th, 0, 8, tgrey))


if __name__ == "__main__":
    main()
