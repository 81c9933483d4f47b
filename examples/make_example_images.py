#!/usr/bin/env python3
"""Writes the small images the example scenes use (procedural, deterministic, stdlib only).

    examples/make_example_images.py            # (re)writes the files below, next to the scenes

  textured/textures/tiles.png         128x128 sRGB colour: terracotta tiles, mortar, speckles
  textured/textures/tiles_height.png  128x128 grey height of the same tiles (bump map)
  textured/textures/ripples_normal.png 64x64 tangent-space normal map of concentric ripples
  environment/sky.pfm                 96x96 linear RGB equal-area (pbrt-v4 octahedral) sky,
                                      box-filtered over 4x4 samples per pixel:
                                      blue gradient, warm horizon, dark ground and a small sun
                                      of 5 degrees radius, 35 degrees above the horizon

The files are committed (each well under 200 KB); run this only to change them. The output is
the same on every machine: integer hashing, no random module, no floating-point formatting.
"""
import math
import os
import struct
import zlib

HERE = os.path.dirname(os.path.abspath(__file__))


def hash01(x, y, salt):
    """Uniform in [0, 1) from integer coordinates (a 32-bit integer hash)."""
    h = (x * 0x8DA6B343 + y * 0xD8163841 + salt * 0xCB1AB31F) & 0xFFFFFFFF
    h ^= h >> 13
    h = (h * 0x5BD1E995) & 0xFFFFFFFF
    h ^= h >> 15
    return h / 4294967296.0


def write_png(path, width, height, channels, rows):
    """8-bit PNG (channels 1 = grey, 3 = RGB); rows: lists of ints 0..255, channels per pixel."""
    color_type = {1: 0, 3: 2}[channels]
    raw = b"".join(b"\x00" + bytes(row) for row in rows)

    def chunk(tag, data):
        return (struct.pack(">I", len(data)) + tag + data
                + struct.pack(">I", zlib.crc32(tag + data) & 0xFFFFFFFF))

    png = (b"\x89PNG\r\n\x1a\n"
           + chunk(b"IHDR", struct.pack(">IIBBBBB", width, height, 8, color_type, 0, 0, 0))
           + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b""))
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "wb") as f:
        f.write(png)


def write_pfm(path, width, height, pixels):
    """Little-endian RGB PFM; pixels[y][x] = (r, g, b) with y = 0 the top row."""
    os.makedirs(os.path.dirname(path), exist_ok=True)
    with open(path, "wb") as f:
        f.write(b"PF\n%d %d\n-1.0\n" % (width, height))
        for y in reversed(range(height)):  # PFM stores the bottom row first
            f.write(b"".join(struct.pack("<3f", *pixels[y][x]) for x in range(width)))


def tiles():
    """Running-bond tiles: 4 x 8 tiles over the image, 3-pixel mortar."""
    n = 128
    colour, height = [], []
    for y in range(n):
        crow, hrow = [], []
        row = y // 16
        for x in range(n):
            xs = x + (16 if row % 2 else 0)  # every other row shifted by half a tile
            tile = (xs // 32) % 4 + 4 * row
            in_mortar = (y % 16) < 2 or (xs % 32) < 3
            speck = hash01(x, y, 1)
            if in_mortar:
                c = [178, 172, 160]
                hgt = 40
            else:
                tint = hash01(tile, row, 2)
                base = (168 + int(40 * tint), 78 + int(30 * tint), 52 + int(14 * tint))
                dark = 0.82 + 0.18 * speck
                c = [int(v * dark) for v in base]
                # Slightly domed tiles: higher in the middle.
                u = ((xs % 32) - 1.5) / 29.0
                v = ((y % 16) - 1.0) / 14.0
                hgt = int(170 + 60 * math.sin(math.pi * min(max(u, 0), 1))
                          * math.sin(math.pi * min(max(v, 0), 1)) + 20 * speck)
            crow += c
            hrow.append(min(255, hgt))
        colour.append(crow)
        height.append(hrow)
    write_png(os.path.join(HERE, "textured", "textures", "tiles.png"), n, n, 3, colour)
    write_png(os.path.join(HERE, "textured", "textures", "tiles_height.png"), n, n, 1, height)


def ripples_normal():
    """Tangent-space normals (x, y, z) * 0.5 + 0.5 of a height sin(r) around the centre."""
    n = 64
    rows = []
    for y in range(n):
        row = []
        for x in range(n):
            dx, dy = (x + 0.5) / n - 0.5, (y + 0.5) / n - 0.5
            r = math.hypot(dx, dy) + 1e-9
            slope = 0.6 * math.cos(r * 40.0)
            nx, ny = -slope * dx / r, -slope * dy / r
            inv = 1.0 / math.sqrt(nx * nx + ny * ny + 1.0)
            row += [int(round(255 * (0.5 + 0.5 * c))) for c in (nx * inv, ny * inv, inv)]
        rows.append(row)
    write_png(os.path.join(HERE, "textured", "textures", "ripples_normal.png"), n, n, 3, rows)


def equal_area_square_to_sphere(u, v):
    """pbrt-v4's EqualAreaSquareToSphere: (u, v) in [0,1]^2 -> unit vector, +z up."""
    u, v = 2 * u - 1, 2 * v - 1
    up, vp = abs(u), abs(v)
    signed = 1 - (up + vp)
    r = 1 - abs(signed)
    phi = (1 if r == 0 else (vp - up) / r + 1) * math.pi / 4
    z = math.copysign(1 - r * r, signed)
    s = r * math.sqrt(max(0.0, 2 - r * r))
    return (math.copysign(math.cos(phi), u) * s, math.copysign(math.sin(phi), v) * s, z)


def sky():
    n = 96
    elev, azim = math.radians(35), math.radians(-60)
    sun = (math.cos(elev) * math.cos(azim), math.cos(elev) * math.sin(azim), math.sin(elev))
    cos_sun = math.cos(math.radians(5.0))
    def radiance(d):
        h = d[2]  # sine of the elevation
        if sum(a * b for a, b in zip(d, sun)) > cos_sun:
            return (220.0, 200.0, 170.0)
        if h < 0:
            return (0.09, 0.08, 0.07)
        t = (1 - h) ** 4
        return (0.6 * (0.25 + 0.75 * t), 0.6 * (0.42 + 0.48 * t), 0.6 * (0.95 - 0.2 * t))

    # 4 x 4 samples per pixel: the horizon and the sun's rim are box-filtered, not jagged.
    k = 4
    pixels = []
    for y in range(n):
        row = []
        for x in range(n):
            acc = [0.0, 0.0, 0.0]
            for j in range(k):
                for i in range(k):
                    d = equal_area_square_to_sphere((x + (i + 0.5) / k) / n,
                                                    (y + (j + 0.5) / k) / n)
                    acc = [a + b for a, b in zip(acc, radiance(d))]
            row.append(tuple(a / (k * k) for a in acc))
        pixels.append(row)
    write_pfm(os.path.join(HERE, "environment", "sky.pfm"), n, n, pixels)


if __name__ == "__main__":
    tiles()
    ripples_normal()
    sky()
    print("wrote textured/textures/{tiles,tiles_height,ripples_normal}.png, environment/sky.pfm")
