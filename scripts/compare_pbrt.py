#!/usr/bin/env python3
"""Renders pbrt-v4 scenes with Tessera and with pbrt-v4 itself, side by side, and reports how
far apart they are next to how far apart two seeds of each renderer are (the noise).

    scripts/compare_pbrt.py [--scale 0.25] [--spp 256] [--threads 2] [-o renders/pbrt-compare]
                            [--tessera build/tessera] [--pbrt PATH] [SCENE.pbrt ...]

Without scenes it takes every scene-v4.pbrt under ../shared/scenes/bitterli (and exits 0
with a message when ../shared is absent). Each scene is rendered at --scale of its Film
resolution (a copy of the scene file with the resolution changed, in a mirror folder whose
other entries link to the originals, so that relative paths resolve alike for both
renderers), with --spp samples per pixel, twice per renderer (seeds 1 and 2). A third run of
each at 1 spp and 1/8 of that resolution measures the time to load the scene (parse, meshes,
textures, BVH) and the peak memory (resident set) of the process.

Per scene it prints and writes to OUT/summary.tsv (and summary.md):
  mean ratio    Tessera's image mean over pbrt-v4's, per channel (both averaged over seeds);
  worst block   the 8x8-pixel block whose Tessera/pbrt-v4 ratio is farthest from 1, among
                those brighter than 5% of the mean whose noise (estimated from the two seeds
                of each renderer) is below 2% of their value ("usable"), with |z|, its
                difference in units of that noise;
  bad blocks    the fraction of block-channels with |z| > 5 and a difference above 2%;
  relMSE        Tessera seed 1 against pbrt-v4 seed 1, beside Tessera's two seeds and pbrt-v4's
                two seeds (relMSE = mean of (a - b)^2 / (b^2 + 0.01), pbrt's definition);
  load s, MB    load time (s) and peak memory (MiB) of each renderer.
If the renderers agree, relMSE(T1, P1) is about (relMSE(T1, T2) + relMSE(P1, P2)) / 2.

Needs numpy (python3-numpy) and oiiotool (openimageio-tools), which Tessera's set-up installs.
"""
import argparse
import os
import re
import shutil
import subprocess
import sys
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SHARED = os.path.join(os.path.dirname(ROOT), 'shared')


def read_image(path):
    """Linear float RGB (h, w, 3) of an EXR, through oiiotool's FITS writer (numpy reads it)."""
    fits = path + '.fits'
    subprocess.run(['oiiotool', path, '--ch', 'R,G,B', '-d', 'float', '-o', fits], check=True,
                   capture_output=True)
    with open(fits, 'rb') as f:
        data = f.read()
    os.remove(fits)
    cards, off = {}, 0
    while True:
        block = data[off:off + 2880].decode('ascii')
        off += 2880
        for i in range(0, 2880, 80):
            card = block[i:i + 80]
            if card.startswith('END'):
                break
            if '=' in card[:10]:
                cards[card[:8].strip()] = card[10:].split('/')[0].strip()
        else:
            continue
        break
    n1, n2, n3 = int(cards['NAXIS1']), int(cards['NAXIS2']), int(cards['NAXIS3'])
    assert int(cards['BITPIX']) == -32 and n1 == 3
    return np.frombuffer(data, dtype='>f4', count=n1 * n2 * n3, offset=off).reshape(n3, n2, n1)


def scaled_scene(scene, out_dir, scale):
    """A copy of `scene` in a mirror of its folder with the Film resolution scaled."""
    src_dir = os.path.dirname(os.path.abspath(scene))
    os.makedirs(out_dir, exist_ok=True)
    for e in os.listdir(src_dir):
        dst = os.path.join(out_dir, e)
        if not os.path.lexists(dst):
            os.symlink(os.path.join(src_dir, e), dst)
    text = open(scene).read()
    res = {}

    def repl(m):
        v = max(8, int(round(int(m.group(3)) * scale)))
        res[m.group(2)] = v
        return f'{m.group(1)}{v}'
    # Line by line, leaving comments alone (scenes keep old resolutions in comments).
    text = '\n'.join(line if line.lstrip().startswith('#') else
                     re.sub(r'("integer\s+([xy])resolution"\s*\[?\s*)(\d+)', repl, line)
                     for line in text.split('\n'))
    if len(res) != 2:
        raise SystemExit(f'compare_pbrt: {scene}: no Film xresolution/yresolution to scale')
    path = os.path.join(out_dir, 'compare-' + os.path.basename(scene))
    if os.path.lexists(path):
        os.remove(path)
    with open(path, 'w') as f:
        f.write(text)
    return path, res['x'], res['y']


