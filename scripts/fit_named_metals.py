#!/usr/bin/env python3
"""Fits the RGB conductor constants Tessera uses for pbrt-v4's named metal spectra
("metal-Au-eta", "metal-Au-k", ...) to pbrt-v4's own spectral rendering of them.

    scripts/fit_named_metals.py [--pbrt PATH] [--res 128] [--spp 256]

pbrt-v4 renders each metal as a smooth unit sphere under a uniform white sky ("rgb L [1 1 1]",
which is D65 and maps to sRGB white) through an orthographic camera: every pixel on the
sphere shows the spectral Fresnel reflectance F(cos theta) of the metal, seen through the
colour matching functions, at the angle its position gives (cos theta = sqrt(1 - r^2) at
distance r from the centre). For each of R, G and B the script then finds the complex index
eta + i k whose Fresnel curve (pbrt-v4's FrComplex) is closest to pbrt-v4's over the disk
(least squares over the pixels with r < 0.95, each weighted alike), and prints the table for
renderer/util/spectra.cpp (kMetals) with the residuals.

An RGB renderer cannot reproduce a spectral Fresnel curve exactly; the fit makes the
reflectance Tessera gives a metal the one pbrt-v4 shows at every angle, within the printed
residual (a band average of eta and k, the usual shortcut, is 1-3% off at normal incidence).
Needs numpy and oiiotool (Tessera's set-up installs both).
"""
import argparse
import os
import subprocess
import sys
import tempfile

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from compare_pbrt import read_image  # noqa: E402

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
METALS = ['Ag', 'Al', 'Au', 'Cu', 'CuZn', 'MgO', 'TiO2']


def fr_complex(cos_i, eta, k):
    """Unpolarised Fresnel reflectance of a conductor (pbrt-v4 FrComplex)."""
    n = eta + 1j * k
    cos_i = np.clip(cos_i, 0, 1)
    sin2_i = 1 - cos_i ** 2
    sin2_t = sin2_i / n ** 2
    cos_t = np.sqrt(1 - sin2_t)
    r_parl = (n * cos_i - cos_t) / (n * cos_i + cos_t)
    r_perp = (cos_i - n * cos_t) / (cos_i + n * cos_t)
    return (np.abs(r_parl) ** 2 + np.abs(r_perp) ** 2) / 2


def fit_channel(cos_t, f, dielectric):
    """(eta, k) minimising sum (FrComplex - f)^2 over a log grid refined four times around its
    best point. Metals keep k in [0.3, 12] (the physical branch: a near-zero eta with k = 0
    also reflects ~95% at normal incidence, but not at other angles inside a coat);
    dielectrics (MgO, TiO2: k is 0 in pbrt-v4's data up to noise) fit eta alone."""
    eta_lo, eta_hi = np.log(0.02), np.log(6.0)
    k_lo, k_hi = np.log(0.3), np.log(12.0)
    best = None
    for _ in range(5):
        etas = np.exp(np.linspace(eta_lo, eta_hi, 41))
        ks = np.array([0.0]) if dielectric else np.exp(np.linspace(k_lo, k_hi, 41))
        E, K = np.meshgrid(etas, ks, indexing='ij')
        err = ((fr_complex(cos_t[None, None, :], E[..., None], K[..., None]) - f[None, None, :]) ** 2).mean(axis=2)
        i, j = np.unravel_index(np.argmin(err), err.shape)
        best = (float(E[i, j]), float(K[i, j]), float(np.sqrt(err[i, j])))
        de = (eta_hi - eta_lo) / 40 * 2
        eta_lo, eta_hi = np.log(best[0]) - de, np.log(best[0]) + de
        if not dielectric:
            dk = (k_hi - k_lo) / 40 * 2
            k_lo, k_hi = max(np.log(0.3), np.log(best[1]) - dk), np.log(best[1]) + dk
    return best


