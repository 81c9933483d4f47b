#!/usr/bin/env python3
"""Writes the small images the fidelity scenes read (scenes/textures/), deterministically.

Python's standard library writes them as PPM / PFM; oiiotool (OpenImageIO, which Tessera's
set-up installs) converts them to PNG (8-bit, sRGB-encoded) and EXR (half, linear). Run from
anywhere: python3 tests/fidelity/make_images.py
"""
import math
import os
import struct
import subprocess
import tempfile

OUT = os.path.join(os.path.dirname(os.path.abspath(__file__)), 'scenes', 'textures')


def srgb_encode(v):
    v = min(max(v, 0.0), 1.0)
    return 12.92 * v if v <= 0.0031308 else 1.055 * v ** (1 / 2.4) - 0.055


def write_ppm(path, w, h, pixel):
    """pixel(x, y) -> (r, g, b) in [0, 1], already encoded; row 0 is the top."""
    with open(path, 'wb') as f:
        f.write(b'P6\n%d %d\n255\n' % (w, h))
        for y in range(h):
            for x in range(w):
                f.write(bytes(max(0, min(255, int(round(c * 255)))) for c in pixel(x, y)))


def write_pfm(path, w, h, pixel):
    """pixel(x, y) -> (r, g, b) linear floats; row 0 is the top (PFM stores bottom first)."""
    with open(path, 'wb') as f:
        f.write(b'PF\n%d %d\n-1.0\n' % (w, h))
        for y in reversed(range(h)):
            for x in range(w):
                f.write(struct.pack('<3f', *pixel(x, y)))


def convert(src, dst, half=False):
    cmd = ['oiiotool', src]
    if half:
        cmd += ['-d', 'half', '--compression', 'zip']
    subprocess.run(cmd + ['-o', dst], check=True)


def equal_area_square_to_sphere(u, v):
    """pbrt-v4's EqualAreaSquareToSphere (Clarberg 2008), [0,1]^2 -> unit vector."""
    u, v = 2 * u - 1, 2 * v - 1
    up, vp = abs(u), abs(v)
    sd = 1 - (up + vp)
    d = abs(sd)
    r = 1 - d
    phi = (math.pi / 4 if r == 0 else ((vp - up) / r + 1) * math.pi / 4)
    z = math.copysign(1 - r * r, sd)
    cos_phi = math.copysign(math.cos(phi), u)
    sin_phi = math.copysign(math.sin(phi), v)
    s = r * math.sqrt(max(0.0, 2 - r * r))
    return (cos_phi * s, sin_phi * s, z)


def main():
    os.makedirs(OUT, exist_ok=True)
    tmp = tempfile.mkdtemp()

    # grid.png: a 64x64 coloured checker (8 squares a side) with a soft ramp, sRGB-encoded.
    def grid(x, y):
        c = ((x // 8) + (y // 8)) % 2
        t = x / 63.0
        base = (0.15 + 0.6 * c, 0.2 + 0.5 * c * (1 - t) + 0.2 * t, 0.25 + 0.4 * (1 - c) * t + 0.2 * c)
        return tuple(srgb_encode(b) for b in base)
    write_ppm(os.path.join(tmp, 'grid.ppm'), 64, 64, grid)
    convert(os.path.join(tmp, 'grid.ppm'), os.path.join(OUT, 'grid.png'))

    # ramp.exr: linear float grey, a smooth 2D variation in [0.1, 0.9].
    def ramp(x, y):
        v = 0.5 + 0.4 * math.sin(2 * math.pi * x / 32.0) * math.cos(2 * math.pi * y / 32.0)
        return (v, v, v)
    write_pfm(os.path.join(tmp, 'ramp.pfm'), 32, 32, ramp)
    convert(os.path.join(tmp, 'ramp.pfm'), os.path.join(OUT, 'ramp.exr'), half=True)

    # normal.png: a tangent-space normal map of smooth bumps h = 0.15 sin(kx) sin(ky),
    # encoded (n + 1) / 2, linear (pbrt-v4 reads normal maps without the sRGB curve).
    def normal(x, y):
        k = 2 * math.pi / 16.0
        dhdx = 0.15 * k * math.cos(k * (x + 0.5)) * math.sin(k * (y + 0.5))
        dhdy = 0.15 * k * math.sin(k * (x + 0.5)) * math.cos(k * (y + 0.5))
        n = (-dhdx, dhdy, 1.0)
        l = math.sqrt(sum(c * c for c in n))
        return tuple((c / l + 1) / 2 for c in n)
    write_ppm(os.path.join(tmp, 'normal.ppm'), 64, 64, normal)
    convert(os.path.join(tmp, 'normal.ppm'), os.path.join(OUT, 'normal.png'))

    # env.exr: an equal-area environment (pbrt-v4's layout for image infinite lights): a sky
    # gradient, brighter toward +z (the map's "up" for pbrt-v4's default orientation), and a
    # small bright sun.
    sun = (0.5, 0.3, 0.81)
    sl = math.sqrt(sum(c * c for c in sun))
    sun = tuple(c / sl for c in sun)

    def env(x, y):
        w = equal_area_square_to_sphere((x + 0.5) / 64.0, (y + 0.5) / 64.0)
        up = max(0.0, w[2])
        sky = (0.3 + 0.5 * up, 0.35 + 0.55 * up, 0.45 + 0.6 * up)
        d = sum(a * b for a, b in zip(w, sun))
        s = 40.0 if d > 0.985 else 0.0
        return tuple(c + s for c in sky)
    write_pfm(os.path.join(tmp, 'env.pfm'), 64, 64, env)
    convert(os.path.join(tmp, 'env.pfm'), os.path.join(OUT, 'env.exr'), half=True)

    # gonio.exr: a grey equal-area intensity map, brighter in a band and around one pole.
    def gonio(x, y):
        w = equal_area_square_to_sphere((x + 0.5) / 32.0, (y + 0.5) / 32.0)
        v = 0.2 + 0.8 * max(0.0, w[2]) ** 2 + (0.6 if abs(w[0]) < 0.3 else 0.0)
        return (v, v, v)
    write_pfm(os.path.join(tmp, 'gonio.pfm'), 32, 32, gonio)
    convert(os.path.join(tmp, 'gonio.pfm'), os.path.join(OUT, 'gonio.exr'), half=True)

    # slide.png: the projection light's image: coloured stripes and a dark frame.
    def slide(x, y):
        if x < 4 or y < 4 or x >= 60 or y >= 44:
            return (0.05, 0.05, 0.05)
        band = (x // 14) % 4
        cols = [(0.9, 0.9, 0.9), (0.8, 0.5, 0.3), (0.4, 0.7, 0.5), (0.5, 0.5, 0.9)]
        return tuple(srgb_encode(c) for c in cols[band])
    write_ppm(os.path.join(tmp, 'slide.ppm'), 64, 48, slide)
    convert(os.path.join(tmp, 'slide.ppm'), os.path.join(OUT, 'slide.png'))

    # alpha.png: a cut-out mask (a ring and bars), 0 or 1.
    def alpha(x, y):
        r = math.hypot(x - 31.5, y - 31.5)
        v = 1.0 if (10 < r < 22) or (x // 6) % 3 == 0 else 0.0
        return (v, v, v)
    write_ppm(os.path.join(tmp, 'alpha.ppm'), 64, 64, alpha)
    convert(os.path.join(tmp, 'alpha.ppm'), os.path.join(OUT, 'alpha.png'))


if __name__ == '__main__':
    main()