def run(cmd, cwd):
    """Runs cmd; returns (seconds, peak resident MiB). Raises on failure."""
    t0 = time.time()
    p = subprocess.Popen(cmd, cwd=cwd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    out = p.stdout.read()
    _, status, ru = os.wait4(p.pid, 0)
    p.returncode = os.waitstatus_to_exitcode(status)
    if p.returncode != 0:
        raise RuntimeError(f'{" ".join(cmd)} exited {p.returncode}:\n{out.decode(errors="replace")[-2000:]}')
    return time.time() - t0, ru.ru_maxrss / 1024.0


def relmse(a, b):
    return float(np.mean((a - b) ** 2 / (b * b + 0.01)))


def blocks(img, n=8):
    h, w, _ = img.shape
    hb, wb = h // n, w // n
    return img[:hb * n, :wb * n].reshape(hb, n, wb, n, 3).mean(axis=(1, 3))


def compare(t1, t2, p1, p2):
    t, p = (t1 + t2) / 2, (p1 + p2) / 2
    mean_ratio = t.mean(axis=(0, 1)) / np.maximum(p.mean(axis=(0, 1)), 1e-12)
    # Per-pixel variance of each two-seed mean, summed into blocks.
    var = ((t1 - t2) ** 2 + (p1 - p2) ** 2) / 4
    bt, bp = blocks(t), blocks(p)
    bvar = blocks(var) / 64.0  # mean of 64 independent pixels: variance / 64
    sigma = np.sqrt(np.maximum(bvar, 1e-30))
    d = bt - bp
    z = np.abs(d) / sigma
    # The worst ratio among the blocks whose ratio means something: brighter than 5% of the
    # image mean and with a noise below 2% of their value.
    usable = (bp > 0.05 * p.mean(axis=(0, 1))) & (sigma < 0.02 * np.abs(bp))
    ratio = np.where(usable, bt / np.maximum(bp, 1e-12), 1.0)
    k = np.unravel_index(np.argmax(np.abs(ratio - 1)), ratio.shape)
    bad = (z > 5) & (np.abs(d) > 0.02 * np.abs(bp) + 1e-3 * p.mean(axis=(0, 1)))
    return {
        'mean_ratio': mean_ratio, 'worst_block': float(ratio[k]), 'worst_block_z': float(z[k]),
        'usable_blocks': float(usable.mean()), 'bad_blocks': float(bad.mean()),
        'relmse_tp': relmse(t1, p1), 'relmse_tt': relmse(t1, t2), 'relmse_pp': relmse(p1, p2),
    }


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('scenes', nargs='*')
    ap.add_argument('--scale', type=float, default=0.25)
    ap.add_argument('--spp', type=int, default=256)
    ap.add_argument('--threads', type=int, default=2)
    ap.add_argument('-o', '--out', default=os.path.join(ROOT, 'renders', 'pbrt-compare'))
    ap.add_argument('--tessera', default=os.path.join(ROOT, 'build', 'tessera'))
    ap.add_argument('--pbrt', default=os.path.join(SHARED, 'tools', 'pbrt-v4', 'bin', 'pbrt'))
    ap.add_argument('--keep-going', action='store_true', help='continue after a failed scene')
    ap.add_argument('--reuse-pbrt', action='store_true',
                    help='keep pbrt-v4 images already in OUT (same scene, scale and spp) instead of '
                         'rendering them again')
    args = ap.parse_args()
    scenes = args.scenes
    if not scenes:
        base = os.path.join(SHARED, 'scenes', 'bitterli')
        if not os.path.isdir(base):
            print('compare_pbrt: skipped: ../shared/scenes/bitterli not found (a user\'s clone has none)')
            return 0
        scenes = sorted(os.path.join(base, d, 'scene-v4.pbrt') for d in os.listdir(base)
                        if os.path.exists(os.path.join(base, d, 'scene-v4.pbrt')))
    if not os.access(args.pbrt, os.X_OK):
        print(f'compare_pbrt: skipped: pbrt-v4 not found at {args.pbrt}')
        return 0
    os.makedirs(args.out, exist_ok=True)
    rows, failed = [], 0
    hdr = ('scene', 'res', 'spp', 'mean R', 'mean G', 'mean B', 'worst block', '|z|',
           'usable', 'bad blocks', 'relMSE T-P', 'relMSE T-T', 'relMSE P-P', 'load s T', 'load s P',
           'MiB T', 'MiB P', 'render s T', 'render s P')
    print('\t'.join(hdr), flush=True)
    for scene in scenes:
        # The scene's folder names it (a "pbrt-v4" folder: its parent), and the file's stem
        # too unless it is the folder's scene.pbrt / scene-v4.pbrt.
        name = os.path.basename(os.path.dirname(os.path.abspath(scene)))
        if name == 'pbrt-v4':
            name = os.path.basename(os.path.dirname(os.path.dirname(os.path.abspath(scene))))
        stem = os.path.splitext(os.path.basename(scene))[0]
        if stem not in ('scene', 'scene-v4'):
            name += '-' + stem
        sdir = os.path.join(args.out, name)
        try:
            path, w, h = scaled_scene(scene, os.path.join(sdir, 'mirror'), args.scale)
            cwd = os.path.dirname(path)
            imgs, secs = {}, {}
            for seed in (1, 2):
                tp = os.path.join(sdir, f'tessera.seed{seed}.exr')
                pp = os.path.join(sdir, f'pbrt.seed{seed}.exr')
                secs[('T', seed)] = run([args.tessera, 'render', path, '-o', tp, '--spp', str(args.spp),
                                         '--sampler', 'uniform', '--seed', str(seed), '--threads',
                                         str(args.threads), '--no-png', '-q'], cwd)[0]
                stamp = pp + '.settings'
                settings = f'{os.path.abspath(scene)} {os.path.getmtime(scene)} {args.scale} {args.spp}'
                if (args.reuse_pbrt and os.path.exists(pp) and os.path.exists(stamp)
                        and open(stamp).read() == settings):
                    secs[('P', seed)] = float('nan')
                else:
                    secs[('P', seed)] = run([args.pbrt, '--spp', str(args.spp), '--seed', str(seed),
                                             '--nthreads', str(args.threads), '--quiet', '--outfile', pp,
                                             path], cwd)[0]
                    with open(stamp, 'w') as f:
                        f.write(settings)
                imgs[('T', seed)], imgs[('P', seed)] = read_image(tp), read_image(pp)
            # Load time and memory: 1 spp at 1/8 of the resolution (the render itself is then
            # a small part of the run).
            lw, lh = max(8, w // 8), max(8, h // 8)
            lt = run([args.tessera, 'render', path, '-o', os.path.join(sdir, 'load.exr'), '--spp', '1',
                      '--resolution', f'{lw}x{lh}', '--threads', str(args.threads), '--no-png', '-q'], cwd)
            small, _, _ = scaled_scene(scene, os.path.join(sdir, 'mirror'), args.scale / 8)
            lp = run([args.pbrt, '--spp', '1', '--nthreads', str(args.threads), '--quiet', '--outfile',
                      os.path.join(sdir, 'load-pbrt.exr'), small], cwd)
            scaled_scene(scene, os.path.join(sdir, 'mirror'), args.scale)
            c = compare(imgs[('T', 1)], imgs[('T', 2)], imgs[('P', 1)], imgs[('P', 2)])
            row = (name, f'{w}x{h}', str(args.spp), *(f'{v:.4f}' for v in c['mean_ratio']),
                   f'{c["worst_block"]:.3f}', f'{c["worst_block_z"]:.1f}',
                   f'{c["usable_blocks"]:.2f}', f'{c["bad_blocks"]:.3f}',
                   f'{c["relmse_tp"]:.4g}', f'{c["relmse_tt"]:.4g}', f'{c["relmse_pp"]:.4g}',
                   f'{lt[0]:.2f}', f'{lp[0]:.2f}', f'{lt[1]:.0f}', f'{lp[1]:.0f}',
                   f'{(secs[("T", 1)] + secs[("T", 2)]) / 2:.1f}', f'{(secs[("P", 1)] + secs[("P", 2)]) / 2:.1f}')
        except (RuntimeError, SystemExit, OSError, subprocess.CalledProcessError) as e:
            failed += 1
            print(f'compare_pbrt: {name}: {e}', file=sys.stderr, flush=True)
            row = (name, 'failed') + ('',) * (len(hdr) - 2)
            if not args.keep_going:
                rows.append(row)
                break
        rows.append(row)
        print('\t'.join(row), flush=True)
    with open(os.path.join(args.out, 'summary.tsv'), 'w') as f:
        f.write('\t'.join(hdr) + '\n' + ''.join('\t'.join(r) + '\n' for r in rows))
    with open(os.path.join(args.out, 'summary.md'), 'w') as f:
        f.write('| ' + ' | '.join(hdr) + ' |\n|' + '---|' * len(hdr) + '\n')
        f.write(''.join('| ' + ' | '.join(r) + ' |\n' for r in rows))
    return 1 if failed else 0


if __name__ == '__main__':
    sys.exit(main())