def rms(cos_t, f, eta, k):
    return float(np.sqrt(((fr_complex(cos_t, eta, k) - f) ** 2).mean()))


# The band averages Tessera used before (renderer/util/spectra.cpp's previous kMetals), to print
# how much the fit gains.
BAND_AVERAGES = {
    'Ag': ((0.1363, 0.1251, 0.1501), (4.1272, 3.3368, 2.4620)),
    'Al': ((1.4869, 0.9672, 0.6217), (7.7954, 6.6799, 5.4706)),
    'Au': ((0.1761, 0.4118, 1.4180), (3.3020, 2.5955, 1.8807)),
    'Cu': ((0.2427, 0.8757, 1.1624), (3.6046, 2.6447, 2.3807)),
    'CuZn': ((0.444, 0.527, 1.094), (3.695, 2.765, 1.829)),
    'MgO': ((1.7338, 1.7407, 1.7529), (0.0, 0.0, 0.0)),
    'TiO2': ((2.8610, 2.9568, 3.1735), (0.0, 0.0, 0.0022)),
}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('--pbrt', default=os.path.join(os.path.dirname(ROOT), 'shared', 'tools', 'pbrt-v4', 'bin', 'pbrt'))
    ap.add_argument('--res', type=int, default=128)
    ap.add_argument('--spp', type=int, default=256)
    ap.add_argument('--threads', type=int, default=2)
    args = ap.parse_args()
    tmp = tempfile.mkdtemp()
    rows = []
    for m in METALS:
        scene = os.path.join(tmp, f'{m}.pbrt')
        with open(scene, 'w') as f:
            f.write(f'''LookAt 0 0 -5  0 0 0  0 1 0
Camera "orthographic" "float screenwindow" [ -1 1 -1 1 ]
Film "rgb" "integer xresolution" [ {args.res} ] "integer yresolution" [ {args.res} ]
PixelFilter "box"
Integrator "path" "integer maxdepth" [ 1 ]
WorldBegin
LightSource "infinite" "rgb L" [ 1 1 1 ]
Material "conductor" "spectrum eta" [ "metal-{m}-eta" ] "spectrum k" [ "metal-{m}-k" ]
Shape "sphere" "float radius" [ 1 ]
''')
        out = os.path.join(tmp, f'{m}.exr')
        subprocess.run([args.pbrt, '--spp', str(args.spp), '--seed', '1', '--nthreads', str(args.threads),
                        '--quiet', '--outfile', out, scene], check=True)
        img = read_image(out)
        c = (np.arange(args.res) + 0.5) / args.res * 2 - 1
        X, Y = np.meshgrid(c, c)
        r2 = X ** 2 + Y ** 2
        # Every second pixel of every second row inside r < 0.95 (about 2800 of them).
        mask = (r2 < 0.95 ** 2) & (np.add.outer(np.arange(args.res), np.arange(args.res)) % 2 == 0)
        mask[1::2, :] = False
        cos_t = np.sqrt(1 - r2[mask])
        dielectric = m in ('MgO', 'TiO2')
        fits = [fit_channel(cos_t, img[..., ch][mask], dielectric) for ch in range(3)]
        rows.append((m, fits))
        be, bk = BAND_AVERAGES[m]
        print(f'{m}: ' + '  '.join(
            f'{"RGB"[ch]} eta {e:.4f} k {k:.4f} rms {r:.4f} (band average {rms(cos_t, img[..., ch][mask], be[ch], bk[ch]):.4f})'
            for ch, (e, k, r) in enumerate(fits)), flush=True)
    print('\nconstexpr MetalEntry kMetals[] = {')
    for m, fits in rows:
        eta = ', '.join(f'{e:.4f}f' for e, _, _ in fits)
        k = ', '.join(f'{k:.4f}f' for _, k, _ in fits)
        print(f'    {{"{m}", {{{eta}}}, {{{k}}}}},')
    print('};')
    return 0


if __name__ == '__main__':
    sys.exit(main())
