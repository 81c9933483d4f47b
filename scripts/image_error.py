#!/usr/bin/env python3
"""Per-pixel error helpers of the adaptive-sampling benchmark (scripts/bench_adaptive.py).

    scripts/image_error.py TEST.exr REF.exr     # prints relMSE and the robust relMSE
    scripts/image_error.py --self-test          # read_exr against analytic images (exit 1: wrong)

EXR files are read through `oiiotool` (OpenImageIO's command-line tool, from the Debian package
openimageio-tools that scripts/setup.sh installs), converted to a temporary float FITS file (the
simplest float format that build writes). The metrics are
those of sampling/image_metrics.h: relMSE = mean over pixels and channels of
(v - ref)^2 / (ref^2 + 0.01); the robust relMSE leaves out the floor(0.001 N) pixels of largest
relative error (their three channels' mean), NaN and Inf first.
"""
import os
import subprocess
import sys
import tempfile

import numpy as np

EPS = 0.01          # sampling::kRelMseEpsilon
DROP = 0.001        # sampling::kRobustDropFraction


def read_fits(path):
    """A FITS image as written by oiiotool (interleaved channels: NAXIS1 = channels, NAXIS2 =
    width, NAXIS3 = height, big-endian float32) as an array (H, W, C), top row first."""
    with open(path, "rb") as f:
        raw = f.read()
    cards, pos = {}, 0
    while True:
        block = raw[pos:pos + 2880].decode("ascii", "replace")
        pos += 2880
        done = False
        for i in range(0, 2880, 80):
            card = block[i:i + 80]
            key = card[:8].strip()
            if key == "END":
                done = True
                break
            if card[8:10] == "= ":
                cards[key] = card[10:].split("/")[0].strip()
        if done:
            break
    if int(cards["BITPIX"]) != -32:
        raise ValueError(f"{path}: expected 32-bit float FITS")
    dims = [int(cards[f"NAXIS{k + 1}"]) for k in range(int(cards["NAXIS"]))]
    if len(dims) == 2:
        dims = [1] + dims
    c, w, h = dims
    # OpenImageIO 2.4's FITS writer (Debian 12's oiiotool) places row y of its bottom-up data
    # at (h - y) rows from the start instead of (h - 1 - y): the file then holds h + 1 rows, the
    # first one never written (zeros) and the image's top row last. A writer that keeps to the
    # standard holds h rows (padded to the 2880-byte block), read from the start.
    row = 4 * c * w
    if len(raw) - pos == row * (h + 1):
        pos += row
    data = np.frombuffer(raw[pos:pos + row * h], dtype=">f4").reshape(h, w, c)
    # FITS rows run bottom-up.
    return data[::-1].astype(np.float32)


def read_exr(path, channels="R,G,B"):
    """Channels of an EXR (default the beauty R, G, B) as a float32 array (H, W, C)."""
    with tempfile.TemporaryDirectory() as d:
        out = os.path.join(d, "x.fits")
        r = subprocess.run(["oiiotool", path, "--ch", channels, "-d", "float", "-o", out],
                           stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True)
        if r.returncode != 0:
            raise RuntimeError(f"{path}: oiiotool failed: {r.stderr.strip()}")
        return read_fits(out)


def pixel_rel_errors(test, ref):
    """Per-pixel relative squared error, the mean of the three channels' terms (H, W)."""
    t = test.astype(np.float64)
    r = ref.astype(np.float64)
    return ((t - r) ** 2 / (r * r + EPS)).mean(axis=2)


def rel_mse(test, ref):
    return float(pixel_rel_errors(test, ref).mean())


def robust_mean(per_pixel, drop=DROP):
    """Mean of per-pixel errors without the floor(drop * N) largest (NaN/Inf first)."""
    v = np.nan_to_num(per_pixel.ravel().astype(np.float64), nan=np.inf)
    k = int(np.floor(drop * v.size))
    if k:
        v = np.partition(v, v.size - k)[: v.size - k]
    return float(v.mean())


def rel_mse_robust(test, ref, drop=DROP):
    return robust_mean(pixel_rel_errors(test, ref), drop)


def block_mean(img, f=8):
    """Box downsampling by f (partial blocks at the edges average what they have)."""
    h, w = img.shape[:2]
    hb, wb = -(-h // f), -(-w // f)
    pad = np.zeros((hb * f, wb * f) + img.shape[2:], dtype=np.float64)
    cnt = np.zeros((hb * f, wb * f), dtype=np.float64)
    pad[:h, :w] = img
    cnt[:h, :w] = 1
    s = pad.reshape(hb, f, wb, f, *img.shape[2:]).sum(axis=(1, 3))
    c = cnt.reshape(hb, f, wb, f).sum(axis=(1, 3))
    return s / (c[..., None] if img.ndim == 3 else c)


def self_test():
    """read_exr on oiiotool's gradients, whose every pixel is known: R = x / (w - 1),
    G = y / (h - 1) (row 0 on top), B = 0.25; sizes odd and even, 3 channels and 1."""
    failures = 0
    with tempfile.TemporaryDirectory() as d:
        for w, h in ((5, 3), (8, 4), (1, 7), (19, 11)):
            exr = os.path.join(d, f"g{w}x{h}.exr")
            pattern = ("fill:topleft=0,0,0.25:topright=1,0,0.25:bottomleft=0,1,0.25:"
                       "bottomright=1,1,0.25")
            subprocess.run(["oiiotool", "--pattern", pattern, f"{w}x{h}", "3", "-d", "float",
                            "-o", exr], check=True, stdout=subprocess.DEVNULL)
            xs = np.arange(w) / max(w - 1, 1)
            ys = np.arange(h) / max(h - 1, 1)
            want = np.stack([np.broadcast_to(xs[None, :], (h, w)),
                             np.broadcast_to(ys[:, None], (h, w)),
                             np.full((h, w), 0.25)], axis=2)
            for channels, sl in (("R,G,B", slice(0, 3)), ("G", slice(1, 2))):
                got = read_exr(exr, channels)
                ok = got.shape == want[..., sl].shape and \
                    np.allclose(got, want[..., sl], atol=1e-6)
                print(f"{w}x{h} {channels}: {'ok' if ok else 'WRONG'}")
                failures += not ok
    return failures


def main():
    if sys.argv[1:] == ["--self-test"]:
        sys.exit(1 if self_test() else 0)
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    t, r = read_exr(sys.argv[1]), read_exr(sys.argv[2])
    print(f"relMSE {rel_mse(t, r):.6g}  relMSE-0.1% {rel_mse_robust(t, r):.6g}")


if __name__ == "__main__":
    main()
