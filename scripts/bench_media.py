#!/usr/bin/env python3
"""Time to equal error on scenes with participating media: Tessera against pbrt-v4, same scene
files, same machine, same thread count, side by side in one run.

    scripts/bench_media.py [--spp 1024] [--threads 2] [-o renders/bench-media]
                           [--tessera build/tessera] [--pbrt PATH] [SCENE.pbrt[@SCALE] ...]

Without scenes: every tests/fidelity/scenes/medium-*.pbrt (64x64) and, when ../shared is
present, ../shared/scenes/bitterli/staircase2 at an eighth of its resolution (128x128).

Each renderer renders each scene twice (seeds 1 and 2) at --spp samples per pixel (Tessera with
its uniform sampler, as pbrt-v4 samples), timing the whole process (parse, build, render,
write). Both are unbiased, so a render's error is its variance, which relMSE(seed 1, seed 2)
measures up to a factor 2 without a reference (each against its own converged answer: the
spectral and RGB answers differ slightly, the noise is what is compared). At 1/N convergence
the time to reach a given error is proportional to time x variance, so

    speed-up = (t_pbrt * relMSE_pbrt) / (t_tessera * relMSE_tessera)

is how many times sooner Tessera reaches any given error than pbrt-v4. Per scene it prints and
writes to OUT/summary.tsv: both times, both relMSEs, the speed-up, and the image means' ratio.
Needs numpy and oiiotool (Tessera's set-up installs both).
"""
import argparse
import math
import os
import sys

import numpy as np

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from compare_pbrt import ROOT, SHARED, read_image, relmse, run, scaled_scene  # noqa: E402


def default_scenes():
    scenes_dir = os.path.join(ROOT, 'tests', 'fidelity', 'scenes')
    out = [(os.path.join(scenes_dir, f), 1.0) for f in sorted(os.listdir(scenes_dir))
           if f.startswith('medium-') and f.endswith('.pbrt')]
    st2 = os.path.join(SHARED, 'scenes', 'bitterli', 'staircase2', 'scene-v4.pbrt')
    if os.path.exists(st2):
        out.append((st2, 0.125))
    else:
        print('bench_media: ../shared/scenes/bitterli/staircase2 not found: left out', flush=True)
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.split('\n')[0])
    ap.add_argument('scenes', nargs='*', help='SCENE.pbrt or SCENE.pbrt@SCALE')
    ap.add_argument('--spp', type=int, default=1024)
    ap.add_argument('--threads', type=int, default=2)
    ap.add_argument('-o', '--out', default=os.path.join(ROOT, 'renders', 'bench-media'))
    ap.add_argument('--tessera', default=os.path.join(ROOT, 'build', 'tessera'))
    ap.add_argument('--pbrt', default=os.path.join(SHARED, 'tools', 'pbrt-v4', 'bin', 'pbrt'))
    args = ap.parse_args()
    if not os.access(args.pbrt, os.X_OK):
        print(f'bench_media: skipped: pbrt-v4 not found at {args.pbrt}')
        return 0
    scenes = []
    for s in args.scenes:
        path, _, scale = s.partition('@')
        scenes.append((path, float(scale) if scale else 1.0))
    scenes = scenes or default_scenes()
    os.makedirs(args.out, exist_ok=True)
    hdr = ('scene', 'res', 'spp', 's tessera', 's pbrt', 'relMSE tessera', 'relMSE pbrt',
           'speed-up', 'mean ratio')
    rows = []
    print('\t'.join(hdr), flush=True)
    for scene, scale in scenes:
        stem = os.path.splitext(os.path.basename(scene))[0]
        name = stem if stem not in ('scene', 'scene-v4') else \
            os.path.basename(os.path.dirname(os.path.abspath(scene)))
        sdir = os.path.join(args.out, name)
        if scale == 1.0:  # as it is (the fidelity scenes take their Film from an Include)
            path = os.path.abspath(scene)
            os.makedirs(sdir, exist_ok=True)
            w = h = '-'
        else:
            path, w, h = scaled_scene(scene, os.path.join(sdir, 'mirror'), scale)
        cwd = os.path.dirname(path)
        t, img = {}, {}
        for seed in (1, 2):
            tp = os.path.join(sdir, f'tessera.seed{seed}.exr')
            pp = os.path.join(sdir, f'pbrt.seed{seed}.exr')
            t[('T', seed)] = run([args.tessera, 'render', path, '-o', tp, '--spp', str(args.spp),
                                  '--sampler', 'uniform', '--seed', str(seed), '--threads',
                                  str(args.threads), '--no-png', '-q'], cwd)[0]
            t[('P', seed)] = run([args.pbrt, '--spp', str(args.spp), '--seed', str(seed),
                                  '--nthreads', str(args.threads), '--quiet', '--outfile', pp,
                                  path], cwd)[0]
            img[('T', seed)] = read_image(tp)
            img[('P', seed)] = read_image(pp)
        tt = (t[('T', 1)] + t[('T', 2)]) / 2
        tp_ = (t[('P', 1)] + t[('P', 2)]) / 2
        rt = relmse(img[('T', 1)], img[('T', 2)])
        rp = relmse(img[('P', 1)], img[('P', 2)])
        speed = (tp_ * rp) / (tt * rt) if tt * rt > 0 else math.nan
        mt = (img[('T', 1)] + img[('T', 2)]).mean() / 2
        mp = (img[('P', 1)] + img[('P', 2)]).mean() / 2
        row = (name, f'{w}x{h}', str(args.spp), f'{tt:.2f}', f'{tp_:.2f}', f'{rt:.4g}',
               f'{rp:.4g}', f'{speed:.2f}', f'{mt / mp:.4f}')
        rows.append(row)
        print('\t'.join(row), flush=True)
    speeds = [float(r[7]) for r in rows if r[7] != 'nan']
    if speeds:
        print(f'speed-up: median {np.median(speeds):.2f}, min {min(speeds):.2f}, '
              f'max {max(speeds):.2f} over {len(speeds)} scenes', flush=True)
    with open(os.path.join(args.out, 'summary.tsv'), 'w') as f:
        f.write('\t'.join(hdr) + '\n')
        for r in rows:
            f.write('\t'.join(r) + '\n')
    return 0


if __name__ == '__main__':
    sys.exit(main())
